/* SPDX-License-Identifier: MIT */
/*
 * The client's blocking calls: each starts a request (or the session, or
 * the close) and runs the client's loop until it is done or timed out, so
 * that Class 1 traffic keeps flowing meanwhile. They need the transport's
 * wait.
 */
#include <stdint.h>
#include <string.h>

#include "client_internal.h"

/* ---- synchronous explicit messaging ----------------------------------------- */

dr_status_t dr_client_connect_sync(dr_client_t *c)
{
    if (c->state == S_READY)
        return DR_OK;
    if (!drc_can_wait(c) || c->closing != CL_NONE)
        return c->closing != CL_NONE ? DR_ESESSION : DR_EINVAL;
    dr_status_t st = drc_begin_session(c);
    if (st != DR_OK)
        return st;
    uint64_t deadline = now_us(c) + 2u * (uint64_t)c->cfg.timeout_ms * 1000u;
    while (c->state == S_CONNECTING || c->state == S_REGISTERING) {
        if (now_us(c) >= deadline) {
            drc_session_fail(c, c->state == S_CONNECTING ? DR_ENOANSWER : DR_ENOREGISTER);
            break;
        }
        drc_wait_and_process(c, deadline);
    }
    return c->state == S_READY ? DR_OK : c->sess_error;
}

/* Run the loop until request r is done; collect and free it. */
static dr_status_t wait_req(dr_client_t *c, req_t *r, size_t *rsp_len)
{
    while (!r->done)
        drc_wait_and_process(c, r->deadline);
    dr_status_t st = r->status;
    if (rsp_len != NULL)
        *rsp_len = r->rsp_len;
    r->active = false;
    return st;
}

dr_status_t dr_client_call_sync(dr_client_t *c, uint8_t service,
                                const uint8_t *path, size_t path_len,
                                const uint8_t *data, size_t data_len,
                                uint8_t *rsp, size_t cap, size_t *rsp_len)
{
    req_t *r;
    if (rsp_len != NULL)
        *rsp_len = 0;
    dr_status_t st = drc_start_call(c, R_USER, service, path, path_len, data, data_len, &r);
    if (st != DR_OK)
        return st;
    r->rsp = rsp; /* replies are only read by wait_req, after this */
    r->cap = cap;
    return wait_req(c, r, rsp_len);
}

dr_status_t dr_client_get_attr_sync(dr_client_t *c, uint16_t cls, uint16_t inst,
                                    uint16_t attr, uint8_t *buf, size_t cap,
                                    size_t *len)
{
    uint8_t path[12];
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, cls, inst, attr);
    c->step = "get";
    return dr_client_call_sync(c, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, path, w.len,
                               NULL, 0, buf, cap, len);
}

dr_status_t dr_client_set_attr_sync(dr_client_t *c, uint16_t cls, uint16_t inst,
                                    uint16_t attr, const uint8_t *data, size_t len)
{
    uint8_t path[12];
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, cls, inst, attr);
    c->step = "set";
    return dr_client_call_sync(c, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, path, w.len,
                               data, len, NULL, 0, NULL);
}

dr_status_t dr_client_read_asm_sync(dr_client_t *c, dr_asm_t a, uint8_t *buf,
                                    size_t len)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    if (info == NULL || len != info->size)
        return info == NULL ? DR_EINVAL : DR_ELENGTH;
    uint8_t tmp[DR_ENCAP_MAX_LEN];
    size_t got = 0;
    dr_status_t st = dr_client_get_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, c->cfg.instance[a],
                                             DR_CIP_ASM_ATTR_DATA, tmp, sizeof tmp, &got);
    if (st != DR_OK)
        return st;
    if (got != info->size)
        return DR_ELENGTH; /* not what the specification says: refuse it */
    memcpy(buf, tmp, got);
    return DR_OK;
}

dr_status_t dr_client_write_asm_sync(dr_client_t *c, dr_asm_t a,
                                     const uint8_t *buf, size_t len)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    if (info == NULL || len != info->size)
        return info == NULL ? DR_EINVAL : DR_ELENGTH;
    return dr_client_set_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, c->cfg.instance[a],
                                   DR_CIP_ASM_ATTR_DATA, buf, len);
}

dr_status_t dr_client_read_asm_size_sync(dr_client_t *c, uint16_t instance, uint16_t *size)
{
    uint8_t tmp[8];
    size_t got = 0;
    dr_status_t st = dr_client_get_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, instance,
                                             DR_CIP_ASM_ATTR_SIZE, tmp, sizeof tmp, &got);
    if (st != DR_OK)
        return st;
    if (got != 2)
        return DR_EMALFORMED;
    *size = dr_get_le16(tmp);
    return DR_OK;
}

dr_status_t dr_client_read_identity_sync(dr_client_t *c, dr_identity_t *id)
{
    uint8_t path[8], tmp[128];
    size_t got = 0;
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, DR_CIP_CLASS_IDENTITY, 1, -1);
    c->step = "identity";
    dr_status_t st = dr_client_call_sync(c, DR_CIP_SVC_GET_ATTRIBUTES_ALL, path, w.len,
                                         NULL, 0, tmp, sizeof tmp, &got);
    if (st != DR_OK)
        return st;
    return dr_identity_parse_all(tmp, got, id);
}

dr_status_t dr_client_list_identity_sync(dr_client_t *c, dr_identity_t *id)
{
    if (c->tcp < 0 || c->state == S_CONNECTING || c->closing != CL_NONE)
        return DR_ESESSION;
    if (!drc_can_wait(c))
        return DR_EINVAL;
    req_t *r = drc_req_alloc(c, R_LIST_IDENTITY);
    if (r == NULL)
        return DR_EFULL;
    uint8_t tmp[DR_ENCAP_MAX_LEN];
    r->rsp = tmp;
    r->cap = sizeof tmp;
    c->step = "list identity";
    dr_status_t st = drc_send_encap(c, DR_ENCAP_LIST_IDENTITY, r->context, NULL, 0);
    deadline_moved(c);
    if (st != DR_OK) {
        r->active = false;
        return st;
    }
    size_t got = 0;
    st = wait_req(c, r, &got);
    if (st != DR_OK)
        return st;
    return dr_list_identity_parse(tmp, got, id);
}

/* ---- close ------------------------------------------------------------------- */

void dr_client_close_sync(dr_client_t *c)
{
    dr_client_close_start(c);
    while (c->closing != CL_NONE && drc_can_wait(c))
        drc_wait_and_process(c, c->close_deadline);
    if (c->closing != CL_NONE)
        drc_close_finish(c); /* no wait in the transport: what is sent is sent */
}
