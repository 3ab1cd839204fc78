# SPDX-License-Identifier: MIT
"""Adapter behaviours we accept (docs/interop.md): the gateway against
drsim making each legal producer choice that real adapters make. No
timing goals: the checks are link state, counters and log lines, sampled
over a few seconds."""
import struct
import time

import pytest

from gwlib import SCALE, dint_regs, running, wait_for


def int_out0(m, regmap):
    a = regmap.addr("IR", "int_out[0]")
    return struct.unpack(">i", struct.pack(">HH", *m.read(4, a, 2)))[0]


def put_int_in0(m, regmap, v):
    m.write_regs(regmap.addr("HR", "int_in[0]"), dint_regs(v, "abcd"))


def rx_packets(st):
    return st[6] << 16 | st[7]


def steady(g, seconds):
    """Sample the status block for `seconds`: the link must stay up and the
    data fresh all along (six connections established). Returns the last
    sample."""
    end = time.monotonic() + seconds
    st = g.status()
    while time.monotonic() < end:
        st = g.status()
        assert st[1] == 2, "link state %d" % st[1]
        assert st[2] == 1, "data not fresh (age %d ms)" % st[3]
        assert [st[16 + i] for i in range(6)] == [2] * 6
        time.sleep(0.05)
    return st


@pytest.mark.parametrize("sim_args", [("--seq-on-change", "--still")],
                         ids=["seq-on-change"])
def test_repeated_sequence_count_keeps_link(sim_args, regmap):
    """A robot standing still whose CIP sequence count repeats while its
    data is unchanged (issue 10: the link flapped with "timed out" every
    16 RPIs): RPI 50 ms, timeout x32 (1.6 s, so that a busy machine's stall
    is not taken for the flap), three timeouts long without a flap, the
    data fresh throughout, and a change of data still comes through."""
    with running("adapters-seq", sim_args=sim_args,
                 robot="rpi_ms = 50\ntimeout_multiplier = 3\n") as g:
        mark = len(g.log())
        st0 = g.status()
        st = steady(g, 5.0)
        assert rx_packets(st) > rx_packets(st0)  # repeats count as packets
        assert "link down" not in g.log()[mark:]
        assert "timed out" not in g.log()[mark:]
        with g.raw() as m:
            for v in (4242, -7):
                put_int_in0(m, regmap, v)
                wait_for(lambda: int_out0(m, regmap) == v, 10 * SCALE, "int_out[0] = %d" % v)
        steady(g, 1.0)
        assert "link down" not in g.log()[mark:]


def test_coarse_tick_api_in_status(regmap):
    """An adapter that produces every 20 ms for a 10 ms request and says so
    in the reply: timeouts follow the granted API, and the status block's
    rpi_ms shows it."""
    with running("adapters-tick", sim_args=("--tick", "20"),
                 robot="rpi_ms = 10\ntimeout_multiplier = 4\n") as g:
        mark = len(g.log())
        st = steady(g, 2.0)
        assert st[5] == 20
        assert "link down" not in g.log()[mark:]


def test_trailing_item_open(regmap):
    """Forward Open replies with an undeclared item after their own (an
    echo of our 0x8001 item): the connections open."""
    with running("adapters-trailing", sim_args=("--trailing-item",)) as g:
        steady(g, 1.0)
        assert "malformed" not in g.log()


def test_trailing_item_refusal_logged(regmap):
    """The same adapter refusing with 0x01/0x0106 (ownership conflict): the
    log and the status block (last_error, last_cip_general) name the
    refusal, not "malformed frame"."""
    with running("adapters-trailing-refused",
                 sim_args=("--trailing-item", "--refuse-forward-open", "0x0106"),
                 start=False) as g:
        g.start(wait_link=False)
        g.log_wait("CIP 0x01/0x0106 ownership conflict", 20)
        last_error = regmap.addr("IR", "status.last_error")
        last_general = regmap.addr("IR", "status.last_cip_general")
        wait_for(lambda: g.status()[last_error] == 0x0106 and g.status()[last_general] == 0x01,
                 10 * SCALE, "0x01/0x0106 in the status block")
        assert "malformed" not in g.log()
        assert g.status()[1] != 2
