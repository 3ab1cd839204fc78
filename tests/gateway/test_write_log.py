# SPDX-License-Identifier: MIT
"""Writes are logged (issue 21): each accepted Modbus or MQTT write is
logged at info with its client (IP:port, the MQTT topic) and the fields it
changed by canonical path, at most one line per client per second, the writes held back in
between counted, so that a PLC writing every cycle does not fill the log
and no write goes unaccounted for. A refused write is no write."""
import json
import re
import time

import pytest

from gwlib import EX_ILLEGAL_ADDRESS, ModbusError, running, skip, wait_for

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


def test_mqtt_write_logged():
    """A plant write on MQTT: logged with its topic and field; the next
    within the second held back and summed up; a refused one not at all."""
    pytest.importorskip("paho.mqtt.client")
    from mqttlib import PREFIX, Broker, Plant, mqtt_section
    from test_metrics import get, http_section, samples, val
    b = Broker("wlog_mqtt").start()
    port, sect = http_section()
    try:
        with running("wlog_mqtt", extra=mqtt_section(b, "writes = yes") + sect,
                     start=False) as g:
            plant = Plant(b)
            g.start()
            try:
                wait_for(lambda: plant.last(PREFIX + "/r0/state") is not None and
                         plant.last(PREFIX + "/r0/state").startswith("up"), 20, "state up")
                mark = len(g.log())
                plant.set("float_in[3]", "2.5")
                plant.set("float_in[4]", "not a number")  # refused: no write
                plant.set("int_in[5]", "-7")
                first = "robot r0: write by mqtt %s/r0/set/float_in[3]: float_in[3]" % PREFIX
                g.log_wait(first, start=mark)
                held = ("robot r0: write by mqtt %s/r0/set/int_in[5]: int_in[5] "
                        "[1 similar message suppressed in 1 s, the last shown]" % PREFIX)
                g.log_wait(held, start=mark)
                assert "set/float_in[4]: float_in[4]" not in g.log()[mark:]
                # the MQTT side's counters (/metrics) and report (/api/v1/status)
                s = samples(get(port, "/metrics")[2])
                assert val(s, "drgate_mqtt_connected") == 1
                assert val(s, "drgate_mqtt_writes_total", result="accepted") == 2
                assert val(s, "drgate_mqtt_writes_total", result="refused") == 1
                assert val(s, "drgate_mqtt_published_total") > 0
                assert val(s, "drgate_mqtt_reconnects_total") == 0
                side = json.loads(get(port, "/api/v1/status")[2])["sides"]["mqtt"]
                assert side["connected"] is True and side["writes"]["accepted"] == 2, side
                assert side["broker"].endswith(":%d" % b.port), side
            finally:
                plant.close()
    finally:
        b.stop()


def test_rtu_write_logged():
    """A write from the RTU master: its line and unit name the client."""
    import shutil
    import struct
    if shutil.which("socat") is None:
        skip("socat", "socat is not installed (make test-deps)")
    from gwlib import Drsim, Gateway
    from test_rtu import RawRtu, pty_pair
    sim = Drsim("wlog-rtu").start()
    try:
        with pty_pair("wlog-rtu") as (dev, master):
            g = Gateway("wlog-rtu", [sim], extra="\n[modbus_rtu line1]\ndevice = %s\n"
                        "baud = 9600\nparity = none\nstop_bits = 2\nrobots = r0:5\n" % dev)
            try:
                g.start()
                rtu = RawRtu(master)
                mark = len(g.log())
                rsp = rtu.request(5, struct.pack(">BHHBHHHH", 0x10, 300, 4, 8, 0, 1, 0, 2))
                assert rsp[0] == 0x10, rsp.hex()
                g.log_wait("robot r0: write by modbus_rtu line1 unit 1: int_in[0], int_in[1]",
                           start=mark)
                rtu.close()
            finally:
                g.kill()
    finally:
        sim.kill()
