/* SPDX-License-Identifier: MIT */
/*
 * drsim adapter: encapsulation commands, the Message Router (Identity,
 * Assembly, Connection Manager objects) and Class 1 connections.
 *
 * References: CIP Vol. 1 ch. 3-5 (Connection Manager), 5A (Identity,
 * Assembly); Vol. 2 ch. 2 (encapsulation), 3 (Class 1 over UDP).
 */
#include <string.h>

#include "adapter.h"
#include "log.h"

/* CIP general status codes drsim answers with. */
enum {
    GS_OK = 0x00,
    GS_CONN_FAILURE = 0x01,
    GS_PATH_SEGMENT = 0x04,
    GS_PATH_UNKNOWN = 0x05,
    GS_SERVICE = 0x08,
    GS_NOT_SETTABLE = 0x0E,
    GS_NOT_ENOUGH_DATA = 0x13,
    GS_ATTRIBUTE = 0x14,
    GS_TOO_MUCH_DATA = 0x15,
    GS_INVALID_PARAMETER = 0x20
};

/* Extended status of general status 0x01 (Connection Manager). */
enum {
    CM_DUPLICATE = 0x0100,
    CM_TRANSPORT = 0x0103,
    CM_OWNERSHIP = 0x0106,
    CM_NOT_FOUND = 0x0107,
    CM_SIZE = 0x0109,
    CM_RPI = 0x0111,
    CM_OUT_OF_CONNS = 0x0113,
    CM_CONFIG_PATH = 0x0118,
    CM_NOT_LISTEN_ONLY = 0x0119, /* non-listen only connection not opened */
    CM_O2T_TYPE = 0x0123,
    CM_T2O_TYPE = 0x0124,
    CM_CONFIG_APP_PATH = 0x0129, /* invalid configuration application path */
    CM_CONSUMING_PATH = 0x012A,  /* invalid consuming application path */
    CM_BAD_SEGMENT = 0x0315,
    CM_UCMM_PARAM = 0x0205
};

/* Encapsulation status codes (Vol. 2, 2-3.3). */
enum {
    ES_INVALID_COMMAND = 0x0001,
    ES_INCORRECT_DATA = 0x0003,
    ES_INVALID_SESSION = 0x0064,
    ES_INVALID_LENGTH = 0x0065,
    ES_PROTOCOL_VERSION = 0x0069,
    /* not on the wire: send_rr_data's "send nothing" */
    ES_LOST_REPLY = 0x10000
};

#define IDENTITY_STATE_OPERATIONAL 3u
/* Unconnected Send may wrap one request; deeper nesting is refused. */
#define UCMM_MAX_DEPTH 1

/* ---- helpers ------------------------------------------------------------ */

/* splitmix64: deterministic numbers from --seed. */
static uint64_t mix64(uint64_t x)
{
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

/* True for the share of I/O packets --drop asks to lose. */
static bool drop_packet(drsim_t *s)
{
    if (s->cfg.drop_pct == 0)
        return false;
    return mix64(s->rng++) % 100u < s->cfg.drop_pct;
}

static const char *ip_text(uint32_t a, char buf[16])
{
    /* snprintf is not needed for four small numbers. */
    char *p = buf;
    for (int shift = 24; shift >= 0; shift -= 8) {
        unsigned v = (a >> shift) & 0xFFu;
        if (v >= 100)
            *p++ = (char)('0' + v / 100);
        if (v >= 10)
            *p++ = (char)('0' + v / 10 % 10);
        *p++ = (char)('0' + v % 10);
        if (shift)
            *p++ = '.';
    }
    *p = '\0';
    return buf;
}

void drsim_config_default(drsim_config_t *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        cfg->instance[a] = DR_ASM_DEFAULT_INSTANCE(a);
    cfg->echo = true;
    cfg->max_conns = 16;
    cfg->tcp_port = DR_ENIP_TCP_PORT;
    cfg->udp_port = DR_ENIP_UDP_PORT;
    cfg->hb_input_only = DRSIM_HB_INPUT_ONLY;
    cfg->hb_listen_only = DRSIM_HB_LISTEN_ONLY;
    cfg->vendor_id = DRSIM_VENDOR_ID;
    dr_layout_default(&cfg->layout, DR_LAYOUT_PER_ASSEMBLY);
}

/* The Assembly instances of the configured layout: one per assembly, or
 * the input point and (when it carries any) the output point. */
static void points_init(drsim_t *s)
{
    s->npt = 0;
    if (s->cfg.layout.kind == DR_LAYOUT_PER_ASSEMBLY) {
        for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
            drsim_point_t *pt = &s->pt[s->npt++];
            pt->dir = dr_asm_info((dr_asm_t)a)->dir;
            pt->p.instance = s->cfg.instance[a];
            pt->p.count = 1;
            pt->p.asm_id[0] = (uint8_t)a;
            pt->p.size = dr_asm_info((dr_asm_t)a)->size;
        }
        return;
    }
    if (dr_point_check(&s->cfg.layout.input, DR_DIR_T2O) == DR_OK)
        s->pt[s->npt++] = (drsim_point_t){DR_DIR_T2O, s->cfg.layout.input};
    if (dr_point_check(&s->cfg.layout.output, DR_DIR_O2T) == DR_OK)
        s->pt[s->npt++] = (drsim_point_t){DR_DIR_O2T, s->cfg.layout.output};
}

void drsim_init(drsim_t *s, const drsim_config_t *cfg, uint64_t now_ns)
{
    memset(s, 0, sizeof *s);
    s->cfg = *cfg;
    if (s->cfg.max_conns == 0 || s->cfg.max_conns > DRSIM_MAX_CONNS)
        s->cfg.max_conns = DRSIM_MAX_CONNS;
    if (s->cfg.drop_pct > 100)
        s->cfg.drop_pct = 100;
    s->rng = mix64(cfg->seed ^ 0xD5095EEDull);
    s->next_session = (uint32_t)mix64(cfg->seed ^ 0x5E55u) | 1u;
    s->next_cid = (uint32_t)mix64(cfg->seed ^ 0xC1Du) | 1u;
    s->start_ns = now_ns;
    s->next_model_ns = now_ns + DRSIM_MODEL_PERIOD_NS;
    points_init(s);

    dr_identity_t *id = &s->identity;
    id->vendor = cfg->vendor_id;
    id->device_type = DRSIM_DEVICE_TYPE;
    id->product_code = DRSIM_PRODUCT_CODE;
    id->rev_major = 2;
    id->rev_minor = 12;
    id->serial = (uint32_t)mix64(cfg->seed);
    strcpy(id->product_name, DRSIM_PRODUCT_NAME);
    id->state = IDENTITY_STATE_OPERATIONAL;

    drsim_robot_init(&s->robot, now_ns, cfg->seed, cfg->echo, &s->img);
    if (cfg->still) { /* from the first update on: images without noise */
        s->robot.still = true;
        drsim_robot_update(&s->robot, now_ns, &s->img);
    }
}

int drsim_asm_of_instance(const drsim_t *s, uint16_t inst)
{
    for (unsigned i = 0; i < s->npt; i++)
        if (s->pt[i].p.instance == inst)
            return (int)i;
    return -1;
}

static bool is_t2o(const drsim_t *s, int pt)
{
    return s->pt[pt].dir == DR_DIR_T2O;
}

static uint16_t pt_size(const drsim_t *s, int pt)
{
    return s->pt[pt].p.size;
}

/* The point's name in log lines: its assembly's, or "input"/"output". */
static const char *pt_name(const drsim_t *s, int pt)
{
    if (s->pt[pt].p.count == 1)
        return dr_asm_info((dr_asm_t)s->pt[pt].p.asm_id[0])->name;
    return is_t2o(s, pt) ? "input (combined)" : "output (combined)";
}

/* The point's image, from the assemblies' own: buf[pt_size]. */
static const uint8_t *pt_read(const drsim_t *s, int pt, uint8_t *buf)
{
    const dr_point_t *p = &s->pt[pt].p;
    if (p->count == 1)
        return s->img.buf[p->asm_id[0]];
    for (unsigned i = 0; i < p->count; i++) {
        dr_asm_t a = (dr_asm_t)p->asm_id[i];
        (void)dr_point_put(p, buf, p->size, a, s->img.buf[a], dr_asm_info(a)->size);
    }
    return buf;
}

/* O->T data of the point's size into the assemblies it carries, each
 * then shown in the T->O images (drsim_robot_input). */
static void pt_write(drsim_t *s, int pt, const uint8_t *data)
{
    const dr_point_t *p = &s->pt[pt].p;
    for (unsigned i = 0; i < p->count; i++) {
        dr_asm_t a = (dr_asm_t)p->asm_id[i];
        if (dr_point_slice(p, data, p->size, a, s->img.buf[a], dr_asm_info(a)->size) == DR_OK)
            drsim_robot_input(&s->robot, a, &s->img);
    }
}

/* Connections in their slots, the held ones too: they still take one. */
unsigned drsim_conn_count(const drsim_t *s)
{
    unsigned n = 0;
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++)
        n += s->conn[i].used;
    return n;
}

drsim_conn_t *drsim_conn_by_o2t(drsim_t *s, uint32_t cid)
{
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++)
        if (s->conn[i].used && s->conn[i].o2t_cid == cid)
            return &s->conn[i];
    return NULL;
}

uint16_t drsim_identity_status(const drsim_t *s)
{
    /* Bit 0 owned; bits 4-7 extended device status: 3 no I/O connection,
     * 6 at least one in run mode, 7 all connections idle. */
    bool owned = false, any = false, run = false;
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++) {
        const drsim_conn_t *c = &s->conn[i];
        if (!c->used || c->held)
            continue;
        any = true;
        owned |= c->o2t_asm >= 0;
        run |= c->o2t_seen && c->run;
    }
    uint16_t ext = !any ? 0x3u : (run ? 0x6u : 0x7u);
    return (uint16_t)((owned ? 0x1u : 0x0u) | ext << 4);
}

static void identity_refresh(drsim_t *s, uint32_t local_addr)
{
    s->identity.status = drsim_identity_status(s);
    s->identity.sockaddr.addr = s->cfg.address ? s->cfg.address : local_addr;
    s->identity.sockaddr.port = s->cfg.tcp_port;
}

/* ---- Message Router replies --------------------------------------------- */

typedef struct {
    drsim_t *s;
    const drsim_peer_t *peer;
    uint64_t now;
    const dr_sockaddr_t *t2o_sa; /* the request's 0x8001 item, or NULL */
    bool o2t_sa;                 /* reply must carry our 0x8000 item */
} req_ctx_t;

static void reply(dr_wr_t *w, uint8_t service, uint8_t general,
                  const uint8_t *data, size_t len)
{
    dr_cip_rsp_write(w, service, general, NULL, 0, data, len);
}

static void reply_u16(dr_wr_t *w, uint8_t service, uint16_t v)
{
    uint8_t b[2];
    dr_wr_t t;
    dr_wr_init(&t, b, sizeof b);
    dr_wr_u16(&t, v);
    reply(w, service, GS_OK, b, sizeof b);
}

/* Class attributes (instance 0) every object here shares: 1 revision,
 * 2 max instance, 3 number of instances. */
static void class_attribute(dr_wr_t *w, const dr_cip_req_t *rq,
                            const dr_epath_t *p, uint16_t revision,
                            uint16_t max_inst, uint16_t count)
{
    if (rq->service != DR_CIP_SVC_GET_ATTRIBUTE_SINGLE) {
        reply(w, rq->service, GS_SERVICE, NULL, 0);
        return;
    }
    if (!p->has_attr) {
        reply(w, rq->service, GS_PATH_SEGMENT, NULL, 0);
        return;
    }
    switch (p->attr) {
    case 1: reply_u16(w, rq->service, revision); break;
    case 2: reply_u16(w, rq->service, max_inst); break;
    case 3: reply_u16(w, rq->service, count); break;
    default: reply(w, rq->service, GS_ATTRIBUTE, NULL, 0); break;
    }
}

/* ---- Identity object (class 1) ------------------------------------------ */

/* Attribute `attr` of the Identity instance into w; false if none. */
static bool identity_attr(const dr_identity_t *id, uint16_t attr, dr_wr_t *w)
{
    switch (attr) {
    case 1: dr_wr_u16(w, id->vendor); return true;
    case 2: dr_wr_u16(w, id->device_type); return true;
    case 3: dr_wr_u16(w, id->product_code); return true;
    case 4: dr_wr_u8(w, id->rev_major); dr_wr_u8(w, id->rev_minor); return true;
    case 5: dr_wr_u16(w, id->status); return true;
    case 6: dr_wr_u32(w, id->serial); return true;
    case 7: {
        size_t n = strlen(id->product_name);
        dr_wr_u8(w, (uint8_t)n);
        dr_wr_bytes(w, id->product_name, n);
        return true;
    }
    case 8: dr_wr_u8(w, id->state); return true;
    default: return false;
    }
}

static void identity_service(req_ctx_t *ctx, const dr_cip_req_t *rq,
                             const dr_epath_t *p, dr_wr_t *w)
{
    if (p->inst == 0) {
        class_attribute(w, rq, p, 1, 1, 1);
        return;
    }
    if (p->inst != 1) {
        reply(w, rq->service, GS_PATH_UNKNOWN, NULL, 0);
        return;
    }
    identity_refresh(ctx->s, ctx->peer->local_addr);
    uint8_t buf[64];
    dr_wr_t d;
    dr_wr_init(&d, buf, sizeof buf);
    switch (rq->service) {
    case DR_CIP_SVC_GET_ATTRIBUTES_ALL:
        if (ctx->s->cfg.refuse_identity) { /* --refuse-identity */
            reply(w, rq->service, GS_SERVICE, NULL, 0);
            break;
        }
        dr_identity_write_all(&d, &ctx->s->identity);
        reply(w, rq->service, GS_OK, buf, d.len);
        break;
    case DR_CIP_SVC_GET_ATTRIBUTE_SINGLE:
        if (!p->has_attr)
            reply(w, rq->service, GS_PATH_SEGMENT, NULL, 0);
        else if (identity_attr(&ctx->s->identity, p->attr, &d))
            reply(w, rq->service, GS_OK, buf, d.len);
        else
            reply(w, rq->service, GS_ATTRIBUTE, NULL, 0);
        break;
    case DR_CIP_SVC_SET_ATTRIBUTE_SINGLE:
        if (!p->has_attr)
            reply(w, rq->service, GS_PATH_SEGMENT, NULL, 0);
        else
            reply(w, rq->service,
                  identity_attr(&ctx->s->identity, p->attr, &d) ? GS_NOT_SETTABLE
                                                                 : GS_ATTRIBUTE,
                  NULL, 0);
        break;
    default:
        reply(w, rq->service, GS_SERVICE, NULL, 0);
        break;
    }
}

/* ---- Assembly object (class 4) ------------------------------------------ */

static uint16_t max_instance(const drsim_t *s)
{
    uint16_t m = 0;
    for (unsigned i = 0; i < s->npt; i++)
        if (s->pt[i].p.instance > m)
            m = s->pt[i].p.instance;
    return m;
}

static void assembly_get(req_ctx_t *ctx, const dr_cip_req_t *rq,
                         const dr_epath_t *p, int a, dr_wr_t *w)
{
    uint16_t size = pt_size(ctx->s, a);
    uint8_t buf[DR_POINT_MAX_SIZE];
    /* Request data after a Get is ignored, as most targets do: pycomm3
     * with route_path=True and no route appends two zero bytes. */
    if (rq->service == DR_CIP_SVC_GET_ATTRIBUTES_ALL ||
        (p->has_attr && p->attr == DR_CIP_ASM_ATTR_DATA))
        reply(w, rq->service, GS_OK, pt_read(ctx->s, a, buf), size);
    else if (!p->has_attr)
        reply(w, rq->service, GS_PATH_SEGMENT, NULL, 0);
    else if (p->attr == DR_CIP_ASM_ATTR_SIZE)
        reply_u16(w, rq->service, size);
    else
        reply(w, rq->service, GS_ATTRIBUTE, NULL, 0);
}

static void assembly_set(req_ctx_t *ctx, const dr_cip_req_t *rq,
                         const dr_epath_t *p, int a, dr_wr_t *w)
{
    uint16_t size = pt_size(ctx->s, a);
    uint8_t gs;
    if (!p->has_attr)
        gs = GS_PATH_SEGMENT;
    else if (p->attr == DR_CIP_ASM_ATTR_SIZE)
        gs = GS_NOT_SETTABLE;
    else if (p->attr != DR_CIP_ASM_ATTR_DATA)
        gs = GS_ATTRIBUTE;
    else if (is_t2o(ctx->s, a)) /* produced by the robot: the PLC may only read it */
        gs = GS_NOT_SETTABLE;
    else if (rq->data_len < size)
        gs = GS_NOT_ENOUGH_DATA;
    else if (rq->data_len > size)
        gs = GS_TOO_MUCH_DATA;
    else {
        pt_write(ctx->s, a, rq->data);
        drsim_log(2, "set %s (%u bytes)", pt_name(ctx->s, a), (unsigned)size);
        gs = GS_OK;
    }
    reply(w, rq->service, gs, NULL, 0);
}

static void assembly_service(req_ctx_t *ctx, const dr_cip_req_t *rq,
                             const dr_epath_t *p, dr_wr_t *w)
{
    if (p->inst == 0) {
        class_attribute(w, rq, p, 2, max_instance(ctx->s), (uint16_t)ctx->s->npt);
        return;
    }
    int a = drsim_asm_of_instance(ctx->s, p->inst);
    if (a < 0) {
        reply(w, rq->service, GS_PATH_UNKNOWN, NULL, 0);
        return;
    }
    switch (rq->service) {
    case DR_CIP_SVC_GET_ATTRIBUTES_ALL:
    case DR_CIP_SVC_GET_ATTRIBUTE_SINGLE:
        if (ctx->s->cfg.no_get_assembly) /* --no-get-assembly */
            reply(w, rq->service, GS_SERVICE, NULL, 0);
        else
            assembly_get(ctx, rq, p, a, w);
        break;
    case DR_CIP_SVC_SET_ATTRIBUTE_SINGLE:
        assembly_set(ctx, rq, p, a, w);
        break;
    default:
        reply(w, rq->service, GS_SERVICE, NULL, 0);
        break;
    }
}

/* ---- Forward Open / Close (class 6) -------------------------------------- */

/* What a Forward Open asks for, once its path is understood. */
typedef struct {
    uint16_t config, o2t_point, t2o_point;
    int o2t_asm; /* a point; -1: heartbeat */
    bool listen_only; /* on the listen-only heartbeat point */
    int t2o_asm; /* a point */
} fo_plan_t;

/* Understand the connection path: [key] 20 04 24 cfg 2C o2t 2C t2o.
 * Returns 0 or an extended status. */
static uint16_t fo_path(const drsim_t *s, const dr_fwd_open_t *fo, fo_plan_t *plan)
{
    dr_epath_t p;
    if (dr_epath_parse(fo->path, fo->path_len, &p) != DR_OK)
        return CM_BAD_SEGMENT;
    if (!p.has_cls || p.cls != DR_CIP_CLASS_ASSEMBLY || !p.has_inst ||
        p.has_attr || p.points != 2)
        return CM_BAD_SEGMENT;
    /* drsim has no configuration assembly: any instance is fine as long
     * as it carries no data, unless --config-instance names the one an
     * EDS would. */
    if (p.data_words > 0)
        return CM_CONFIG_PATH;
    if (s->cfg.config_instance != 0 && p.inst != s->cfg.config_instance)
        return CM_CONFIG_APP_PATH;
    plan->config = p.inst;
    plan->o2t_point = p.point[0];
    plan->t2o_point = p.point[1];
    int o = drsim_asm_of_instance(s, p.point[0]);
    int t = drsim_asm_of_instance(s, p.point[1]);
    uint16_t hb = p.point[0];
    if (hb != 0 && (hb == s->cfg.hb_input_only || hb == s->cfg.hb_listen_only)) {
        plan->o2t_asm = -1;
        plan->listen_only = hb == s->cfg.hb_listen_only;
    } else if (o >= 0 && !is_t2o(s, o)) {
        plan->o2t_asm = o;
    } else if (o < 0) {
        /* Neither an O->T assembly nor a heartbeat point this target
         * offers (such as 198 on one that has no input-only). */
        return CM_CONSUMING_PATH;
    } else {
        return CM_BAD_SEGMENT;
    }
    if (t < 0 || !is_t2o(s, t))
        return CM_BAD_SEGMENT;
    plan->t2o_asm = t;
    return 0;
}

/* Network size the O->T direction needs: data + sequence count + run/idle
 * header; a heartbeat has no data (2 modeless, 6 with run/idle). */
static uint16_t o2t_wanted(const drsim_t *s, const fo_plan_t *plan, uint16_t asked)
{
    if (plan->o2t_asm < 0)
        return asked == 2 ? 2 : 6;
    return (uint16_t)(pt_size(s, plan->o2t_asm) + 6u);
}

static uint16_t t2o_wanted(const drsim_t *s, const fo_plan_t *plan)
{
    return (uint16_t)(pt_size(s, plan->t2o_asm) + 2u);
}

static bool same_originator(const drsim_conn_t *c, uint16_t vendor, uint32_t orig)
{
    return c->vendor == vendor && c->orig_serial == orig;
}

static drsim_conn_t *conn_by_triad(drsim_t *s, uint16_t serial, uint16_t vendor,
                                   uint32_t orig)
{
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++) {
        drsim_conn_t *c = &s->conn[i];
        if (c->used && c->conn_serial == serial && c->vendor == vendor &&
            c->orig_serial == orig)
            return c;
    }
    return NULL;
}

/* A listen-only connection joins the data of an exclusive owner or
 * input-only connection of the same T->O assembly (multicast on a real
 * target); without one there is nothing to listen to. */
static bool t2o_produced(const drsim_t *s, int t2o)
{
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++)
        if (s->conn[i].used && !s->conn[i].listen_only && !s->conn[i].held &&
            s->conn[i].t2o_asm == t2o)
            return true;
    return false;
}

/* Exclusive ownership of an O->T assembly, as OpENer decides it
 * (appcontype.c, GetExclusiveOwnerConnection): an established owner
 * refuses every other open of it, the same originator's too (0x0106); an
 * owner that timed out (held) may be taken over by its own originator,
 * same vendor ID and originator serial, and refuses everyone else.
 * Returns 0 or CM_OWNERSHIP; *takeover is the held owner to close when
 * the open succeeds, *owner the one that refused it. */
static uint16_t ownership(drsim_t *s, const dr_fwd_open_t *fo, int o2t_asm,
                          drsim_conn_t **takeover, const drsim_conn_t **owner)
{
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++) {
        drsim_conn_t *c = &s->conn[i];
        if (!c->used || c->o2t_asm < 0 || c->o2t_asm != o2t_asm)
            continue;
        if (c->held && same_originator(c, fo->vendor, fo->orig_serial)) {
            *takeover = c;
            continue;
        }
        *owner = c;
        return CM_OWNERSHIP;
    }
    return 0;
}

static bool rpi_ok(uint32_t us)
{
    return us >= DRSIM_RPI_MIN_US && us <= DRSIM_RPI_MAX_US;
}

/* Every check a Forward Open must pass, in the order a target makes them.
 * Returns 0 or the extended status; *want is the size for 0x0109,
 * *takeover and *owner as ownership() says. */
static uint16_t fo_check(drsim_t *s, const dr_fwd_open_t *fo, fo_plan_t *plan,
                         uint16_t *want, drsim_conn_t **takeover,
                         const drsim_conn_t **owner)
{
    uint16_t ext = fo_path(s, fo, plan);
    if (s->cfg.refuse_fo != 0) {
        /* Fault injection; the size named for 0x0109 is the right one. */
        *want = ext == 0 ? o2t_wanted(s, plan, fo->o2t.size) : 0;
        return s->cfg.refuse_fo;
    }
    if (ext != 0)
        return ext;
    const drsim_conn_t *dup = conn_by_triad(s, fo->conn_serial, fo->vendor, fo->orig_serial);
    if (dup != NULL && !dup->held) /* a held one's triad: a takeover below */
        return CM_DUPLICATE;
    /* Class 1, cyclic or change-of-state, originator is the client. */
    unsigned cls = fo->transport & 0x0Fu, trig = (fo->transport >> 4) & 0x07u;
    if (cls != 1 || trig > 1 || (fo->transport & 0x80u))
        return CM_TRANSPORT;
    if (fo->o2t.type != DR_CONN_TYPE_P2P)
        return CM_O2T_TYPE;
    if (fo->t2o.type != DR_CONN_TYPE_P2P) /* no multicast in drsim */
        return CM_T2O_TYPE;
    *want = o2t_wanted(s, plan, fo->o2t.size);
    if (fo->o2t.size != *want)
        return CM_SIZE;
    *want = t2o_wanted(s, plan);
    if (fo->t2o.size != *want)
        return CM_SIZE;
    if (!rpi_ok(fo->o2t_rpi_us) || !rpi_ok(fo->t2o_rpi_us))
        return CM_RPI;
    if (plan->o2t_asm >= 0 && ownership(s, fo, plan->o2t_asm, takeover, owner) != 0)
        return CM_OWNERSHIP;
    if (plan->listen_only && !t2o_produced(s, plan->t2o_asm))
        return CM_NOT_LISTEN_ONLY;
    /* the connection taken over gives its slot */
    if (drsim_conn_count(s) - (*takeover != NULL ? 1u : 0u) >= s->cfg.max_conns)
        return CM_OUT_OF_CONNS;
    return 0;
}

static uint32_t new_cid(drsim_t *s)
{
    uint32_t cid;
    do
        cid = s->next_cid++;
    while (cid == 0 || drsim_conn_by_o2t(s, cid) != NULL);
    return cid;
}

/* The interval drsim produces at for an RPI: the RPI itself, or with
 * --tick rounded up to a multiple of the tick, as adapters with a coarser
 * timer do (e.g. 10 ms for a 5 ms request). */
static uint32_t api_of(const drsim_t *s, uint32_t rpi_us)
{
    uint32_t tick = s->cfg.tick_us;
    if (tick == 0 || rpi_us % tick == 0)
        return rpi_us;
    return (rpi_us / tick + 1u) * tick;
}

static drsim_conn_t *conn_open(req_ctx_t *ctx, const dr_fwd_open_t *fo,
                               const fo_plan_t *plan)
{
    drsim_t *s = ctx->s;
    drsim_conn_t *c = NULL;
    for (unsigned i = 0; i < DRSIM_MAX_CONNS && c == NULL; i++)
        if (!s->conn[i].used)
            c = &s->conn[i];
    if (c == NULL)
        return NULL;
    memset(c, 0, sizeof *c);
    c->used = true;
    c->o2t_cid = new_cid(s);
    c->t2o_cid = fo->t2o_cid != 0 ? fo->t2o_cid : new_cid(s);
    c->conn_serial = fo->conn_serial;
    c->vendor = fo->vendor;
    c->orig_serial = fo->orig_serial;
    c->o2t_asm = plan->o2t_asm;
    c->t2o_asm = plan->t2o_asm;
    c->o2t_point = plan->o2t_point;
    c->t2o_point = plan->t2o_point;
    c->config_inst = plan->config;
    c->listen_only = plan->listen_only;
    c->o2t_run_idle = plan->o2t_asm >= 0 || fo->o2t.size == 6;
    c->o2t_data_len = plan->o2t_asm >= 0 ? pt_size(s, plan->o2t_asm) : 0;
    /* Timers run in nanoseconds: the APIs are the RPIs, unrounded unless
     * --tick asks for a coarser one. */
    c->o2t_api_us = api_of(s, fo->o2t_rpi_us);
    c->t2o_api_us = api_of(s, fo->t2o_rpi_us);
    c->timeout_ns = (uint64_t)c->o2t_api_us * 1000u * (4u << (fo->timeout_mult & 7u));
    c->opened_ns = ctx->now;
    c->next_produce_ns = ctx->now; /* first T->O right after the reply */
    /* T->O goes where the originator's 0x8001 item says, else to its
     * address at UDP 2222; a zero address or port means "the usual".
     * --t2o-to-peer: OpENer's rule, the item's port only, the address
     * always the TCP peer's (docs/interop.md). */
    c->t2o_dest.addr = ctx->peer->addr;
    c->t2o_dest.port = DR_ENIP_UDP_PORT;
    if (ctx->t2o_sa != NULL) {
        if (ctx->t2o_sa->addr != 0 && !s->cfg.t2o_to_peer)
            c->t2o_dest.addr = ctx->t2o_sa->addr;
        if (ctx->t2o_sa->port != 0)
            c->t2o_dest.port = ctx->t2o_sa->port;
    }
    return c;
}

static void conn_end(drsim_t *s, drsim_conn_t *c, const char *why);

static void forward_open(req_ctx_t *ctx, const dr_cip_req_t *rq, dr_wr_t *w)
{
    bool large = rq->service == DR_CIP_SVC_LARGE_FORWARD_OPEN;
    dr_fwd_open_t fo;
    dr_status_t st = dr_fwd_open_parse(rq->data, rq->data_len, large, &fo);
    if (st != DR_OK) {
        reply(w, rq->service, st == DR_ELONG ? GS_TOO_MUCH_DATA : GS_NOT_ENOUGH_DATA,
              NULL, 0);
        return;
    }
    fo_plan_t plan;
    memset(&plan, 0, sizeof plan);
    uint16_t want = 0;
    drsim_conn_t *takeover = NULL;
    const drsim_conn_t *owner = NULL;
    uint16_t ext = fo_check(ctx->s, &fo, &plan, &want, &takeover, &owner);
    if (ext == 0 && takeover != NULL)
        conn_end(ctx->s, takeover, "taken over by its originator");
    drsim_conn_t *c = ext == 0 ? conn_open(ctx, &fo, &plan) : NULL;
    if (ext == 0 && c == NULL)
        ext = CM_OUT_OF_CONNS;
    if (ext != 0) {
        uint16_t e[2] = {ext, want};
        dr_cip_rsp_write(w, rq->service, GS_CONN_FAILURE, e, ext == CM_SIZE ? 2 : 1,
                         NULL, 0);
        dr_fwd_fail_write(w, fo.conn_serial, fo.vendor, fo.orig_serial);
        drsim_log(1, "forward open %u/%u/%u refused: 0x01/0x%04X %s",
                  (unsigned)fo.conn_serial, (unsigned)fo.vendor,
                  (unsigned)fo.orig_serial, (unsigned)ext,
                  dr_strerror(DR_CIP(GS_CONN_FAILURE, ext)));
        if (owner != NULL)
            drsim_log(1, "  %s is owned by connection 0x%08X (%s) of originator"
                      " vendor 0x%04X serial 0x%08X",
                      pt_name(ctx->s, owner->o2t_asm),
                      (unsigned)owner->o2t_cid, owner->held ? "timed out, held" : "established",
                      (unsigned)owner->vendor, (unsigned)owner->orig_serial);
        return;
    }
    dr_fwd_open_reply_t r = {
        .o2t_cid = c->o2t_cid, .t2o_cid = c->t2o_cid,
        .conn_serial = c->conn_serial, .vendor = c->vendor,
        .orig_serial = c->orig_serial,
        .o2t_api_us = c->o2t_api_us, .t2o_api_us = c->t2o_api_us};
    if (ctx->s->cfg.api_requested) { /* --api-report requested */
        r.o2t_api_us = fo.o2t_rpi_us;
        r.t2o_api_us = fo.t2o_rpi_us;
    }
    dr_cip_rsp_write(w, rq->service, GS_OK, NULL, 0, NULL, 0);
    dr_fwd_open_reply_write(w, &r);
    ctx->o2t_sa = true;
    char ip[16];
    drsim_log(1, "connection open: O->T %u (0x%08X, %s) T->O %u (0x%08X) -> %s:%u,"
              " API %u/%u us, timeout %llu ms",
              (unsigned)c->o2t_point, (unsigned)c->o2t_cid,
              c->o2t_asm >= 0 ? pt_name(ctx->s, c->o2t_asm) : "heartbeat",
              (unsigned)c->t2o_point, (unsigned)c->t2o_cid,
              ip_text(c->t2o_dest.addr, ip), (unsigned)c->t2o_dest.port,
              (unsigned)c->o2t_api_us, (unsigned)c->t2o_api_us,
              (unsigned long long)(c->timeout_ns / 1000000u));
}

/* The close line ends with the O->T timing: "O->T N in T us, shortest gap
 * G us, K under 3/4 API" (N packets consumed from the first to the last
 * arrival, T apart), which tests/gateway/test_link.py reads. */
static void conn_close(drsim_conn_t *c, const char *why)
{
    uint64_t span = c->consumed > 0 ? c->last_rx_ns - c->o2t_first_ns : 0;
    uint64_t gap = c->consumed > 1 ? c->o2t_min_gap_ns : 0;
    drsim_log(1, "connection 0x%08X closed (%s): %llu produced, %llu consumed,"
              " %llu applied, %llu stale, %llu/%llu dropped in/out;"
              " O->T %llu in %llu us, shortest gap %llu us, %llu under 3/4 API",
              (unsigned)c->o2t_cid, why, (unsigned long long)c->produced,
              (unsigned long long)c->consumed, (unsigned long long)c->applied,
              (unsigned long long)c->stale, (unsigned long long)c->rx_dropped,
              (unsigned long long)c->produce_dropped, (unsigned long long)c->consumed,
              (unsigned long long)(span / 1000u), (unsigned long long)(gap / 1000u),
              (unsigned long long)c->o2t_short);
    memset(c, 0, sizeof *c);
}

/* Closes c; when it was the last connection producing its T->O assembly
 * (an owner or input-only one), the listen-only connections on that
 * assembly go with it: they have nothing left to listen to, and their
 * originators see them time out. OpENer does the same only when the
 * producer is multicast (it closes the listeners when the last master
 * connection of a multicast input point closes, by Forward Close or
 * timeout); drsim does it for every producer, the stricter case for an
 * originator. */
static void conn_end(drsim_t *s, drsim_conn_t *c, const char *why)
{
    bool producer = !c->listen_only;
    int t2o = c->t2o_asm;
    conn_close(c, why); /* logged first: the listeners' lines follow it */
    if (!producer || t2o_produced(s, t2o))
        return;
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++)
        if (s->conn[i].used && s->conn[i].listen_only && s->conn[i].t2o_asm == t2o)
            conn_close(&s->conn[i], "its producer closed");
}

static void forward_close(req_ctx_t *ctx, const dr_cip_req_t *rq, dr_wr_t *w)
{
    dr_fwd_close_t fc;
    dr_status_t st = dr_fwd_close_parse(rq->data, rq->data_len, &fc);
    if (st != DR_OK) {
        reply(w, rq->service, st == DR_ELONG ? GS_TOO_MUCH_DATA : GS_NOT_ENOUGH_DATA,
              NULL, 0);
        return;
    }
    drsim_conn_t *c = conn_by_triad(ctx->s, fc.conn_serial, fc.vendor, fc.orig_serial);
    if (c == NULL) {
        uint16_t e = CM_NOT_FOUND;
        dr_cip_rsp_write(w, rq->service, GS_CONN_FAILURE, &e, 1, NULL, 0);
        dr_fwd_fail_write(w, fc.conn_serial, fc.vendor, fc.orig_serial);
        drsim_log(1, "forward close %u/%u/%u: no such connection",
                  (unsigned)fc.conn_serial, (unsigned)fc.vendor,
                  (unsigned)fc.orig_serial);
        return;
    }
    conn_end(ctx->s, c, "forward close");
    dr_cip_rsp_write(w, rq->service, GS_OK, NULL, 0, NULL, 0);
    dr_fwd_close_reply_write(w, fc.conn_serial, fc.vendor, fc.orig_serial);
}

static void dispatch(req_ctx_t *ctx, const uint8_t *req, size_t len, int depth,
                     dr_wr_t *w);

/* Unconnected Send: answer the embedded request as if it came directly;
 * the route path names this device, so it is not followed. One with no
 * embedded request is refused as an Unconnected Send (answering it as
 * service 0x00 was found by fuzz_sim_request). */
static void unconnected_send(req_ctx_t *ctx, const dr_cip_req_t *rq, int depth,
                             dr_wr_t *w)
{
    dr_ucmm_send_t us;
    if (depth >= UCMM_MAX_DEPTH ||
        dr_ucmm_send_parse(rq->data, rq->data_len, &us) != DR_OK || us.message_len == 0) {
        uint16_t e = CM_UCMM_PARAM;
        dr_cip_rsp_write(w, rq->service, GS_CONN_FAILURE, &e, 1, NULL, 0);
        return;
    }
    dispatch(ctx, us.message, us.message_len, depth + 1, w);
}

static void cm_service(req_ctx_t *ctx, const dr_cip_req_t *rq,
                       const dr_epath_t *p, int depth, dr_wr_t *w)
{
    if (p->inst == 0) {
        class_attribute(w, rq, p, 1, 1, 1);
        return;
    }
    if (p->inst != 1) {
        reply(w, rq->service, GS_PATH_UNKNOWN, NULL, 0);
        return;
    }
    switch (rq->service) {
    case DR_CIP_SVC_LARGE_FORWARD_OPEN:
        if (ctx->s->cfg.no_large_fo) {
            reply(w, rq->service, GS_SERVICE, NULL, 0);
            break;
        }
        forward_open(ctx, rq, w);
        break;
    case DR_CIP_SVC_FORWARD_OPEN:
        forward_open(ctx, rq, w);
        break;
    case DR_CIP_SVC_FORWARD_CLOSE:
        forward_close(ctx, rq, w);
        break;
    case DR_CIP_SVC_UNCONNECTED_SEND:
        unconnected_send(ctx, rq, depth, w);
        break;
    default:
        reply(w, rq->service, GS_SERVICE, NULL, 0);
        break;
    }
}

/* ---- Message Router ---------------------------------------------------- */

static void dispatch(req_ctx_t *ctx, const uint8_t *req, size_t len, int depth,
                     dr_wr_t *w)
{
    dr_cip_req_t rq;
    if (dr_cip_req_parse(req, len, &rq) != DR_OK) {
        reply(w, len > 0 ? (uint8_t)(req[0] & 0x7Fu) : 0, GS_PATH_SEGMENT, NULL, 0);
        return;
    }
    rq.service &= 0x7Fu; /* a request never carries the reply bit */
    dr_epath_t p;
    if (dr_epath_parse(rq.path, rq.path_len, &p) != DR_OK || !p.has_cls ||
        !p.has_inst) {
        reply(w, rq.service, GS_PATH_SEGMENT, NULL, 0);
        return;
    }
    drsim_log(2, "request 0x%02X class 0x%02X instance %u attribute %d (%u bytes)",
              (unsigned)rq.service, (unsigned)p.cls, (unsigned)p.inst,
              p.has_attr ? (int)p.attr : -1, (unsigned)rq.data_len);
    switch (p.cls) {
    case DR_CIP_CLASS_IDENTITY:
        identity_service(ctx, &rq, &p, w);
        break;
    case DR_CIP_CLASS_ASSEMBLY:
        assembly_service(ctx, &rq, &p, w);
        break;
    case DR_CIP_CLASS_CONNECTION_MANAGER:
        cm_service(ctx, &rq, &p, depth, w);
        break;
    default:
        reply(w, rq.service, GS_PATH_UNKNOWN, NULL, 0);
        break;
    }
}

size_t drsim_cip(drsim_t *s, const drsim_peer_t *peer, uint64_t now_ns,
                 const uint8_t *req, size_t len, const dr_sockaddr_t *t2o_sa,
                 uint8_t *out, size_t cap, bool *o2t_sa_out)
{
    req_ctx_t ctx = {s, peer, now_ns, t2o_sa, false};
    dr_wr_t w;
    dr_wr_init(&w, out, cap);
    dispatch(&ctx, req, len, 0, &w);
    if (o2t_sa_out != NULL)
        *o2t_sa_out = ctx.o2t_sa;
    return w.overflow ? 0 : w.len;
}

/* ---- encapsulation --------------------------------------------------------- */

static void list_identity(drsim_t *s, const drsim_peer_t *peer, dr_wr_t *w)
{
    identity_refresh(s, peer->local_addr);
    dr_list_identity_write(w, &s->identity);
}

static void list_services(dr_wr_t *w)
{
    dr_list_services_write(w, DR_SVC_FLAG_CIP_TCP | DR_SVC_FLAG_CLASS01_UDP);
}

static uint32_t register_session(drsim_t *s, drsim_peer_t *peer,
                                 const dr_encap_t *h, const uint8_t *body,
                                 dr_encap_t *rh, dr_wr_t *w)
{
    uint16_t version, options;
    if (dr_register_parse(body, h->length, &version, &options) != DR_OK)
        return ES_INVALID_LENGTH;
    dr_register_write(w, 1, 0);
    if (version != 1)
        return ES_PROTOCOL_VERSION;
    if (peer->session != 0) { /* one session per TCP connection */
        rh->session = peer->session;
        return ES_INVALID_COMMAND;
    }
    do
        peer->session = s->next_session++;
    while (peer->session == 0);
    rh->session = peer->session;
    char ip[16];
    drsim_log(1, "session 0x%08X registered by %s:%u", (unsigned)peer->session,
              ip_text(peer->addr, ip), (unsigned)peer->port);
    return 0;
}

/* SendRRData: one CIP request in a 0x00B2 item, after a null address. */
static uint32_t send_rr_data(drsim_t *s, const drsim_peer_t *peer, uint64_t now,
                             const dr_encap_t *h, const uint8_t *body, dr_wr_t *w)
{
    if (peer->session == 0 || h->session != peer->session)
        return ES_INVALID_SESSION;
    uint32_t iface;
    uint16_t timeout;
    dr_cpf_t cpf;
    if (dr_rr_parse(body, h->length, &iface, &timeout, &cpf) != DR_OK)
        return ES_INCORRECT_DATA;
    const dr_cpf_item_t *addr = dr_cpf_find(&cpf, DR_CPF_NULL);
    const dr_cpf_item_t *data = dr_cpf_find(&cpf, DR_CPF_UNCONNECTED_DATA);
    if (iface != 0 || addr == NULL || addr->length != 0 || data == NULL)
        return ES_INCORRECT_DATA;
    const dr_cpf_item_t *sa_item = dr_cpf_find(&cpf, DR_CPF_SOCKADDR_T2O);
    dr_sockaddr_t t2o_sa;
    if (sa_item != NULL && dr_cpf_sockaddr_parse(sa_item, &t2o_sa) != DR_OK)
        return ES_INCORRECT_DATA;

    uint8_t rsp[DR_ENCAP_MAX_LEN];
    bool o2t_sa = false;
    size_t n = drsim_cip(s, peer, now, data->data, data->length,
                         sa_item ? &t2o_sa : NULL, rsp, sizeof rsp, &o2t_sa);
    if (o2t_sa && s->lost_fo_replies < s->cfg.lose_fo_replies) {
        /* --lose-forward-open-reply: opened, but the originator never
         * hears of it (field-facts.md, "Late Forward Open replies") */
        s->lost_fo_replies++;
        drsim_log(1, "forward open reply not sent (--lose-forward-open-reply, %u of %u)",
                  s->lost_fo_replies, s->cfg.lose_fo_replies);
        return ES_LOST_REPLY;
    }
    dr_rr_begin(w, 0);
    dr_cpf_begin(w, o2t_sa ? 3 : 2);
    size_t m = dr_cpf_item_begin(w, DR_CPF_NULL);
    dr_cpf_item_end(w, m);
    m = dr_cpf_item_begin(w, DR_CPF_UNCONNECTED_DATA);
    dr_wr_bytes(w, rsp, n);
    dr_cpf_item_end(w, m);
    if (o2t_sa) {
        /* Where the originator sends O->T: our UDP port, on the address
         * the request came in on unless we are bound to one. */
        dr_sockaddr_t sa = {s->cfg.address ? s->cfg.address : peer->local_addr,
                            s->cfg.udp_port};
        dr_cpf_sockaddr_write(w, DR_CPF_SOCKADDR_O2T, sa);
    }
    if (s->cfg.trailing_item && n > 0 &&
        (rsp[0] == (DR_CIP_SVC_FORWARD_OPEN | DR_CIP_REPLY) ||
         rsp[0] == (DR_CIP_SVC_LARGE_FORWARD_OPEN | DR_CIP_REPLY))) {
        /* --trailing-item: like an adapter seen in the field, echo the
         * request's T->O socket address after the items we declared
         * (the originator's address, port 2222, if it sent none). */
        dr_sockaddr_t echo = sa_item ? t2o_sa : (dr_sockaddr_t){peer->addr, DR_ENIP_UDP_PORT};
        dr_cpf_sockaddr_write(w, DR_CPF_SOCKADDR_T2O, echo);
    }
    return 0;
}

static drsim_action_t finish(const dr_encap_t *rh, uint32_t status, dr_wr_t *w,
                             uint8_t *out, size_t cap, size_t *out_len)
{
    dr_encap_t h = *rh;
    h.status = status;
    h.options = 0;
    size_t body = w->overflow ? 0 : w->len;
    if (dr_encap_write(out, cap, &h, body) != DR_OK)
        return DRSIM_CLOSE;
    *out_len = DR_ENCAP_HEADER_LEN + body;
    return DRSIM_REPLY;
}

drsim_action_t drsim_encap(drsim_t *s, drsim_peer_t *peer, uint64_t now_ns,
                           const uint8_t *frame, size_t len, uint8_t *out,
                           size_t cap, size_t *out_len)
{
    dr_encap_t h;
    const uint8_t *body;
    if (cap < DR_ENCAP_HEADER_LEN || dr_encap_parse(frame, len, &h, &body) != DR_OK)
        return DRSIM_CLOSE; /* the stream has lost its framing */
    dr_wr_t w;
    dr_wr_init(&w, out + DR_ENCAP_HEADER_LEN, cap - DR_ENCAP_HEADER_LEN);
    dr_encap_t rh = h;
    uint32_t status = 0;
    drsim_log(2, "encapsulation command 0x%04X, %u bytes", (unsigned)h.command,
              (unsigned)h.length);
    switch (h.command) {
    case DR_ENCAP_NOP:
        return DRSIM_SILENT; /* NOP is never answered */
    case DR_ENCAP_LIST_IDENTITY:
        list_identity(s, peer, &w);
        break;
    case DR_ENCAP_LIST_SERVICES:
        list_services(&w);
        break;
    case DR_ENCAP_LIST_INTERFACES:
        dr_cpf_begin(&w, 0);
        break;
    case DR_ENCAP_REGISTER_SESSION:
        rh.session = 0;
        status = register_session(s, peer, &h, body, &rh, &w);
        break;
    case DR_ENCAP_UNREGISTER_SESSION:
        if (peer->session != 0 && h.session == peer->session) {
            drsim_log(1, "session 0x%08X unregistered", (unsigned)peer->session);
            return DRSIM_CLOSE;
        }
        status = ES_INVALID_SESSION;
        break;
    case DR_ENCAP_SEND_RR_DATA:
        status = send_rr_data(s, peer, now_ns, &h, body, &w);
        if (status == ES_LOST_REPLY)
            return DRSIM_SILENT;
        if (status != 0)
            w.len = 0;
        break;
    default:
        status = ES_INVALID_COMMAND;
        break;
    }
    return finish(&rh, status, &w, out, cap, out_len);
}

drsim_action_t drsim_encap_udp(drsim_t *s, const drsim_peer_t *peer,
                               const uint8_t *frame, size_t len, uint8_t *out,
                               size_t cap, size_t *out_len)
{
    dr_encap_t h;
    const uint8_t *body;
    if (cap < DR_ENCAP_HEADER_LEN || dr_encap_parse(frame, len, &h, &body) != DR_OK)
        return DRSIM_SILENT;
    dr_wr_t w;
    dr_wr_init(&w, out + DR_ENCAP_HEADER_LEN, cap - DR_ENCAP_HEADER_LEN);
    if (h.command == DR_ENCAP_LIST_IDENTITY)
        list_identity(s, peer, &w);
    else if (h.command == DR_ENCAP_LIST_SERVICES)
        list_services(&w);
    else
        return DRSIM_SILENT;
    return finish(&h, 0, &w, out, cap, out_len);
}

/* ---- Class 1 I/O ------------------------------------------------------------ */

/* The O->T packet taken at now_ns, in the connection's timing figures. */
static void o2t_timing(drsim_conn_t *c, uint64_t now_ns)
{
    if (!c->o2t_seen) {
        c->o2t_first_ns = now_ns;
        c->o2t_min_gap_ns = UINT64_MAX;
        return;
    }
    uint64_t gap = now_ns > c->last_rx_ns ? now_ns - c->last_rx_ns : 0;
    if (gap < c->o2t_min_gap_ns)
        c->o2t_min_gap_ns = gap;
    if (gap * 4u < (uint64_t)c->o2t_api_us * 3000u)
        c->o2t_short++;
}

void drsim_io_receive(drsim_t *s, uint64_t now_ns, const dr_sockaddr_t *from,
                      const uint8_t *buf, size_t len)
{
    dr_io_frame_t f;
    char ip[16];
    if (dr_io_frame_parse(buf, len, false, &f) != DR_OK) {
        drsim_log(2, "malformed I/O packet from %s:%u", ip_text(from->addr, ip),
                  (unsigned)from->port);
        return;
    }
    drsim_conn_t *c = drsim_conn_by_o2t(s, f.cid);
    if (c == NULL || c->held) { /* a timed-out connection stays so */
        drsim_log(2, "I/O packet for %s connection 0x%08X", c ? "a timed-out" : "unknown",
                  (unsigned)f.cid);
        return;
    }
    /* Parse again now that the connection says whether run/idle is there. */
    if (c->o2t_run_idle && dr_io_frame_parse(buf, len, true, &f) != DR_OK)
        return;
    if (drop_packet(s)) {
        c->rx_dropped++;
        return;
    }
    if (f.data_len != c->o2t_data_len) {
        drsim_log(2, "connection 0x%08X: %u data bytes, want %u", (unsigned)c->o2t_cid,
                  (unsigned)f.data_len, (unsigned)c->o2t_data_len);
        return;
    }
    /* A packet that is not newer than the last one (duplicate, reordered)
     * is discarded whole; the first one is taken whatever its number. */
    if (c->o2t_seen && !dr_seq32_newer(f.encap_seq, c->o2t_encap_seq)) {
        c->stale++;
        return;
    }
    bool fresh = !c->o2t_seen || dr_seq16_newer(f.cip_seq, c->o2t_cip_seq);
    bool run = !c->o2t_run_idle || (f.run_idle & 1u);
    if (c->o2t_seen && run != c->run)
        drsim_log(1, "connection 0x%08X: %s", (unsigned)c->o2t_cid, run ? "run" : "idle");
    o2t_timing(c, now_ns);
    c->o2t_seen = true;
    c->o2t_encap_seq = f.encap_seq;
    c->last_rx_ns = now_ns;
    c->run = run;
    c->consumed++;
    if (!fresh)
        return;
    c->o2t_cip_seq = f.cip_seq;
    if (run && c->o2t_asm >= 0) {
        pt_write(s, c->o2t_asm, f.data);
        c->applied++;
    }
}

static uint64_t timeout_deadline(const drsim_t *s, const drsim_conn_t *c)
{
    if (c->held)
        return s->cfg.owner_hold_ns != 0 ? c->held_ns + s->cfg.owner_hold_ns : UINT64_MAX;
    if (c->o2t_seen)
        return c->last_rx_ns + c->timeout_ns;
    uint64_t grace = c->timeout_ns > DRSIM_FIRST_PACKET_NS ? c->timeout_ns
                                                           : DRSIM_FIRST_PACKET_NS;
    return c->opened_ns + grace;
}

/* The T->O production period for an API, on drsim's clock
 * (cfg.clock_ppm): a clock that runs fast produces more often. */
static uint64_t production_period_ns(const drsim_t *s, uint32_t api_us)
{
    uint64_t ns = (uint64_t)api_us * 1000u;
    if (s->cfg.clock_ppm == 0)
        return ns;
    return ns * 1000000u / (uint64_t)(1000000 + (int64_t)s->cfg.clock_ppm);
}

static void produce(drsim_t *s, drsim_conn_t *c, uint64_t now,
                    drsim_send_fn send, void *ctx)
{
    uint64_t api_ns = production_period_ns(s, c->t2o_api_us);
    if (s->cfg.stop_producing_ns != 0 && now - c->opened_ns >= s->cfg.stop_producing_ns) {
        if (!c->stopped)
            drsim_log(1, "connection 0x%08X: stop producing (fault injection)",
                      (unsigned)c->o2t_cid);
        c->stopped = true;
        return;
    }
    uint8_t buf[DR_POINT_MAX_SIZE];
    const uint8_t *data = pt_read(s, c->t2o_asm, buf);
    size_t size = pt_size(s, c->t2o_asm);
    bool first = c->produced + c->produce_dropped == 0;
    /* The encapsulation sequence number moves with every packet; the CIP
     * sequence count with new data only under --seq-on-change. */
    c->t2o_encap_seq++;
    if (!s->cfg.seq_on_change || first || memcmp(c->last_t2o, data, size) != 0)
        c->t2o_cip_seq++;
    if (s->cfg.seq_on_change)
        memcpy(c->last_t2o, data, size);
    dr_io_frame_t f = {.cid = c->t2o_cid, .encap_seq = c->t2o_encap_seq,
                       .cip_seq = c->t2o_cip_seq, .data = data, .data_len = size,
                       .has_run_idle = false};
    uint8_t pkt[64 + DR_POINT_MAX_SIZE];
    size_t n;
    if (dr_io_frame_write(pkt, sizeof pkt, &f, &n) == DR_OK) {
        if (s->cfg.drop_t2o || drop_packet(s))
            c->produce_dropped++;
        else {
            send(ctx, &c->t2o_dest, pkt, n);
            c->produced++;
        }
    }
    /* Next deadline on the absolute grid start_ns + k * API, shared by
     * every connection with this API, so six connections at 1 ms cost one
     * wake-up per millisecond, not six. Periods we could not make (a
     * stalled process) are skipped, not bunched up. After the first
     * packet (sent at once on open) the next one waits at least API / 2. */
    uint64_t since = now > s->start_ns ? now - s->start_ns : 0;
    uint64_t next = s->start_ns + (since / api_ns + 1u) * api_ns;
    if (c->produced + c->produce_dropped == 1 && next - now < api_ns / 2u)
        next += api_ns;
    c->next_produce_ns = next;
}

/* An exclusive owner whose originator went silent is not freed: like an
 * ODVA adapter, drsim keeps it timed out, producing nothing, and lets only
 * its originator take it over (ownership()), for --owner-hold or until it
 * stops. Input-only and listen-only connections simply close. */
static void conn_timeout(drsim_t *s, drsim_conn_t *c, uint64_t now)
{
    const char *why = c->o2t_seen ? "O->T timeout" : "no O->T packet";
    if (c->held) {
        conn_end(s, c, "timed out and held for --owner-hold");
        return;
    }
    if (c->o2t_asm < 0) {
        conn_end(s, c, why);
        return;
    }
    drsim_log(1, "connection 0x%08X timed out (%s): held, %s may only be taken over by"
              " its originator, vendor 0x%04X serial 0x%08X; %llu produced, %llu consumed",
              (unsigned)c->o2t_cid, why, pt_name(s, c->o2t_asm),
              (unsigned)c->vendor, (unsigned)c->orig_serial,
              (unsigned long long)c->produced, (unsigned long long)c->consumed);
    c->held = true;
    c->held_ns = now;
    int t2o = c->t2o_asm;
    if (t2o_produced(s, t2o))
        return;
    /* its listeners have nothing left to listen to, as in conn_end */
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++)
        if (s->conn[i].used && s->conn[i].listen_only && s->conn[i].t2o_asm == t2o)
            conn_close(&s->conn[i], "its producer closed");
}

void drsim_run(drsim_t *s, uint64_t now_ns, drsim_send_fn send, void *ctx)
{
    /* The model first, the packets after: a packet due at the same moment
     * as a model step carries that step, as an explicit Get right after
     * it does (produced before, Class 1 data was one step behind Get). */
    if (now_ns >= s->next_model_ns) {
        drsim_robot_update(&s->robot, now_ns, &s->img);
        s->next_model_ns += DRSIM_MODEL_PERIOD_NS;
        if (s->next_model_ns <= now_ns)
            s->next_model_ns = now_ns + DRSIM_MODEL_PERIOD_NS;
    }
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++) {
        drsim_conn_t *c = &s->conn[i];
        if (!c->used)
            continue;
        if (now_ns >= timeout_deadline(s, c)) {
            conn_timeout(s, c, now_ns);
            continue;
        }
        if (!c->stopped && !c->held && now_ns >= c->next_produce_ns)
            produce(s, c, now_ns, send, ctx);
    }
}

uint64_t drsim_next_deadline(const drsim_t *s)
{
    uint64_t t = s->next_model_ns;
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++) {
        const drsim_conn_t *c = &s->conn[i];
        if (!c->used)
            continue;
        uint64_t d = timeout_deadline(s, c);
        if (d < t)
            t = d;
        if (!c->stopped && !c->held && c->next_produce_ns < t)
            t = c->next_produce_ns;
    }
    return t;
}
