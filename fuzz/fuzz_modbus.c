/* SPDX-License-Identifier: MIT */
/*
 * Modbus TCP requests through the gateway's check-and-apply path, as a
 * client's byte stream reaches it: gw_mbap_frame cuts the stream into
 * ADUs, gw_mbs_decide checks each one against the register map and the
 * client's rights and applies it to the units' images (gw_regmap_read /
 * gw_regmap_write) and builds the reply, which gw_mbap_reply frames. The
 * reply is checked, and compared byte for byte with what libmodbus's
 * modbus_reply / modbus_reply_exception sends for the same decision (on a
 * socketpair here): the gateway answered through libmodbus before its own
 * reply builder, and Modbus TCP clients must see the same bytes.
 *
 * Input layout (gen_corpus.c writes seeds in it):
 *   [flags][k] pattern[k] stream...
 * flags bits 0-1: word order; bits 2-3: on_link_loss (3 = hold); bit 4:
 * link up; bit 5: the client may not write; bit 6: unit 2 exists too
 * (unit 1 always does); bit 7: unmapped_read = exception. The pattern of
 * k & 63 bytes is repeated over every image of every unit; with k bit 6,
 * GPIO inputs own bit_in[3] and io_control.cb_do[1] of every unit; with k
 * bit 7, every unit's write fault is latched. The rest is what the client
 * sends.
 *
 * Properties: a frame the framer refuses ends the stream (the daemon drops
 * the client); every request gets exactly one reply that echoes its MBAP
 * header; an exception changes no unit, byte for byte; a read changes no
 * unit; an accepted write changes only the addressed unit, only its O->T
 * images, only the assemblies it reports dirty (and the control registers
 * when it addresses them), and reads back as written; the client's right
 * to write is asked for writes only, and the server is told of accepted
 * writes only; no write changes a bit a GPIO input owns; with the write
 * fault latched, the only write accepted is the fault reset (HR 1 = 1
 * within HR 0-1), which clears it, and every other gets 0x04 unless an
 * earlier check refused it; the exception codes are the
 * documented ones; no read succeeds past a table's last mapped address; the
 * reply is what libmodbus answers for the same decision.
 */
#include <errno.h>
#include <fcntl.h>
#include <modbus.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "modbus/mbproto.h"
#include "fuzz.h"

/* The gateway's quantity limits (mbproto.h, from the specification) are
 * libmodbus's, against which this fuzzer compares the replies. */
#define SAME_LIMIT(name) typedef char same_##name[GW_MB_##name == MODBUS_##name ? 1 : -1]
SAME_LIMIT(MAX_READ_BITS);
SAME_LIMIT(MAX_WRITE_BITS);
SAME_LIMIT(MAX_READ_REGISTERS);
SAME_LIMIT(MAX_WRITE_REGISTERS);
SAME_LIMIT(MAX_WR_READ_REGISTERS);
SAME_LIMIT(MAX_WR_WRITE_REGISTERS);

#define UNITS 2

static gw_unit_t units[UNITS];
static gw_robot_t robots[UNITS]; /* units[i].robot */
static bool unit2;
static bool read_only;
static unsigned asked; /* may_write calls for the current request */
static unsigned told;  /* wrote calls for the current request */
static int sv[2] = {-1, -1};
static modbus_t *ctx;
static modbus_mapping_t *map;
static gw_mb_result_t res, back;

static gw_unit_t *unit_for(void *user, uint8_t id)
{
    (void)user;
    if (id == 1 || (id == 2 && unit2))
        return &units[id - 1];
    return NULL;
}

static bool may_write(void *client)
{
    (void)client;
    asked++;
    return !read_only;
}

static void wrote(void *client)
{
    (void)client;
    told++;
}

static void setup(void)
{
    if (ctx != NULL)
        return;
    gw_regmap_init();
    FUZZ_CHECK(socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) == 0);
    FUZZ_CHECK(fcntl(sv[1], F_SETFL, O_NONBLOCK) == 0);
    ctx = modbus_new_tcp("127.0.0.1", 502); /* only formats replies */
    map = modbus_mapping_new(GW_AREA_SIZE, GW_AREA_SIZE, GW_AREA_SIZE, GW_AREA_SIZE);
    FUZZ_CHECK(ctx != NULL && map != NULL);
    modbus_set_socket(ctx, sv[0]);
}

/* Byte for byte, padding included: what "unchanged" means here. */
static bool same_bytes(const void *a, const void *b, size_t n)
{
    return memcmp(a, b, n) == 0;
}

static uint16_t be16(const uint8_t *p)
{
    return (uint16_t)(p[0] << 8 | p[1]);
}

static bool is_write_fc(uint8_t fc)
{
    return fc == 0x05 || fc == 0x06 || fc == 0x0F || fc == 0x10 || fc == 0x17;
}

/* FC 43 / MEI 14's reply: its header, then objects in ascending id order
 * filling exactly the PDU, as many as it says. */
static void check_device_id(const gw_mb_result_t *r, const uint8_t *adu)
{
    const uint8_t *p = r->pdu;
    FUZZ_CHECK(r->pdu_len >= 7 && p[0] == 0x2B && p[1] == 0x0E && p[2] == adu[GW_MBAP_LEN + 2]);
    FUZZ_CHECK(p[3] == 0x83 && (p[4] == 0x00 || p[4] == 0xFF));
    size_t n = 7;
    unsigned objects = 0;
    int last = -1;
    while (n < r->pdu_len) {
        FUZZ_CHECK(n + 2 <= r->pdu_len && n + 2u + p[n + 1] <= r->pdu_len);
        FUZZ_CHECK((int)p[n] > last);
        last = p[n];
        n += 2u + p[n + 1];
        objects++;
    }
    FUZZ_CHECK(n == r->pdu_len && objects == p[6] && objects >= 1);
    if (adu[GW_MBAP_LEN + 2] == 4)
        FUZZ_CHECK(objects == 1 && r->pdu[7] == adu[GW_MBAP_LEN + 3]);
}

static bool is_read_fc(uint8_t fc)
{
    return fc >= 0x01 && fc <= 0x04;
}

static bool is_t2o(unsigned a)
{
    return dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O;
}

/* What an accepted write may change in the unit it addressed and its
 * robot (rb: before, ra: after). */
static void check_write_effect(const gw_unit_t *before, const gw_unit_t *after,
                               const gw_robot_t *rb, const gw_robot_t *ra,
                               const gw_mb_result_t *r)
{
    FUZZ_CHECK(r->dirty != 0 || r->area == GW_HOLDING); /* control registers */
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        size_t size = dr_asm_info((dr_asm_t)a)->size;
        bool dirty = (r->dirty >> a) & 1u;
        if (is_t2o(a))
            FUZZ_CHECK(!dirty);
        if (!dirty)
            FUZZ_CHECK(memcmp(rb->img[a], ra->img[a], sizeof rb->img[a]) == 0);
        /* Bytes past the assembly's size are never written. */
        FUZZ_CHECK(memcmp(rb->img[a] + size, ra->img[a] + size,
                          sizeof rb->img[a] - size) == 0);
    }
    FUZZ_CHECK(r->dirty >> DR_ASM_COUNT == 0);
    /* The robot's link facts, name and the rest: only images are written
     * back to it (the images come first). */
    static gw_robot_t rx; /* ra, but the latch a reset cleared */
    rx = *ra;
    if (r->reset)
        rx.fault = rb->fault;
    FUZZ_CHECK(same_bytes((const uint8_t *)rb + sizeof rb->img,
                          (const uint8_t *)&rx + sizeof rx.img, sizeof *rb - sizeof rb->img));
    /* Member by member: *u = tmp need not copy the padding. */
    const gw_status_t *x = &before->status, *y = &after->status;
    FUZZ_CHECK(x->exceptions == y->exceptions && x->clients == y->clients &&
               (rb->fault == ra->fault || r->reset) &&
               x->writer_present == y->writer_present &&
               x->rtu_dropped == y->rtu_dropped && x->rtu_other == y->rtu_other);
    FUZZ_CHECK(before->order == after->order && before->on_loss == after->on_loss &&
               before->robot == after->robot);
    /* A bit a GPIO input drives is the input's. */
    for (unsigned i = 0; i < rb->write_policy.gpio_in_count; i++) {
        dr_ref_t g = rb->write_policy.gpio_in[i];
        size_t size = dr_asm_info((dr_asm_t)g.field->assembly)->size;
        dr_value_t x0, x1;
        FUZZ_CHECK(dr_field_get(rb->img[g.field->assembly], size, g, &x0) == DR_OK &&
                   dr_field_get(ra->img[g.field->assembly], size, g, &x1) == DR_OK &&
                   x0.u == x1.u);
    }
    bool control = r->area == GW_HOLDING && r->addr <= GW_HR_FAULT_RESET;
    if (!control || r->addr > GW_HR_WATCHDOG)
        FUZZ_CHECK(before->watchdog == after->watchdog);
    if (!control || (uint32_t)r->addr + r->count <= GW_HR_FAULT_RESET)
        FUZZ_CHECK(before->fault_reset == after->fault_reset);
    /* The latched reset is only ever set by a write, never cleared. */
    FUZZ_CHECK(!before->fault_reset || after->fault_reset);
}

/* An accepted write reads back as written through the same addresses. */
static void check_read_back(const gw_mb_result_t *w)
{
    uint8_t adu[12] = {0, 1, 0, 0, 0, 6, w->unit_id,
                       w->area == GW_COILS ? 0x01 : 0x03,
                       (uint8_t)(w->addr >> 8), (uint8_t)w->addr,
                       (uint8_t)(w->count >> 8), (uint8_t)w->count};
    const gw_mb_env_t env = {unit_for, NULL, may_write, wrote, NULL, "9.8.7", GW_ORIGIN_MODBUS_TCP, NULL, NULL, NULL};
    /* Writes take at most 1968 bits or 123 registers: one read covers them. */
    FUZZ_CHECK(gw_mbs_decide(adu, sizeof adu, &env, &back) == 0);
    for (uint16_t i = 0; i < w->count; i++) {
        unsigned a = (unsigned)w->addr + i;
        if (w->area == GW_HOLDING && a == GW_HR_FAULT_RESET)
            continue; /* write 1 to reset: reads 0 */
        if (w->area == GW_HOLDING && a >= 1000 && w->values[i] == 0x8000) {
            /* A scaled view (1000 above its REAL): -32768 sets value /
             * scale, and reads saturate at -32767 (-32768 is how a NaN
             * reads); tests/gateway/test_map.py wants exactly this. */
            FUZZ_CHECK(back.values[i] == 0x8001);
            continue;
        }
        FUZZ_CHECK(back.values[i] == w->values[i]);
    }
}

/* What libmodbus sends for the decision (how the gateway answered before
 * it built its replies itself), into rsp; its length. FC 23 and 43 were
 * never libmodbus's: they are skipped (0). */
static size_t libmodbus_reply(const uint8_t *adu, size_t len, int ex, const gw_mb_result_t *r,
                              uint8_t *rsp, size_t size)
{
    uint8_t copy[GW_ADU_MAX];
    memcpy(copy, adu, len);
    if (ex != 0) {
        copy[GW_MBAP_LEN] &= 0x7Fu; /* what the gateway did for libmodbus */
        FUZZ_CHECK(modbus_reply_exception(ctx, copy, (unsigned)ex) >= 0);
    } else if (r->fc == 0x17 || r->fc == 0x2B) {
        return 0;
    } else {
        for (uint16_t i = 0; !r->write && i < r->count; i++) {
            unsigned a = (unsigned)r->addr + i;
            switch (r->area) {
            case GW_COILS: map->tab_bits[a] = (uint8_t)r->values[i]; break;
            case GW_DISCRETE: map->tab_input_bits[a] = (uint8_t)r->values[i]; break;
            case GW_HOLDING: map->tab_registers[a] = r->values[i]; break;
            default: map->tab_input_registers[a] = r->values[i]; break;
            }
        }
        FUZZ_CHECK(modbus_reply(ctx, copy, (int)len, map) >= 0);
    }
    ssize_t n = recv(sv[1], rsp, size, 0);
    FUZZ_CHECK(n > 0);
    uint8_t extra; /* one reply per request: nothing left over */
    FUZZ_CHECK(recv(sv[1], &extra, 1, 0) < 0 && (errno == EAGAIN || errno == EWOULDBLOCK));
    return (size_t)n;
}

/* Check the reply against the decision, and against libmodbus's. */
static void check_reply(const uint8_t *adu, size_t len, int ex, const gw_mb_result_t *r)
{
    uint8_t rsp[GW_ADU_MAX], lm[GW_ADU_MAX + 16];
    size_t rn = gw_mbap_reply(adu, r, rsp);
    FUZZ_CHECK(rn >= 9 && rn <= GW_ADU_MAX);
    size_t ln = libmodbus_reply(adu, len, ex, r, lm, sizeof lm);
    if (ln > 0)
        FUZZ_CHECK(ln == rn && memcmp(lm, rsp, rn) == 0);
    FUZZ_CHECK(memcmp(rsp, adu, 4) == 0);             /* transaction, protocol */
    FUZZ_CHECK(be16(rsp + 4) == rn - 6u);             /* length */
    FUZZ_CHECK(rsp[6] == adu[6]);                     /* unit ID */
    uint8_t fc = adu[GW_MBAP_LEN];
    if (ex != 0) {
        FUZZ_CHECK(rn == 9 && rsp[7] == (uint8_t)(fc | 0x80) && rsp[8] == ex);
        return;
    }
    FUZZ_CHECK(rsp[7] == fc);
    switch (fc) {
    case 0x01:
    case 0x02:
        FUZZ_CHECK(rsp[8] == (r->count + 7u) / 8u && rn == 9u + rsp[8]);
        for (unsigned i = 0; i < r->count; i++)
            FUZZ_CHECK(((rsp[9 + i / 8] >> (i % 8)) & 1u) == r->values[i]);
        break;
    case 0x03:
    case 0x04:
        FUZZ_CHECK(rsp[8] == 2u * r->count && rn == 9u + rsp[8]);
        for (unsigned i = 0; i < r->count; i++)
            FUZZ_CHECK(be16(rsp + 9 + 2 * i) == r->values[i]);
        break;
    case 0x05:
    case 0x06:
        FUZZ_CHECK(rn == len && memcmp(rsp, adu, len) == 0); /* an echo */
        break;
    case 0x17:
    case 0x2B: /* built by mbproto.c: exactly its PDU */
        FUZZ_CHECK(rn == GW_MBAP_LEN + r->pdu_len && memcmp(rsp + 7, r->pdu, r->pdu_len) == 0);
        if (fc == 0x17) {
            FUZZ_CHECK(rsp[8] == 2u * r->rcount);
            for (unsigned i = 0; i < r->rcount; i++)
                FUZZ_CHECK(be16(rsp + 9 + 2 * i) == r->rvalues[i]);
        }
        break;
    default: /* 0x0F, 0x10: address and count */
        FUZZ_CHECK(rn == 12 && be16(rsp + 8) == r->addr && be16(rsp + 10) == r->count);
        break;
    }
}

static void request(const uint8_t *adu, size_t len)
{
    static gw_unit_t before[UNITS];
    static gw_robot_t before_r[UNITS];
    memcpy(before, units, sizeof units);
    memcpy(before_r, robots, sizeof robots);
    const gw_mb_env_t env = {unit_for, NULL, may_write, wrote, NULL, "9.8.7", GW_ORIGIN_MODBUS_TCP, NULL, NULL, NULL};
    asked = told = 0;
    int ex = gw_mbs_decide(adu, len, &env, &res);
    uint8_t fc = adu[GW_MBAP_LEN];
    gw_unit_t *u = unit_for(NULL, adu[6]);

    FUZZ_CHECK(ex == 0 || ex == GW_EX_ILLEGAL_FUNCTION || ex == GW_EX_ILLEGAL_ADDRESS ||
               ex == GW_EX_ILLEGAL_VALUE || ex == 0x0A || ex == GW_EX_TARGET_FAILED ||
               ex == GW_EX_DEVICE_FAILURE);
    FUZZ_CHECK(told == (ex == 0 && is_write_fc(fc)));
    bool latched = u != NULL && before_r[u - units].fault;
    FUZZ_CHECK(res.reset == (latched && ex == 0 && is_write_fc(fc)));
    if (ex == GW_EX_DEVICE_FAILURE)
        FUZZ_CHECK(is_write_fc(fc) && latched);
    if (res.reset) {
        /* Only the reset passes a latched fault, and it clears it. */
        FUZZ_CHECK(!u->robot->fault && res.area == GW_HOLDING &&
                   res.addr <= GW_HR_FAULT_RESET &&
                   (uint32_t)res.addr + res.count == GW_HR_FAULT_RESET + 1u &&
                   res.values[GW_HR_FAULT_RESET - res.addr] == 1);
    }
    FUZZ_CHECK(res.unit_id == adu[6] && res.fc == fc && res.unit == u);
    FUZZ_CHECK((ex == 0x0A) == (u == NULL));
    FUZZ_CHECK((asked > 0) == (u != NULL && is_write_fc(fc))); /* asked for writes only */
    if (u != NULL && !is_read_fc(fc) && !is_write_fc(fc) && fc != 0x2B)
        FUZZ_CHECK(ex == GW_EX_ILLEGAL_FUNCTION);
    if (ex == 0 && fc == 0x2B)
        check_device_id(&res, adu);
    FUZZ_CHECK(res.pdu_len >= 2);
    if (u != NULL && is_write_fc(fc) && read_only)
        FUZZ_CHECK(ex == GW_EX_ILLEGAL_FUNCTION);
    if (ex == GW_EX_TARGET_FAILED)
        FUZZ_CHECK(is_read_fc(fc) && u->on_loss == GW_LOSS_EXCEPTION &&
                   u->robot->link.link_state != 2 && (fc == 0x02 || fc == 0x04));

    if (ex != 0 || !is_write_fc(fc)) {
        /* Refused, or a read: nothing changed anywhere. */
        FUZZ_CHECK(same_bytes(before, units, sizeof units));
        FUZZ_CHECK(same_bytes(before_r, robots, sizeof robots));
        FUZZ_CHECK(res.dirty == 0);
    } else {
        FUZZ_CHECK(res.write && res.count >= 1);
        for (unsigned i = 0; i < UNITS; i++)
            if (&units[i] != u) {
                FUZZ_CHECK(same_bytes(&before[i], &units[i], sizeof units[i]));
                FUZZ_CHECK(same_bytes(&before_r[i], &robots[i], sizeof robots[i]));
            }
        check_write_effect(&before[u - units], u, &before_r[u - units], u->robot, &res);
    }
    if (ex == 0 && is_read_fc(fc)) {
        FUZZ_CHECK(!res.write && res.count >= 1);
        FUZZ_CHECK((uint32_t)res.addr + res.count <= gw_regmap_extent(res.area));
        if (fc <= 0x02)
            for (unsigned i = 0; i < res.count; i++)
                FUZZ_CHECK(res.values[i] <= 1);
    }

    check_reply(adu, len, ex, &res);

    if (ex == 0 && is_write_fc(fc))
        check_read_back(&res);
    if (ex == 0 && fc == 0x17) {
        /* FC 23's read part is what the registers read after its write. */
        uint8_t rd[12] = {0, 1, 0, 0, 0, 6, res.unit_id, 0x03,
                          (uint8_t)(res.raddr >> 8), (uint8_t)res.raddr,
                          (uint8_t)(res.rcount >> 8), (uint8_t)res.rcount};
        uint16_t rv[GW_MB_MAX_WR_READ_REGISTERS];
        uint16_t rn = res.rcount;
        memcpy(rv, res.rvalues, sizeof rv);
        const gw_mb_env_t env2 = {unit_for, NULL, may_write, wrote, NULL, "9.8.7", GW_ORIGIN_MODBUS_TCP, NULL, NULL, NULL};
        FUZZ_CHECK(gw_mbs_decide(rd, sizeof rd, &env2, &back) == 0 && back.count == rn &&
                   memcmp(back.values, rv, rn * sizeof rv[0]) == 0);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    setup();
    if (size < 2)
        return 0;
    unsigned flags = data[0];
    size_t k = data[1] & 63u;
    if (size - 2 < k)
        return 0;
    const uint8_t *pat = data + 2;
    const uint8_t *p = data + 2 + k, *end = data + size;

    unit2 = (flags & 0x40u) != 0;
    read_only = (flags & 0x20u) != 0;
    memset(units, 0, sizeof units);
    memset(robots, 0, sizeof robots);
    for (unsigned i = 0; i < UNITS; i++) {
        gw_unit_t *u = &units[i];
        u->robot = &robots[i];
        for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
            size_t n = dr_asm_info((dr_asm_t)a)->size;
            for (size_t j = 0; j < n; j++)
                u->robot->img[a][j] = k ? pat[(j + 7u * a) % k] : 0;
        }
        u->order = (gw_word_order_t)(flags & 3u);
        u->on_loss = ((flags >> 2) & 3u) == 3 ? GW_LOSS_HOLD : (gw_link_loss_t)((flags >> 2) & 3u);
        u->unmapped = (flags & 0x80u) ? GW_UNMAPPED_EXCEPTION : GW_UNMAPPED_ZERO;
        if (data[1] & 0x40u) {
            static const char *const owned[] = {"bit_in[3]", "io_control.cb_do[1]"};
            for (unsigned j = 0; j < 2; j++)
                FUZZ_CHECK(dr_path_parse(owned[j],
                                         &u->robot->write_policy
                                              .gpio_in[u->robot->write_policy.gpio_in_count++]) ==
                           DR_OK);
        }
        u->robot->fault = (data[1] & 0x80u) != 0;
        memcpy(u->robot->name, i == 0 ? "arm1" : "arm2", sizeof "arm1");
        u->robot->link.link_state = (flags & 0x10u) ? 2 : 0;
        u->robot->link.fresh = (flags & 0x10u) != 0;
    }

    while (p < end) {
        size_t total = 0;
        gw_mbap_t st = gw_mbap_frame(p, (size_t)(end - p), &total);
        if (st != GW_MBAP_FRAME)
            break; /* MORE: the client never finishes; BAD: dropped */
        FUZZ_CHECK(total >= GW_MBAP_LEN + 1 && total <= GW_ADU_MAX &&
                   total <= (size_t)(end - p));
        /* Exactly the frame, on the heap: ASan sees a read past it. */
        uint8_t *adu = malloc(total);
        FUZZ_CHECK(adu != NULL);
        memcpy(adu, p, total);
        request(adu, total);
        free(adu);
        p += total;
    }
    return 0;
}
