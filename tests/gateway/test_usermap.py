# SPDX-License-Identifier: MIT
"""The user's register map (issue 22, docs/register-map.md "Your own map"):
the docs' worked example run as written (one FC 03 of 40 registers, FC 06
to int_in[0..3] echoed by drsim to int_out), in two word orders, through
raw frames, pymodbus, mbpoll and libmodbus's client (ctypes); per-entry
write rights (0x02 and nothing changes); INT16 saturation at both ends;
unit 255 answered when configured, refused and logged when not; a reload
that changes the map without dropping the robot's link."""
import ctypes
import json
import math
import re
import shutil
import signal
import struct
import subprocess
from pathlib import Path

import pytest

from gwlib import (libmodbus, DRGATEWAYD, EX_ILLEGAL_ADDRESS, EX_PATH_UNAVAILABLE, GW_ADDR, INSTANCE,
                   EnipReader, ModbusError, dint_regs, int16, regs_dint, regs_real, running,
                   timeout, wait_for)

DOC = Path(__file__).resolve().parents[2] / "docs" / "register-map.md"
MBPOLL = shutil.which("mbpoll")
BASE = 2000  # the example's block


def example_lines(keys=("map ", "unit_id_alias")):
    """The worked example's lines of these keys, as the docs have them."""
    text = DOC.read_text()
    sec = text[text.index("### Worked example"):]
    ini = re.search(r"```ini\n(.*?)```", sec, re.S).group(1)
    lines = [l for l in ini.splitlines() if l.startswith(keys)]
    assert len([l for l in lines if l.startswith("map ")]) == 6, ini
    return "\n".join(lines) + "\n"


# the example, and blocks for the checks the example does not cover
EXTRA = ("map = hr 2100 int_in[5] int16 saturate\n"        # O->T, not writable
         "map = hr 2102 int_in[6..7] dint writable\n"
         "map = hr 2106 float_in[0] real writable\n"
         "map = co 2048 bit_in[0..15] writable\n"
         "map = hr 2110 bit_in[0..15] bits\n")


@pytest.fixture(scope="module", params=["abcd", "cdab"])
def gw(request):
    order = request.param
    with running("usermap-%s" % order, modbus="word_order = %s\n" % order,
                 robot=example_lines() + EXTRA) as g:
        g.order = order
        g.enip = EnipReader("127.0.0.2", g.sim.tcp)
        yield g
        g.enip.close()


def robot_int_in(g, i):
    return struct.unpack_from("<i", g.enip.get(INSTANCE["int_in"]), 4 * i)[0]


def half_away(x):
    return int(math.floor(x + 0.5)) if x >= 0 else int(math.ceil(x - 0.5))


def check_block(g, regs, regmap, m):
    """The 40 registers of the example, against the default map."""
    assert len(regs) == 40
    state = m.read(4, regmap.addr("IR", "io_state.robot_state"), 1)[0]
    assert regs[0] == state
    assert regs[1] in (0, 1)
    for j in range(6):
        deg = regs_real(regs[2 + 2 * j:4 + 2 * j], g.order)
        # the same snapshot: the INT16 x 10 view of the same joint
        assert int16(regs[30 + j]) == max(-32768, min(32767, half_away(deg * 10))), (j, deg)


def test_docs_example_one_read_and_fc06(gw, regmap):
    with gw.raw() as m:
        for i, v in enumerate([1, -2, 300, 32767]):
            m.write_reg(BASE + 36 + i, v & 0xFFFF)          # FC 06, unit 1
        for i, v in enumerate([1, -2, 300, 32767]):
            wait_for(lambda: robot_int_in(gw, i) == v, 10, "int_in[%d] at the robot" % i)

        def echoed():
            regs = m.read(3, BASE, 40, unit=255)             # one FC 03, unit 255
            return [regs_dint(regs[14 + 2 * i:16 + 2 * i], gw.order) for i in range(4)] == \
                [1, -2, 300, 32767]
        wait_for(echoed, 10, "int_in[0..3] echoed to int_out[0..3]")
        regs = m.read(3, BASE, 40, unit=255)
        check_block(gw, regs, regmap, m)
        assert [int16(r) for r in regs[36:40]] == [1, -2, 300, 32767]
        # the default map shows the same int_out
        assert m.read(4, regmap.addr("IR", "int_out[1]"), 2) == dint_regs(-2, gw.order)


def test_pymodbus_reads_and_writes(gw, regmap):
    c = gw.pymodbus()
    try:
        rr = c.write_register(BASE + 37, 1234, slave=1)               # FC 06
        assert not rr.isError(), rr
        wait_for(lambda: robot_int_in(gw, 1) == 1234, 10, "int_in[1]")
        rr = c.write_registers(2102, dint_regs(-123456, gw.order) + dint_regs(7, gw.order),
                               slave=1)
        assert not rr.isError(), rr
        wait_for(lambda: robot_int_in(gw, 6) == -123456 and robot_int_in(gw, 7) == 7, 10,
                 "int_in[6..7]")
        rr = c.read_holding_registers(BASE, count=40, slave=1)
        assert not rr.isError(), rr
        with gw.raw() as m:
            check_block(gw, rr.registers, regmap, m)
        rr = c.write_coils(2048, [True, False, True] + [False] * 13, slave=1)
        assert not rr.isError(), rr
        rr = c.read_holding_registers(2110, count=1, slave=1)
        assert rr.registers == [0b101]
        rr = c.read_coils(2048, count=3, slave=1)
        assert rr.bits[:3] == [True, False, True]
    finally:
        c.close()


@pytest.mark.skipif(MBPOLL is None, reason="mbpoll is not installed (make deps)")
def test_mbpoll_fc06_echo(gw):
    args = [MBPOLL, "-m", "tcp", "-p", str(gw.port), "-a", "255", "-t", "4", "-0",
            "-r", str(BASE + 36), "-o", "5", GW_ADDR, "--", str(0xFFFF & -77)]
    r = subprocess.run(args, capture_output=True, text=True, timeout=timeout(30),
                       stdin=subprocess.DEVNULL)
    assert r.returncode == 0 and "Written 1 references" in r.stdout, r.stdout + r.stderr
    with gw.raw() as m:
        wait_for(lambda: regs_dint(m.read(3, BASE + 14, 2), gw.order) == -77, 10,
                 "int_out[0] = -77 in the user's map")
    # a REAL block in the gateway's word order (mbpoll: -B = high word first)
    base = [MBPOLL, "-m", "tcp", "-p", str(gw.port), "-a", "1", "-t", "4:float", "-0",
            "-r", "2106", "-o", "5"] + (["-B"] if gw.order == "abcd" else [])
    r = subprocess.run(base + [GW_ADDR, "--", "-2.75"], capture_output=True, text=True,
                       timeout=timeout(30), stdin=subprocess.DEVNULL)
    assert r.returncode == 0 and "Written 1 references" in r.stdout, r.stdout + r.stderr
    wait_for(lambda: struct.unpack_from("<f", gw.enip.get(INSTANCE["float_in"]), 0)[0] == -2.75,
             10, "float_in[0] = -2.75 at the robot")
    r = subprocess.run(base + ["-c", "1", "-1", GW_ADDR], capture_output=True, text=True,
                       timeout=timeout(30), stdin=subprocess.DEVNULL)
    assert r.returncode == 0, r.stderr
    assert re.findall(r"^\[\d+\]:\s+(\S+)", r.stdout, re.M) == ["-2.75"], r.stdout



def test_libmodbus_client(gw, regmap):
    lib = libmodbus()
    ctx = lib.modbus_new_tcp(GW_ADDR.encode(), gw.port)
    assert ctx
    try:
        lib.modbus_set_slave(ctx, 255)
        lib.modbus_set_response_timeout(ctx, int(timeout(5)), 0)
        assert lib.modbus_connect(ctx) == 0
        assert lib.modbus_write_register(ctx, BASE + 38, 0xFFFF & -5) == 1   # FC 06
        wait_for(lambda: robot_int_in(gw, 2) == -5, 10, "int_in[2]")
        dest = (ctypes.c_uint16 * 40)()
        assert lib.modbus_read_registers(ctx, BASE, 40, dest) == 40
        with gw.raw() as m:
            check_block(gw, list(dest), regmap, m)
        # not writable: libmodbus reports the exception
        assert lib.modbus_write_register(ctx, BASE, 1) == -1
    finally:
        lib.modbus_close(ctx)
        lib.modbus_free(ctx)


def test_write_to_a_block_not_writable_changes_nothing(gw, regmap):
    with gw.raw() as m:
        m.write_regs(regmap.addr("HR", "int_in[5]"), dint_regs(55, gw.order))
        wait_for(lambda: robot_int_in(gw, 5) == 55, 10, "int_in[5] = 55")
        # int_in[5] is O->T but its block does not say writable
        assert m.exception(struct.pack(">BHH", 0x06, 2100, 9)) == EX_ILLEGAL_ADDRESS
        # T->O blocks: robot state, joints, int_out
        for a in (BASE, BASE + 2, BASE + 14, BASE + 30):
            assert m.exception(struct.pack(">BHH", 0x06, a, 1)) == EX_ILLEGAL_ADDRESS
        # a write spanning a writable and a read-only block: nothing applied
        pdu = struct.pack(">BHHB", 0x10, BASE + 35, 2, 4) + struct.pack(">HH", 1, 4321)
        assert m.exception(pdu) == EX_ILLEGAL_ADDRESS
        assert m.read(3, 2100, 1) == [55]
        assert int16(m.read(3, BASE + 36, 1)[0]) != 4321
        # a free address between blocks is not writable either
        assert m.exception(struct.pack(">BHH", 0x06, 2101, 1)) == EX_ILLEGAL_ADDRESS
    assert robot_int_in(gw, 5) == 55


def test_int16_saturates_at_both_ends(gw, regmap):
    with gw.raw() as m:
        a = regmap.addr("HR", "int_in[3]")
        m.write_regs(a, dint_regs(100000, gw.order))
        assert m.read(3, BASE + 39, 1) == [32767]
        m.write_regs(a, dint_regs(-100000, gw.order))
        assert m.read(3, BASE + 39, 1) == [0x8000]
        m.write_regs(a, dint_regs(-32768, gw.order))
        assert m.read(3, BASE + 39, 1) == [0x8000]
        # the ends written through the view are exact
        m.write_reg(BASE + 39, 0x8000)
        assert regs_dint(m.read(3, a, 2), gw.order) == -32768
        m.write_reg(BASE + 39, 0x7FFF)
        assert regs_dint(m.read(3, a, 2), gw.order) == 32767


def test_docs_example_writes_nothing_else(regmap):
    """With the example's default_map_writes = no, int_in[0..3] through the
    user's map are all a PLC may write (HR 310 = int_in[5] used to take it)."""
    lines = example_lines(("map ", "unit_id_alias", "default_map_writes"))
    assert "default_map_writes = no" in lines
    with running("usermap-only", robot=lines) as g:
        g.enip = EnipReader("127.0.0.2", g.sim.tcp)
        try:
            with g.raw() as m:
                a = regmap.addr("HR", "int_in[5]")
                assert m.exception(struct.pack(">BHHB", 0x10, a, 2, 4) +
                                   struct.pack(">HH", 0, 9)) == EX_ILLEGAL_ADDRESS
                assert m.exception(struct.pack(">BHH", 0x05, regmap.addr("CO", "bit_in[0]"),
                                               0xFF00)) == EX_ILLEGAL_ADDRESS
                m.write_reg(BASE + 36, 99, unit=255)
                wait_for(lambda: robot_int_in(g, 0) == 99, 10, "int_in[0] = 99")
                assert robot_int_in(g, 5) == 0
                m.write_reg(0, 1)  # the watchdog register stays writable
        finally:
            g.enip.close()


def test_unit_refused_and_logged_once():
    """Without unit_id_alias, 255 and 0 get 0x0A, logged once per client."""
    with running("usermap-unit") as g:
        with g.raw() as m:
            assert m.exception(struct.pack(">BHH", 0x04, 0, 1), unit=255) == EX_PATH_UNAVAILABLE
            assert m.exception(struct.pack(">BHH", 0x04, 0, 1), unit=255) == EX_PATH_UNAVAILABLE
            g.log_wait("asked for unit ID 255")
            assert m.read(4, 32, 1) == [0x1234]
        assert g.log().count("asked for unit ID 255") == 1
        assert "unit_id_alias = 255" in g.log()


def test_reload_changes_the_map_without_dropping_the_link():
    with running("usermap-reload", robot="map = hr 3000 int_in[0] int16 writable saturate\n") as g:
        with g.raw() as m:
            m.write_reg(3000, 42)
            st0 = m.read(4, 0, 40)
            mark = len(g.log())
            g.write_config(g.config_text(robot="map = hr 3100 int_in[0] uint16 lo writable\n"))
            g.signal(signal.SIGHUP)
            g.log_wait("reloaded (generation 1)", start=mark)
            wait_for(lambda: m.read(4, 29, 1) == [1], 10, "config_generation 1")
            assert m.read(3, 3100, 1) == [42]
            # the old block's address is a gap now (reads 0), and the
            # table ends with the new block
            assert m.read(3, 3000, 1) == [0]
            with pytest.raises(ModbusError) as e:
                m.read(3, 3100, 2)
            assert e.value.code == EX_ILLEGAL_ADDRESS
            st1 = m.read(4, 0, 40)
            assert st1[1] == 2 and (st1[6] << 16 | st1[7]) >= (st0[6] << 16 | st0[7])
            assert "link down" not in g.log()[mark:]
            log = g.sim.log()
            assert log.count("connection open") == 6, log


def test_print_map_json_and_filter(tmp_path):
    conf = tmp_path / "gw.ini"
    conf.write_text("[robot arm]\nhost = 127.0.0.1\n" + example_lines())
    out = subprocess.run([str(DRGATEWAYD), "-c", str(conf), "--print-map", "--json",
                          "joint_state.position"], check=True, capture_output=True, text=True,
                         timeout=timeout(30)).stdout
    rows = json.loads(out)
    assert rows and all("joint_state.position" in r["name"] for r in rows)
    mine = [r for r in rows if r.get("robot") == "arm"]
    assert [r["address"] for r in mine] == [2002, 2004, 2006, 2008, 2010, 2012] + \
        list(range(2030, 2036))
    assert not any(r["writable"] for r in mine)


@pytest.mark.skipif(shutil.which("socat") is None, reason="socat is not installed (make deps)")
def test_rtu_serves_the_same_map():
    """A Modbus RTU line answers for the robot with its own map, the same
    rules as on TCP (read, FC 06 to a writable block, 0x02 elsewhere)."""
    from test_rtu import RawRtu, pty_pair
    from gwlib import Drsim, Gateway
    sim = Drsim("usermap-rtu").start()
    with pty_pair("usermap-rtu") as (dev, master):
        extra = ("\n[modbus_rtu line1]\ndevice = %s\nbaud = 9600\nparity = none\n"
                 "stop_bits = 2\nrobots = r0:5\n" % dev)
        g = Gateway("usermap-rtu", sim, robot=example_lines(), extra=extra)
        m = None
        try:
            g.start()
            g.enip = EnipReader("127.0.0.2", sim.tcp)
            m = RawRtu(master)
            pdu = m.request(5, struct.pack(">BHH", 0x06, BASE + 37, 0xFFFF & -9))
            assert pdu == struct.pack(">BHH", 0x06, BASE + 37, 0xFFFF & -9)
            wait_for(lambda: robot_int_in(g, 1) == -9, 10, "int_in[1] = -9 over RTU")
            regs = m.read(3, BASE, 40, 5)
            assert int16(regs[37]) == -9
            assert m.request(5, struct.pack(">BHH", 0x06, BASE, 1)) == \
                bytes([0x86, EX_ILLEGAL_ADDRESS])
            g.enip.close()
        finally:
            if m is not None:
                m.close()
            g.kill()
            sim.kill()
