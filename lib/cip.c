/* SPDX-License-Identifier: MIT */
/*
 * EtherNet/IP encapsulation, CPF and CIP messages: builders and parsers.
 * Every read goes through the bounded reader below; a read past the end
 * sets `short_` and yields zeros, and each parser checks it before use.
 */
#include <string.h>

#include "cip_internal.h"
#include "drgate/codec.h" /* dr_get_le16/32, dr_put_le16/32 */

/* ---- bounded reader ------------------------------------------------------ */

typedef struct {
    const uint8_t *p;
    size_t len, pos;
    bool short_;
} rd_t;

static void rd_init(rd_t *r, const uint8_t *p, size_t len)
{
    r->p = p;
    r->len = len;
    r->pos = 0;
    r->short_ = false;
}

static size_t rd_left(const rd_t *r)
{
    return r->len - r->pos;
}

static const uint8_t *rd_take(rd_t *r, size_t n)
{
    if (r->short_ || rd_left(r) < n) {
        r->short_ = true;
        return NULL;
    }
    const uint8_t *p = r->p + r->pos;
    r->pos += n;
    return p;
}

static uint8_t rd_u8(rd_t *r)
{
    const uint8_t *p = rd_take(r, 1);
    return p ? p[0] : 0;
}

static uint16_t rd_u16(rd_t *r)
{
    const uint8_t *p = rd_take(r, 2);
    return p ? dr_get_le16(p) : 0;
}

static uint32_t rd_u32(rd_t *r)
{
    const uint8_t *p = rd_take(r, 4);
    return p ? dr_get_le32(p) : 0;
}

static uint16_t rd_u16_be(rd_t *r)
{
    const uint8_t *p = rd_take(r, 2);
    return p ? (uint16_t)(p[0] << 8 | p[1]) : 0;
}

static uint32_t rd_u32_be(rd_t *r)
{
    const uint8_t *p = rd_take(r, 4);
    return p ? (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 |
                   (uint32_t)p[2] << 8 | p[3]
             : 0;
}

/* The whole input consumed, nothing missing. */
static dr_status_t rd_done(const rd_t *r)
{
    if (r->short_)
        return DR_ESHORT;
    return rd_left(r) == 0 ? DR_OK : DR_ELONG;
}

/* ---- bounded writer ------------------------------------------------------ */

void dr_wr_init(dr_wr_t *w, uint8_t *buf, size_t cap)
{
    w->buf = buf;
    w->cap = cap;
    w->len = 0;
    w->overflow = false;
}

uint8_t *dr_wr_reserve(dr_wr_t *w, size_t n)
{
    if (w->overflow || w->cap - w->len < n) {
        w->overflow = true;
        return NULL;
    }
    uint8_t *p = w->buf + w->len;
    w->len += n;
    return p;
}

void dr_wr_u8(dr_wr_t *w, uint8_t v)
{
    uint8_t *p = dr_wr_reserve(w, 1);
    if (p)
        p[0] = v;
}

void dr_wr_u16(dr_wr_t *w, uint16_t v)
{
    uint8_t *p = dr_wr_reserve(w, 2);
    if (p)
        dr_put_le16(p, v);
}

void dr_wr_u32(dr_wr_t *w, uint32_t v)
{
    uint8_t *p = dr_wr_reserve(w, 4);
    if (p)
        dr_put_le32(p, v);
}

void dr_wr_u16_be(dr_wr_t *w, uint16_t v)
{
    uint8_t *p = dr_wr_reserve(w, 2);
    if (p) {
        p[0] = (uint8_t)(v >> 8);
        p[1] = (uint8_t)v;
    }
}

void dr_wr_u32_be(dr_wr_t *w, uint32_t v)
{
    dr_wr_u16_be(w, (uint16_t)(v >> 16));
    dr_wr_u16_be(w, (uint16_t)v);
}

void dr_wr_bytes(dr_wr_t *w, const void *src, size_t n)
{
    uint8_t *p = dr_wr_reserve(w, n);
    if (p && n > 0)
        memcpy(p, src, n);
}

/* A path size in words (USINT). A longer path does not fit the field: a
 * wrapped count would put a frame on the wire whose lengths lie, so it
 * counts as an overflow like a full buffer. */
static void wr_path_words(dr_wr_t *w, size_t path_len)
{
    if (path_len > 2u * 0xFFu)
        w->overflow = true;
    else
        dr_wr_u8(w, (uint8_t)((path_len + 1u) / 2u));
}

/* ---- encapsulation --------------------------------------------------------- */

dr_status_t dr_encap_frame_len(const uint8_t *buf, size_t len, size_t *total)
{
    if (len < DR_ENCAP_HEADER_LEN)
        return DR_EAGAIN;
    size_t n = DR_ENCAP_HEADER_LEN + dr_get_le16(buf + 2);
    if (n > DR_ENCAP_MAX_LEN)
        return DR_ELONG;
    *total = n;
    return DR_OK;
}

dr_status_t dr_encap_parse(const uint8_t *buf, size_t len, dr_encap_t *hdr,
                           const uint8_t **body)
{
    rd_t r;
    rd_init(&r, buf, len);
    hdr->command = rd_u16(&r);
    hdr->length = rd_u16(&r);
    hdr->session = rd_u32(&r);
    hdr->status = rd_u32(&r);
    const uint8_t *ctx = rd_take(&r, 8);
    if (ctx)
        memcpy(hdr->context, ctx, 8);
    hdr->options = rd_u32(&r);
    if (r.short_)
        return DR_ESHORT;
    *body = rd_take(&r, hdr->length);
    return rd_done(&r);
}

dr_status_t dr_encap_write(uint8_t *buf, size_t cap, const dr_encap_t *hdr,
                           size_t body_len)
{
    if (body_len > 0xFFFFu || cap < DR_ENCAP_HEADER_LEN ||
        cap - DR_ENCAP_HEADER_LEN < body_len)
        return DR_ENOSPACE;
    dr_put_le16(buf, hdr->command);
    dr_put_le16(buf + 2, (uint16_t)body_len);
    dr_put_le32(buf + 4, hdr->session);
    dr_put_le32(buf + 8, hdr->status);
    memcpy(buf + 12, hdr->context, 8);
    dr_put_le32(buf + 20, hdr->options);
    return DR_OK;
}

/* ---- CPF ----------------------------------------------------------------- */

/* The declared items, each length-checked; what follows them is left in
 * the reader for the caller to judge. */
static dr_status_t cpf_items(rd_t *r, dr_cpf_t *cpf)
{
    cpf->count = rd_u16(r);
    if (r->short_)
        return DR_ESHORT;
    if (cpf->count > DR_CPF_MAX_ITEMS)
        return DR_EMALFORMED;
    for (unsigned i = 0; i < cpf->count; i++) {
        cpf->item[i].type = rd_u16(r);
        cpf->item[i].length = rd_u16(r);
        cpf->item[i].data = rd_take(r, cpf->item[i].length);
        if (r->short_)
            return DR_ESHORT;
    }
    return DR_OK;
}

dr_status_t dr_cpf_parse(const uint8_t *buf, size_t len, dr_cpf_t *cpf)
{
    rd_t r;
    rd_init(&r, buf, len);
    dr_status_t st = cpf_items(&r, cpf);
    return st != DR_OK ? st : rd_done(&r);
}

dr_status_t dr_cpf_parse_reply(const uint8_t *buf, size_t len, dr_cpf_t *cpf,
                               size_t *extra)
{
    rd_t r;
    rd_init(&r, buf, len);
    dr_status_t st = cpf_items(&r, cpf);
    *extra = st == DR_OK ? rd_left(&r) : 0;
    return st;
}

const dr_cpf_item_t *dr_cpf_find(const dr_cpf_t *cpf, uint16_t type)
{
    for (unsigned i = 0; i < cpf->count; i++)
        if (cpf->item[i].type == type)
            return &cpf->item[i];
    return NULL;
}

dr_status_t dr_cpf_sockaddr_parse(const dr_cpf_item_t *item, dr_sockaddr_t *out)
{
    rd_t r;
    rd_init(&r, item->data, item->length);
    uint16_t family = rd_u16_be(&r);
    out->port = rd_u16_be(&r);
    out->addr = rd_u32_be(&r);
    (void)rd_take(&r, 8); /* sin_zero */
    dr_status_t st = rd_done(&r);
    if (st == DR_OK && family != 2) /* AF_INET on the wire */
        return DR_EMALFORMED;
    return st;
}

void dr_cpf_begin(dr_wr_t *w, uint16_t item_count)
{
    dr_wr_u16(w, item_count);
}

size_t dr_cpf_item_begin(dr_wr_t *w, uint16_t type)
{
    dr_wr_u16(w, type);
    dr_wr_u16(w, 0); /* length, filled in by dr_cpf_item_end */
    return w->len;
}

void dr_cpf_item_end(dr_wr_t *w, size_t mark)
{
    if (!w->overflow && w->len - mark > 0xFFFFu)
        w->overflow = true; /* the 16-bit item length cannot say it */
    if (!w->overflow)
        dr_put_le16(w->buf + mark - 2, (uint16_t)(w->len - mark));
}

void dr_cpf_sockaddr_write(dr_wr_t *w, uint16_t type, dr_sockaddr_t sa)
{
    size_t m = dr_cpf_item_begin(w, type);
    dr_wr_u16_be(w, 2);
    dr_wr_u16_be(w, sa.port);
    dr_wr_u32_be(w, sa.addr);
    uint8_t zero[8] = {0};
    dr_wr_bytes(w, zero, sizeof zero);
    dr_cpf_item_end(w, m);
}

/* ---- encapsulation command bodies ---------------------------------------- */

dr_status_t dr_register_parse(const uint8_t *body, size_t len,
                              uint16_t *version, uint16_t *options)
{
    rd_t r;
    rd_init(&r, body, len);
    *version = rd_u16(&r);
    *options = rd_u16(&r);
    return rd_done(&r);
}

void dr_register_write(dr_wr_t *w, uint16_t version, uint16_t options)
{
    dr_wr_u16(w, version);
    dr_wr_u16(w, options);
}

dr_status_t dr_rr_parse(const uint8_t *body, size_t len, uint32_t *iface,
                        uint16_t *timeout, dr_cpf_t *cpf)
{
    rd_t r;
    rd_init(&r, body, len);
    *iface = rd_u32(&r);
    *timeout = rd_u16(&r);
    if (r.short_)
        return DR_ESHORT;
    return dr_cpf_parse(body + r.pos, rd_left(&r), cpf);
}

void dr_rr_begin(dr_wr_t *w, uint16_t timeout)
{
    dr_wr_u32(w, 0); /* interface handle: CIP */
    dr_wr_u16(w, timeout);
}

void dr_list_services_write(dr_wr_t *w, uint16_t flags)
{
    /* Service name: 16 bytes, NUL-padded (Vol. 2, 2-4.6.3). */
    static const char name[16] = "Communications";
    dr_cpf_begin(w, 1);
    size_t m = dr_cpf_item_begin(w, DR_CPF_LIST_SERVICES);
    dr_wr_u16(w, 1); /* encapsulation protocol version */
    dr_wr_u16(w, flags);
    dr_wr_bytes(w, name, sizeof name);
    dr_cpf_item_end(w, m);
}

/* ---- EPATH ----------------------------------------------------------------- */

dr_status_t dr_epath_parse(const uint8_t *buf, size_t len, dr_epath_t *out)
{
    rd_t r;
    rd_init(&r, buf, len);
    memset(out, 0, sizeof *out);
    while (rd_left(&r) > 0) {
        uint8_t seg = rd_u8(&r);
        uint16_t v;
        switch (seg) {
        case 0x20: case 0x24: case 0x2C: case 0x30:
            v = rd_u8(&r);
            break;
        case 0x21: case 0x25: case 0x2D: case 0x31:
            (void)rd_u8(&r); /* pad byte */
            v = rd_u16(&r);
            break;
        case 0x34: { /* electronic key: format 4, 8 bytes of key data */
            uint8_t fmt = rd_u8(&r);
            if (fmt != 4)
                return DR_CIP(0x04, 0);
            (void)rd_take(&r, 8);
            out->has_key = 1;
            continue;
        }
        case 0x80: /* simple data segment: size in words, data */
            out->data_words = rd_u8(&r);
            out->data = rd_take(&r, 2u * out->data_words);
            continue;
        default:
            return DR_CIP(0x04, 0);
        }
        if (r.short_)
            break;
        switch (seg & 0xFC) {
        case 0x20: out->cls = v; out->has_cls = 1; break;
        case 0x24: out->inst = v; out->has_inst = 1; break;
        case 0x30: out->attr = v; out->has_attr = 1; break;
        default: /* 0x2C connection point */
            if (out->points >= 2)
                return DR_CIP(0x04, 0);
            out->point[out->points++] = v;
            break;
        }
    }
    return r.short_ ? DR_CIP(0x04, 0) : DR_OK;
}

static void epath_logical(dr_wr_t *w, uint8_t type, uint16_t v)
{
    if (v <= 0xFF) {
        dr_wr_u8(w, type);
        dr_wr_u8(w, (uint8_t)v);
    } else {
        dr_wr_u8(w, (uint8_t)(type | 1u));
        dr_wr_u8(w, 0);
        dr_wr_u16(w, v);
    }
}

void dr_epath_write(dr_wr_t *w, uint16_t cls, uint16_t inst, int attr)
{
    epath_logical(w, 0x20, cls);
    epath_logical(w, 0x24, inst);
    if (attr >= 0)
        epath_logical(w, 0x30, (uint16_t)attr);
}

size_t dr_cip_path(uint8_t *buf, size_t cap, uint16_t cls, uint16_t inst, int attr)
{
    dr_wr_t w;
    dr_wr_init(&w, buf, cap);
    dr_epath_write(&w, cls, inst, attr);
    return w.overflow ? 0 : w.len;
}

/* ---- Message Router request / reply ------------------------------------ */

dr_status_t dr_cip_req_parse(const uint8_t *buf, size_t len, dr_cip_req_t *req)
{
    rd_t r;
    rd_init(&r, buf, len);
    req->service = rd_u8(&r);
    uint8_t words = rd_u8(&r);
    req->path_len = 2u * words;
    req->path = rd_take(&r, req->path_len);
    if (r.short_)
        return DR_ESHORT;
    req->data = buf + r.pos;
    req->data_len = rd_left(&r);
    return DR_OK;
}

void dr_cip_req_write(dr_wr_t *w, uint8_t service, const uint8_t *path,
                      size_t path_len, const uint8_t *data, size_t data_len)
{
    dr_wr_u8(w, service);
    wr_path_words(w, path_len);
    dr_wr_bytes(w, path, path_len);
    if (path_len % 2u)
        dr_wr_u8(w, 0);
    dr_wr_bytes(w, data, data_len);
}

dr_status_t dr_cip_rsp_parse(const uint8_t *buf, size_t len, dr_cip_rsp_t *rsp)
{
    rd_t r;
    rd_init(&r, buf, len);
    rsp->service = rd_u8(&r);
    (void)rd_u8(&r); /* reserved */
    rsp->general = rd_u8(&r);
    rsp->ext_count = rd_u8(&r);
    rsp->ext[0] = rsp->ext[1] = 0;
    for (unsigned i = 0; i < rsp->ext_count; i++) {
        uint16_t e = rd_u16(&r);
        if (i < 2)
            rsp->ext[i] = e;
    }
    if (r.short_)
        return DR_ESHORT;
    if (!(rsp->service & DR_CIP_REPLY))
        return DR_EMALFORMED;
    rsp->data = buf + r.pos;
    rsp->data_len = rd_left(&r);
    return DR_OK;
}

dr_status_t dr_cip_rsp_status(const dr_cip_rsp_t *rsp)
{
    if (rsp->general == 0)
        return DR_OK;
    return DR_CIP(rsp->general, rsp->ext_count > 0 ? rsp->ext[0] : 0);
}

void dr_cip_rsp_write(dr_wr_t *w, uint8_t service, uint8_t general,
                      const uint16_t *ext, uint8_t ext_count,
                      const uint8_t *data, size_t data_len)
{
    dr_wr_u8(w, (uint8_t)(service | DR_CIP_REPLY));
    dr_wr_u8(w, 0);
    dr_wr_u8(w, general);
    dr_wr_u8(w, ext_count);
    for (unsigned i = 0; i < ext_count; i++)
        dr_wr_u16(w, ext[i]);
    dr_wr_bytes(w, data, data_len);
}

/* ---- Unconnected Send ---------------------------------------------------- */

dr_status_t dr_ucmm_send_parse(const uint8_t *data, size_t len, dr_ucmm_send_t *out)
{
    rd_t r;
    rd_init(&r, data, len);
    out->priority_tick = rd_u8(&r);
    out->timeout_ticks = rd_u8(&r);
    out->message_len = rd_u16(&r);
    out->message = rd_take(&r, out->message_len);
    if (out->message_len % 2u)
        (void)rd_u8(&r); /* pad */
    uint8_t words = rd_u8(&r);
    (void)rd_u8(&r); /* reserved */
    out->route_len = 2u * words;
    out->route = rd_take(&r, out->route_len);
    return rd_done(&r);
}

void dr_ucmm_send_write(dr_wr_t *w, const uint8_t *message, size_t message_len,
                        const uint8_t *route, size_t route_len)
{
    dr_wr_u8(w, 0x0A); /* priority/tick: 2^10 ms ticks */
    dr_wr_u8(w, 0x05); /* 5 ticks, about 5 s */
    if (message_len > 0xFFFFu)
        w->overflow = true; /* the 16-bit message size cannot say it */
    dr_wr_u16(w, (uint16_t)message_len);
    dr_wr_bytes(w, message, message_len);
    if (message_len % 2u)
        dr_wr_u8(w, 0);
    wr_path_words(w, route_len);
    dr_wr_u8(w, 0);
    dr_wr_bytes(w, route, route_len);
    if (route_len % 2u)
        dr_wr_u8(w, 0);
}

/* ---- Forward Open / Close ------------------------------------------------ */

uint32_t dr_netparams_encode(const dr_netparams_t *np, bool large)
{
    if (large)
        return (uint32_t)np->redundant_owner << 31 | (uint32_t)(np->type & 3u) << 29 |
               (uint32_t)(np->priority & 3u) << 26 | (uint32_t)np->variable << 25 |
               np->size;
    return (uint32_t)np->redundant_owner << 15 | (uint32_t)(np->type & 3u) << 13 |
           (uint32_t)(np->priority & 3u) << 10 | (uint32_t)np->variable << 9 |
           (np->size & 0x1FFu);
}

dr_netparams_t dr_netparams_decode(uint32_t raw, bool large)
{
    dr_netparams_t np;
    if (large) {
        np.redundant_owner = (raw >> 31) & 1u;
        np.type = (uint8_t)((raw >> 29) & 3u);
        np.priority = (uint8_t)((raw >> 26) & 3u);
        np.variable = (raw >> 25) & 1u;
        np.size = (uint16_t)raw;
    } else {
        np.redundant_owner = (raw >> 15) & 1u;
        np.type = (uint8_t)((raw >> 13) & 3u);
        np.priority = (uint8_t)((raw >> 10) & 3u);
        np.variable = (raw >> 9) & 1u;
        np.size = (uint16_t)(raw & 0x1FFu);
    }
    return np;
}

dr_status_t dr_fwd_open_parse(const uint8_t *data, size_t len, bool large,
                              dr_fwd_open_t *out)
{
    rd_t r;
    rd_init(&r, data, len);
    memset(out, 0, sizeof *out);
    out->large = large;
    out->priority_tick = rd_u8(&r);
    out->timeout_ticks = rd_u8(&r);
    out->o2t_cid = rd_u32(&r);
    out->t2o_cid = rd_u32(&r);
    out->conn_serial = rd_u16(&r);
    out->vendor = rd_u16(&r);
    out->orig_serial = rd_u32(&r);
    out->timeout_mult = rd_u8(&r);
    (void)rd_take(&r, 3);
    out->o2t_rpi_us = rd_u32(&r);
    out->o2t = dr_netparams_decode(large ? rd_u32(&r) : rd_u16(&r), large);
    out->t2o_rpi_us = rd_u32(&r);
    out->t2o = dr_netparams_decode(large ? rd_u32(&r) : rd_u16(&r), large);
    out->transport = rd_u8(&r);
    uint8_t words = rd_u8(&r);
    out->path_len = 2u * words;
    out->path = rd_take(&r, out->path_len);
    return rd_done(&r);
}

void dr_fwd_open_write(dr_wr_t *w, const dr_fwd_open_t *fo)
{
    /* 16-bit parameters hold 9 bits of size: a larger connection needs
     * 0x5B, and masking the size would open a connection of the wrong size. */
    if (!fo->large && (fo->o2t.size > 0x1FFu || fo->t2o.size > 0x1FFu))
        w->overflow = true;
    dr_wr_u8(w, fo->priority_tick);
    dr_wr_u8(w, fo->timeout_ticks);
    dr_wr_u32(w, fo->o2t_cid);
    dr_wr_u32(w, fo->t2o_cid);
    dr_wr_u16(w, fo->conn_serial);
    dr_wr_u16(w, fo->vendor);
    dr_wr_u32(w, fo->orig_serial);
    dr_wr_u8(w, fo->timeout_mult);
    dr_wr_u8(w, 0);
    dr_wr_u16(w, 0);
    dr_wr_u32(w, fo->o2t_rpi_us);
    if (fo->large)
        dr_wr_u32(w, dr_netparams_encode(&fo->o2t, true));
    else
        dr_wr_u16(w, (uint16_t)dr_netparams_encode(&fo->o2t, false));
    dr_wr_u32(w, fo->t2o_rpi_us);
    if (fo->large)
        dr_wr_u32(w, dr_netparams_encode(&fo->t2o, true));
    else
        dr_wr_u16(w, (uint16_t)dr_netparams_encode(&fo->t2o, false));
    dr_wr_u8(w, fo->transport);
    wr_path_words(w, fo->path_len);
    dr_wr_bytes(w, fo->path, fo->path_len);
    if (fo->path_len % 2u)
        dr_wr_u8(w, 0);
}

size_t dr_conn_path_write(uint8_t *buf, size_t cap, uint16_t config_inst,
                          uint16_t o2t_point, uint16_t t2o_point)
{
    dr_wr_t w;
    dr_wr_init(&w, buf, cap);
    epath_logical(&w, 0x20, DR_CIP_CLASS_ASSEMBLY);
    epath_logical(&w, 0x24, config_inst);
    epath_logical(&w, 0x2C, o2t_point);
    epath_logical(&w, 0x2C, t2o_point);
    return w.overflow ? 0 : w.len;
}

dr_status_t dr_fwd_open_reply_parse(const uint8_t *data, size_t len,
                                    dr_fwd_open_reply_t *out)
{
    rd_t r;
    rd_init(&r, data, len);
    out->o2t_cid = rd_u32(&r);
    out->t2o_cid = rd_u32(&r);
    out->conn_serial = rd_u16(&r);
    out->vendor = rd_u16(&r);
    out->orig_serial = rd_u32(&r);
    out->o2t_api_us = rd_u32(&r);
    out->t2o_api_us = rd_u32(&r);
    uint8_t words = rd_u8(&r);
    (void)rd_u8(&r);
    (void)rd_take(&r, 2u * words); /* application reply: not used */
    return rd_done(&r);
}

void dr_fwd_open_reply_write(dr_wr_t *w, const dr_fwd_open_reply_t *rp)
{
    dr_wr_u32(w, rp->o2t_cid);
    dr_wr_u32(w, rp->t2o_cid);
    dr_wr_u16(w, rp->conn_serial);
    dr_wr_u16(w, rp->vendor);
    dr_wr_u32(w, rp->orig_serial);
    dr_wr_u32(w, rp->o2t_api_us);
    dr_wr_u32(w, rp->t2o_api_us);
    dr_wr_u8(w, 0);
    dr_wr_u8(w, 0);
}

/* The serial triad, then an empty block: the remaining path of a refusal
 * and the application reply of a Forward Close reply have the same shape
 * (size in words, reserved byte). */
static void serials_then_empty(dr_wr_t *w, uint16_t conn_serial, uint16_t vendor,
                               uint32_t orig_serial)
{
    dr_wr_u16(w, conn_serial);
    dr_wr_u16(w, vendor);
    dr_wr_u32(w, orig_serial);
    dr_wr_u8(w, 0); /* size in words */
    dr_wr_u8(w, 0); /* reserved */
}

void dr_fwd_fail_write(dr_wr_t *w, uint16_t conn_serial, uint16_t vendor,
                       uint32_t orig_serial)
{
    serials_then_empty(w, conn_serial, vendor, orig_serial);
}

dr_status_t dr_fwd_close_parse(const uint8_t *data, size_t len, dr_fwd_close_t *out)
{
    rd_t r;
    rd_init(&r, data, len);
    out->priority_tick = rd_u8(&r);
    out->timeout_ticks = rd_u8(&r);
    out->conn_serial = rd_u16(&r);
    out->vendor = rd_u16(&r);
    out->orig_serial = rd_u32(&r);
    uint8_t words = rd_u8(&r);
    (void)rd_u8(&r);
    out->path_len = 2u * words;
    out->path = rd_take(&r, out->path_len);
    return rd_done(&r);
}

void dr_fwd_close_write(dr_wr_t *w, const dr_fwd_close_t *fc)
{
    dr_wr_u8(w, fc->priority_tick);
    dr_wr_u8(w, fc->timeout_ticks);
    dr_wr_u16(w, fc->conn_serial);
    dr_wr_u16(w, fc->vendor);
    dr_wr_u32(w, fc->orig_serial);
    wr_path_words(w, fc->path_len);
    dr_wr_u8(w, 0);
    dr_wr_bytes(w, fc->path, fc->path_len);
    if (fc->path_len % 2u)
        dr_wr_u8(w, 0);
}

void dr_fwd_close_reply_write(dr_wr_t *w, uint16_t conn_serial, uint16_t vendor,
                              uint32_t orig_serial)
{
    serials_then_empty(w, conn_serial, vendor, orig_serial);
}

/* ---- Class 1 frames ------------------------------------------------------ */

dr_status_t dr_io_frame_parse(const uint8_t *buf, size_t len, bool run_idle,
                              dr_io_frame_t *out)
{
    dr_cpf_t cpf;
    dr_status_t st = dr_cpf_parse(buf, len, &cpf);
    if (st != DR_OK)
        return st;
    if (cpf.count != 2 || cpf.item[0].type != DR_CPF_SEQUENCED_ADDRESS ||
        cpf.item[1].type != DR_CPF_CONNECTED_DATA)
        return DR_EMALFORMED;
    rd_t r;
    rd_init(&r, cpf.item[0].data, cpf.item[0].length);
    out->cid = rd_u32(&r);
    out->encap_seq = rd_u32(&r);
    if ((st = rd_done(&r)) != DR_OK)
        return st;
    rd_init(&r, cpf.item[1].data, cpf.item[1].length);
    out->cip_seq = rd_u16(&r);
    out->has_run_idle = run_idle;
    out->run_idle = run_idle ? rd_u32(&r) : 0;
    if (r.short_)
        return DR_ESHORT;
    out->data = cpf.item[1].data + r.pos;
    out->data_len = rd_left(&r);
    return DR_OK;
}

dr_status_t dr_io_frame_write(uint8_t *buf, size_t cap, const dr_io_frame_t *f,
                              size_t *out_len)
{
    dr_wr_t w;
    dr_wr_init(&w, buf, cap);
    dr_cpf_begin(&w, 2);
    size_t m = dr_cpf_item_begin(&w, DR_CPF_SEQUENCED_ADDRESS);
    dr_wr_u32(&w, f->cid);
    dr_wr_u32(&w, f->encap_seq);
    dr_cpf_item_end(&w, m);
    m = dr_cpf_item_begin(&w, DR_CPF_CONNECTED_DATA);
    dr_wr_u16(&w, f->cip_seq);
    if (f->has_run_idle)
        dr_wr_u32(&w, f->run_idle);
    dr_wr_bytes(&w, f->data, f->data_len);
    dr_cpf_item_end(&w, m);
    if (w.overflow)
        return DR_ENOSPACE;
    *out_len = w.len;
    return DR_OK;
}

bool dr_seq16_newer(uint16_t a, uint16_t b)
{
    uint16_t d = (uint16_t)(a - b);
    return d != 0 && d < 0x8000u;
}

bool dr_seq32_newer(uint32_t a, uint32_t b)
{
    uint32_t d = a - b;
    return d != 0 && d < 0x80000000u;
}

/* ---- Identity ------------------------------------------------------------ */

static void rd_short_string(rd_t *r, char *out, size_t cap)
{
    uint8_t n = rd_u8(r);
    const uint8_t *s = rd_take(r, n);
    size_t k = 0;
    if (s != NULL)
        for (; k < n && k + 1 < cap; k++)
            out[k] = (char)((s[k] >= 0x20 && s[k] < 0x7F) ? s[k] : '?');
    out[k] = '\0';
}

static void identity_fields(rd_t *r, dr_identity_t *id)
{
    id->vendor = rd_u16(r);
    id->device_type = rd_u16(r);
    id->product_code = rd_u16(r);
    id->rev_major = rd_u8(r);
    id->rev_minor = rd_u8(r);
    id->status = rd_u16(r);
    id->serial = rd_u32(r);
    rd_short_string(r, id->product_name, sizeof id->product_name);
}

dr_status_t dr_identity_parse_all(const uint8_t *data, size_t len, dr_identity_t *out)
{
    rd_t r;
    rd_init(&r, data, len);
    memset(out, 0, sizeof *out);
    identity_fields(&r, out);
    out->state = 0xFF;
    if (r.short_)
        return DR_ESHORT;
    /* Attributes after 7 (state, config consistency, ...) may follow. */
    return DR_OK;
}

static void write_identity_fields(dr_wr_t *w, const dr_identity_t *id)
{
    size_t n = strlen(id->product_name);
    dr_wr_u16(w, id->vendor);
    dr_wr_u16(w, id->device_type);
    dr_wr_u16(w, id->product_code);
    dr_wr_u8(w, id->rev_major);
    dr_wr_u8(w, id->rev_minor);
    dr_wr_u16(w, id->status);
    dr_wr_u32(w, id->serial);
    dr_wr_u8(w, (uint8_t)n);
    dr_wr_bytes(w, id->product_name, n);
}

void dr_identity_write_all(dr_wr_t *w, const dr_identity_t *id)
{
    write_identity_fields(w, id);
}

dr_status_t dr_list_identity_parse(const uint8_t *body, size_t len, dr_identity_t *out)
{
    /* A reply, read as Forward Open replies are: an item after the
     * declared ones (as some adapters append) does not lose the answer. */
    dr_cpf_t cpf;
    size_t extra;
    dr_status_t st = dr_cpf_parse_reply(body, len, &cpf, &extra);
    if (st != DR_OK)
        return st;
    const dr_cpf_item_t *it = dr_cpf_find(&cpf, DR_CPF_LIST_IDENTITY);
    if (it == NULL)
        return DR_EMALFORMED;
    rd_t r;
    rd_init(&r, it->data, it->length);
    memset(out, 0, sizeof *out);
    (void)rd_u16(&r); /* encapsulation protocol version */
    (void)rd_u16_be(&r); /* sin_family */
    out->sockaddr.port = rd_u16_be(&r);
    out->sockaddr.addr = rd_u32_be(&r);
    (void)rd_take(&r, 8);
    identity_fields(&r, out);
    out->state = rd_u8(&r);
    return rd_done(&r);
}

void dr_list_identity_write(dr_wr_t *w, const dr_identity_t *id)
{
    dr_cpf_begin(w, 1);
    size_t m = dr_cpf_item_begin(w, DR_CPF_LIST_IDENTITY);
    dr_wr_u16(w, 1); /* encapsulation protocol version */
    dr_wr_u16_be(w, 2);
    dr_wr_u16_be(w, id->sockaddr.port);
    dr_wr_u32_be(w, id->sockaddr.addr);
    uint8_t zero[8] = {0};
    dr_wr_bytes(w, zero, sizeof zero);
    write_identity_fields(w, id);
    dr_wr_u8(w, id->state);
    dr_cpf_item_end(w, m);
}
