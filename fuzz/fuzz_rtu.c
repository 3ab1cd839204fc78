/* SPDX-License-Identifier: MIT */
/*
 * Modbus RTU as a serial line's bytes reach the gateway: gw_rtu_rx_add
 * takes what one read() returns, gw_rtu_rx_next cuts frames (by the
 * length a request's function code gives and its CRC, or at t3.5 of
 * silence), each frame for slave 1 or 2 goes through gw_mb_handle, and
 * gw_rtu_reply frames the answer (mbrtu.c does exactly this around its
 * read() and write()).
 *
 * Input layout (gen_corpus.c writes seeds in it):
 *   [flags] then chunks [c] bytes[c & 0x7F]...
 * flags bit 0: the link is up; bit 1: the master may not write; bits
 * 2-3: word order. A chunk is what one read() returns; c bit 7: the line
 * is silent for t3.5 after it.
 *
 * Properties: every frame handed out is 4..256 bytes with a good CRC and
 * is exactly the bytes at the front of what was buffered; a frame is
 * handed out before the silence only if its function code gives its
 * length; a dropped frame empties the buffer; bytes are conserved
 * (appended = handed out + dropped + still buffered); a silence leaves
 * nothing buffered; every reply is 1 + the reply PDU + a good CRC,
 * addressed as the request, at most 256 bytes.
 */
#include <string.h>

#include "modbus/mbproto.h"
#include "fuzz.h"

static gw_unit_t units[2];
static gw_robot_t robots[2]; /* units[i].robot */
static bool read_only;

static gw_unit_t *unit_for(void *user, uint8_t id)
{
    (void)user;
    return id == 1 || id == 2 ? &units[id - 1] : NULL;
}

static bool may_write(void *client)
{
    (void)client;
    return !read_only;
}

static void wrote(void *client)
{
    (void)client;
}

static void answer(const uint8_t *frame, size_t n)
{
    static gw_mb_result_t res;
    const gw_mb_env_t env = {unit_for, NULL, may_write, wrote, NULL, "9.8.7", GW_ORIGIN_MODBUS_RTU, NULL, NULL, NULL};
    if (unit_for(NULL, frame[0]) == NULL)
        return; /* another slave's, or a broadcast: no reply */
    int ex = gw_mb_handle(frame[0], frame + 1, n - 3, &env, &res);
    FUZZ_CHECK(ex >= 0); /* frames are 4..256 bytes: PDUs 1..253 */
    FUZZ_CHECK(res.unit == unit_for(NULL, frame[0])); /* what on_write is handed */
    uint8_t out[GW_RTU_MAX];
    size_t len = gw_rtu_reply(frame[0], &res, out);
    FUZZ_CHECK(len == res.pdu_len + 3 && len <= GW_RTU_MAX && out[0] == frame[0]);
    FUZZ_CHECK(gw_rtu_crc_ok(out, len));
    FUZZ_CHECK((out[1] & 0x7Fu) == (frame[1] & 0x7Fu));
}

/* Take everything rx hands out now. */
static void drain(gw_rtu_rx_t *rx, bool silence, size_t *out)
{
    for (;;) {
        uint8_t before[GW_RTU_MAX], frame[GW_RTU_MAX];
        size_t len = rx->len, n = 0;
        bool overflow = rx->overflow;
        memcpy(before, rx->buf, len);
        size_t known = gw_rtu_request_len(before, len);
        gw_rtu_ev_t ev = gw_rtu_rx_next(rx, silence, frame, &n);
        if (ev == GW_RTU_NONE) {
            FUZZ_CHECK(!silence || (len == 0 && !overflow));
            FUZZ_CHECK(rx->len == len);
            return;
        }
        if (ev == GW_RTU_BAD) {
            FUZZ_CHECK(silence && rx->len == 0 && !rx->overflow);
            *out += len;
            continue;
        }
        FUZZ_CHECK(!overflow && n >= GW_RTU_MIN && n <= GW_RTU_MAX && n <= len);
        FUZZ_CHECK(memcmp(frame, before, n) == 0 && gw_rtu_crc_ok(frame, n));
        FUZZ_CHECK(silence || n == known);
        FUZZ_CHECK(rx->len == len - n && memcmp(rx->buf, before + n, rx->len) == 0);
        *out += n;
        answer(frame, n);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    gw_regmap_init();
    memset(units, 0, sizeof units);
    memset(robots, 0, sizeof robots);
    for (unsigned i = 0; i < 2; i++) {
        units[i].robot = &robots[i];
        robots[i].link.link_state = (data[0] & 1u) ? 2 : 0;
        units[i].order = (gw_word_order_t)((data[0] >> 2) & 3u);
    }
    read_only = (data[0] & 2u) != 0;
    static gw_rtu_rx_t rx;
    memset(&rx, 0, sizeof rx);
    size_t in = 0, out = 0;
    const uint8_t *p = data + 1, *end = data + size;
    while (p < end) {
        size_t c = *p & 0x7Fu;
        bool silence = (*p & 0x80u) != 0;
        p++;
        if (c > (size_t)(end - p))
            c = (size_t)(end - p);
        size_t len0 = rx.len;
        gw_rtu_rx_add(&rx, p, c);
        FUZZ_CHECK(rx.len == len0 + c || (rx.overflow && rx.len == len0));
        in += rx.len - len0;
        p += c;
        drain(&rx, false, &out);
        if (silence)
            drain(&rx, true, &out);
        FUZZ_CHECK(in == out + rx.len);
    }
    drain(&rx, true, &out);
    FUZZ_CHECK(in == out && rx.len == 0);
    return 0;
}
