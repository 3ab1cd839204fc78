# SPDX-License-Identifier: MIT
"""Writes are logged (issue 21): each accepted Modbus write is logged at
info with its client (IP:port) and the fields it changed by canonical
path, at most one line per client per second, the writes held back in
between counted, so that a PLC writing every cycle does not fill the log
and no write goes unaccounted for. A refused write is no write."""
import re
import time

from gwlib import EX_ILLEGAL_ADDRESS, ModbusError, running, wait_for

LINE = re.compile(r"robot r0: write by modbus (\S+): (.*?)( \[(\d+) similar messages? "
                  r"suppressed( in 1 s, the last shown)?\])?$")


def write_lines(log, client):
    """(fields, held back, summary?) of each write line of client."""
    out = []
    for line in log.splitlines():
        m = LINE.search(line)
        if m and m.group(1) == client:
            out.append((m.group(2), int(m.group(4) or 0), bool(m.group(5))))
    return out


def test_write_logged_with_client_and_fields():
    with running("wlog") as g, g.raw() as m:
        me = "%s:%d" % m.sock.getsockname()
        mark = len(g.log())
        m.write_regs(300, [0, 5, 0, 6])       # int_in[0] and int_in[1], both halves each
        m.write_regs(104, [0, 0])             # io_control.ao[0] (REAL)
        m.write_reg(100, 0x0005)              # io_control.cb_do: a packed mask
        try:                                  # refused (half a DINT): no write, no line
            m.write_reg(301, 1)
            raise AssertionError("a torn DINT write was accepted")
        except ModbusError as e:
            assert e.code == EX_ILLEGAL_ADDRESS
        g.log_wait("write by modbus %s: int_in[0], int_in[1]" % me, start=mark)
        # the next two come within a second: held back, then summed up
        wait_for(lambda: write_lines(g.log()[mark:], me)[-1][2], 10,
                 "the summary of the held-back writes")
        lines = write_lines(g.log()[mark:], me)
        assert lines[0] == ("int_in[0], int_in[1]", 0, False), lines
        assert lines[-1] == ("io_control.cb_do", 2, True), lines  # the last shown
        assert "info: robot r0: write by modbus %s: int_in[0]" % me in g.log()


def test_write_log_rate_limited():
    """200 writes as fast as the client can: a line per second at most, and
    every write counted in one of them."""
    n = 200
    with running("wlograte") as g, g.raw() as m:
        me = "%s:%d" % m.sock.getsockname()
        mark = len(g.log())
        t0 = time.monotonic()
        for i in range(n):
            m.write_regs(302, [0, i])  # int_in[1]
        elapsed = time.monotonic() - t0
        def accounted():
            lines = write_lines(g.log()[mark:], me)
            # a plain line is one write; "[N ... suppressed]" after a line
            # adds N to it; a summary ("in 1 s, the last shown") is N
            return sum(h if summary else 1 + h for _, h, summary in lines)
        wait_for(lambda: accounted() == n, 15, "all %d writes in the log's counts" % n)
        lines = write_lines(g.log()[mark:], me)
        assert len(lines) <= elapsed + 3, (len(lines), elapsed, lines)
        assert len(lines) < n // 4, lines
        assert any(h > 0 for _, h, _ in lines), lines
        assert all(f == "int_in[1]" for f, _, _ in lines), lines
