/* SPDX-License-Identifier: MIT */
/*
 * Class 1 datagrams from UDP 2222 (dr_io_frame_parse), read both as a
 * connection with the 32-bit run/idle header (O->T) and as a modeless one
 * (T->O). The format has one spelling, so an accepted datagram re-encodes
 * to itself; the two readings must agree with each other; and the
 * sequence compares must be antisymmetric on the numbers found.
 */
#include <string.h>

#include "cip_internal.h"
#include "fuzz.h"

static uint8_t out[0x20000];

static void check(const uint8_t *buf, size_t len, bool run_idle,
                  const dr_io_frame_t *f)
{
    FUZZ_CHECK(f->has_run_idle == run_idle);
    FUZZ_CHECK(fuzz_within(f->data, f->data_len, buf, len));
    /* The data is the tail of the datagram. */
    FUZZ_CHECK(f->data + f->data_len == buf + len);
    FUZZ_CHECK(len == 2u + 4u + 8u + 4u + 2u + (run_idle ? 4u : 0u) + f->data_len);
    size_t n = 0;
    FUZZ_CHECK(dr_io_frame_write(out, sizeof out, f, &n) == DR_OK);
    FUZZ_CHECK(n == len && memcmp(out, buf, len) == 0);
    /* One byte less room than needed is refused. */
    FUZZ_CHECK(dr_io_frame_write(out, len - 1, f, &n) == DR_ENOSPACE);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    dr_io_frame_t ri, plain;
    dr_status_t st_ri = dr_io_frame_parse(data, size, true, &ri);
    dr_status_t st_plain = dr_io_frame_parse(data, size, false, &plain);
    if (st_ri == DR_OK) {
        check(data, size, true, &ri);
        /* A frame with a header is also a modeless frame 4 bytes longer. */
        FUZZ_CHECK(st_plain == DR_OK);
        FUZZ_CHECK(plain.data_len == ri.data_len + 4u);
        FUZZ_CHECK(plain.cid == ri.cid && plain.cip_seq == ri.cip_seq);
    }
    if (st_plain == DR_OK) {
        check(data, size, false, &plain);
        FUZZ_CHECK(plain.run_idle == 0);
        uint16_t a = plain.cip_seq, b = (uint16_t)plain.encap_seq;
        FUZZ_CHECK(!(dr_seq16_newer(a, b) && dr_seq16_newer(b, a)));
        FUZZ_CHECK(!dr_seq16_newer(a, a));
        FUZZ_CHECK(dr_seq16_newer((uint16_t)(a + 1u), a));
        uint32_t x = plain.cid, y = plain.encap_seq;
        FUZZ_CHECK(!(dr_seq32_newer(x, y) && dr_seq32_newer(y, x)));
        FUZZ_CHECK(dr_seq32_newer(y + 1u, y) && !dr_seq32_newer(y, y));
        FUZZ_CHECK(dr_seq32_newer(x, y) == (x != y && x - y < 0x80000000u));
    }
    return 0;
}
