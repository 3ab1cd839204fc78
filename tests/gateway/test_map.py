# SPDX-License-Identifier: MIT
"""Every field through the register map, in each word order.

One drsim and one drgatewayd per word order. Values go in through Modbus
(pymodbus), come back through drsim's echo (bit_in -> bit_out, int_in ->
int_out, float_in -> float_out, io_control -> io_state) and are compared
with registers computed here by hand, and with what the robot itself holds
(read beside the gateway with our own EtherNet/IP reader, not the
project's client)."""
import math
import struct
import time

import pytest

from gwlib import (INSTANCE, ORDERS, ORDER_INDEX, REAL_123456, EnipReader, between, decode_t2o,
                   dint_regs, f32, int16, noise_of, real_regs, regs_dint, regs_real, running,
                   wait_for)


@pytest.fixture(scope="module", params=ORDERS)
def gw(request):
    order = request.param
    with running("map-%s" % order, modbus="word_order = %s\n" % order) as g:
        g.order = order
        g.pm = g.pymodbus()
        g.enip = EnipReader("127.0.0.2", g.sim.tcp)
        yield g
        g.pm.close()
        g.enip.close()
        rc, _ = g.stop()
        assert rc == 0, g.log()


def ok(r):
    assert not r.isError(), repr(r)
    return r


def read_regs(pm, fc, addr, count):
    out = []
    while count > 0:
        n = min(count, 125)
        f = pm.read_input_registers if fc == 4 else pm.read_holding_registers
        out += ok(f(addr, count=n, slave=1)).registers
        addr += n
        count -= n
    return out


def read_bits(pm, fc, addr, count):
    f = pm.read_discrete_inputs if fc == 2 else pm.read_coils
    return [int(b) for b in ok(f(addr, count=count, slave=1)).bits[:count]]


def robot(g, name):
    return g.enip.get(INSTANCE[name])


def wait_regs(g, fc, addr, want, what):
    return wait_for(lambda: read_regs(g.pm, fc, addr, len(want)) == want, 10, what)


# ---- constants ------------------------------------------------------------------

def test_word_order_helpers_agree_with_the_docs():
    # the worked example, 123456.0 = 0x47F12000, in all four orders
    for order in ORDERS:
        assert real_regs(123456.0, order) == REAL_123456[order]
        assert regs_real(REAL_123456[order], order) == 123456.0


def test_test_registers(gw, regmap):
    base = regmap.addr("IR", "test.u16 = 0x1234")
    regs = read_regs(gw.pm, 4, base, 8)
    want = ([0x1234] + dint_regs(0x12345678, gw.order) + REAL_123456[gw.order] +
            real_regs(-1.5, gw.order) + [0xFFFE])
    assert regs == want, [hex(r) for r in regs]
    assert regs_real(regs[3:5], gw.order) == 123456.0
    assert regs_real(regs[5:7], gw.order) == -1.5
    assert regs_dint(regs[1:3], gw.order) == 0x12345678
    wo = regmap.addr("IR", "status.word_order (0 abcd, 1 cdab, 2 badc, 3 dcba)")
    assert read_regs(gw.pm, 4, wo, 1) == [ORDER_INDEX[gw.order]]


def test_controller_version_and_state(gw, regmap):
    v = [regmap.addr("IR", "io_state.version.%s" % p) for p in ("major", "minor", "patch")]
    assert v[1] == v[0] + 1 and v[2] == v[0] + 2
    assert read_regs(gw.pm, 4, v[0], 3) == [2, 12, 3]
    rs = regmap.addr("IR", "io_state.robot_state")
    wait_for(lambda: read_regs(gw.pm, 4, rs, 1) == [2], 15, "robot_state OPERATING (2)")
    assert read_regs(gw.pm, 4, regmap.addr("IR", "io_state.servo_on"), 1) == [1]
    assert read_bits(gw.pm, 2, regmap.addr("DI", "io_state.servo_on"), 1) == [1]


# ---- Modbus -> robot -> Modbus ------------------------------------------------------

DINTS = [0, 1, -1, 0x12345678, -0x12345678, 2**31 - 1, -2**31, 100000, -100000,
         0x00FF00FF, 0x7F000001, 0x01020304, 255, 256, 65535, 65536, -65536, 42,
         -42, 0x40000000, 0x0BADF00D, -559038737, 7, 123456789]
REALS = [0.0, 1.0, -1.0, 123456.0, -1.5, 0.1, 3.14159274, 1e-7, -1e-7, 1e30, -1e30,
         3.4e38, 1.17549435e-38, 65504.0, 0.5, -0.25, 100.0, 327.67, -327.67,
         2.5, 12.34, 1e6, -0.0, 7.0]


def test_dint_round_trip(gw, regmap):
    hr, n = regmap.span("HR", ["int_in[%d]" % i for i in range(24)])
    ir, n2 = regmap.span("IR", ["int_out[%d]" % i for i in range(24)])
    assert n == n2 == 48
    for values in (DINTS, [-v for v in DINTS[7:]] + DINTS[:7]):
        values = [max(-2**31, min(2**31 - 1, v)) for v in values]
        regs = [w for v in values for w in dint_regs(v, gw.order)]
        ok(gw.pm.write_registers(hr, regs, slave=1))
        # the robot got the values (not just the registers)
        wait_for(lambda: list(struct.unpack("<24i", robot(gw, "int_in"))) == values, 10,
                 "int_in at the robot")
        # echoed back to int_out, and served in the same word order
        wait_regs(gw, 4, ir, regs, "int_out echo")
        assert list(struct.unpack("<24i", robot(gw, "int_out"))) == values
        # holding registers read back the O->T image
        assert read_regs(gw.pm, 3, hr, 48) == regs


def test_real_round_trip(gw, regmap):
    names_in = ["float_in[%d]" % i for i in range(24)]
    hr, _ = regmap.span("HR", names_in)
    hs, _ = regmap.span("HR", names_in, scaled=True)
    ir, _ = regmap.span("IR", ["float_out[%d]" % i for i in range(24)])
    irs, _ = regmap.span("IR", ["float_out[%d]" % i for i in range(24)], scaled=True)
    scale = regmap.scale("HR", "float_in[0]")
    assert scale == regmap.scale("IR", "float_out[0]") == 100
    values = [f32(v) for v in REALS]
    regs = [w for v in values for w in real_regs(v, gw.order)]
    ok(gw.pm.write_registers(hr, regs, slave=1))
    wait_for(lambda: list(struct.unpack("<24f", robot(gw, "float_in"))) == values, 10,
             "float_in at the robot")
    assert struct.unpack("<I", robot(gw, "float_in")[-8:-4])[0] == 0x80000000  # -0.0 kept
    wait_regs(gw, 4, ir, regs, "float_out echo")
    assert read_regs(gw.pm, 3, hr, 48) == regs
    # the scaled INT16 views: round(x * 100), saturated at +-32767
    want = [max(-32767, min(32767, int(math.copysign(math.floor(abs(v) * scale + 0.5), v))))
            for v in values]
    got = [int16(r) for r in read_regs(gw.pm, 4, irs, 24)]
    assert got == want
    assert [int16(r) for r in read_regs(gw.pm, 3, hs, 24)] == want


def test_real_hand_computed_pairs(gw, regmap):
    hr = regmap.addr("HR", "float_in[5]")
    ir = regmap.addr("IR", "float_out[5]")
    ok(gw.pm.write_registers(hr, REAL_123456[gw.order], slave=1))
    wait_for(lambda: struct.unpack_from("<f", robot(gw, "float_in"), 20)[0] == 123456.0, 10,
             "float_in[5] = 123456.0 at the robot")
    wait_regs(gw, 4, ir, REAL_123456[gw.order], "float_out[5] = 0x47F12000")
    # -1.5 = 0xBFC00000, written as its bytes in this order
    ok(gw.pm.write_registers(hr, {"abcd": [0xBFC0, 0], "cdab": [0, 0xBFC0],
                                  "badc": [0xC0BF, 0], "dcba": [0, 0xC0BF]}[gw.order], slave=1))
    wait_for(lambda: struct.unpack_from("<f", robot(gw, "float_in"), 20)[0] == -1.5, 10,
             "float_in[5] = -1.5 at the robot")


def test_scaled_write(gw, regmap):
    hs = regmap.addr("HR", "float_in[3]", scaled=True)
    hr = regmap.addr("HR", "float_in[3]")
    ir = regmap.addr("IR", "float_out[3]")
    for raw in (-32768, -32767, -1234, -1, 0, 1, 1234, 32767):
        ok(gw.pm.write_register(hs, raw & 0xFFFF, slave=1))
        want = f32(raw / 100.0)
        wait_for(lambda: struct.unpack_from("<f", robot(gw, "float_in"), 12)[0] == want, 10,
                 "float_in[3] = %r at the robot" % want)
        assert read_regs(gw.pm, 3, hr, 2) == real_regs(want, gw.order)
        wait_regs(gw, 4, ir, real_regs(want, gw.order), "float_out[3] echo")
        assert int16(read_regs(gw.pm, 3, hs, 1)[0]) == max(raw, -32767)


def test_bits_round_trip(gw, regmap):
    co = regmap.addr("CO", "bit_in[0]")
    assert regmap.span("CO", ["bit_in[%d]" % i for i in range(64)]) == (co, 64)
    di = regmap.addr("DI", "bit_out[0]")
    assert regmap.span("DI", ["bit_out[%d]" % i for i in range(64)]) == (di, 64)
    hp = regmap.entry("HR", "bit_in")
    ip = regmap.entry("IR", "bit_out")
    assert hp["count"] == ip["count"] == 4
    for pattern in (0x8000000000000001, 0x0123456789ABCDEF, 0xFEDCBA9876543210, 0):
        bits = [(pattern >> i) & 1 for i in range(64)]
        words = [(pattern >> (16 * k)) & 0xFFFF for k in range(4)]
        ok(gw.pm.write_coils(co, [bool(b) for b in bits], slave=1))
        wait_for(lambda: struct.unpack("<Q", robot(gw, "bit_in"))[0] == pattern, 10,
                 "bit_in = %#x at the robot" % pattern)
        assert read_bits(gw.pm, 1, co, 64) == bits
        assert read_regs(gw.pm, 3, hp["address"], 4) == words
        wait_for(lambda: read_bits(gw.pm, 2, di, 64) == bits, 10, "bit_out echo")
        assert read_regs(gw.pm, 4, ip["address"], 4) == words
    # the packed words written as registers
    pattern = 0x5AA5C33C0FF0F00F
    words = [(pattern >> (16 * k)) & 0xFFFF for k in range(4)]
    ok(gw.pm.write_registers(hp["address"], words, slave=1))
    wait_for(lambda: struct.unpack("<Q", robot(gw, "bit_in"))[0] == pattern, 10,
             "bit_in from packed words")
    assert read_bits(gw.pm, 1, co, 64) == [(pattern >> i) & 1 for i in range(64)]
    wait_regs(gw, 4, ip["address"], words, "bit_out packed echo")
    # one packed word alone changes only its 16 bits
    ok(gw.pm.write_register(hp["address"] + 2, 0x1234, slave=1))
    pattern = (pattern & ~(0xFFFF << 32)) | (0x1234 << 32)
    wait_for(lambda: struct.unpack("<Q", robot(gw, "bit_in"))[0] == pattern, 10,
             "bit_in after one packed word")
    # single coils
    ok(gw.pm.write_coil(co + 63, False, slave=1))
    ok(gw.pm.write_coil(co + 1, True, slave=1))
    pattern = (pattern & ~(1 << 63)) | 2
    wait_for(lambda: struct.unpack("<Q", robot(gw, "bit_in"))[0] == pattern, 10,
             "bit_in after single coils")
    wait_for(lambda: read_bits(gw.pm, 2, di, 64) == [(pattern >> i) & 1 for i in range(64)],
             10, "bit_out echo of single coils")


def test_io_control_to_io_state(gw, regmap):
    co_do = regmap.addr("CO", "io_control.cb_do[1]")
    co_tool = regmap.addr("CO", "io_control.tool_do[1]")
    co_type = regmap.addr("CO", "io_control.ao_type.ao0")
    hr_do = regmap.addr("HR", "io_control.cb_do")
    hr_tool = regmap.addr("HR", "io_control.tool_do")
    hr_type = regmap.addr("HR", "io_control.ao_type.ao0")
    hr_ao, _ = regmap.span("HR", ["io_control.ao[0]", "io_control.ao[1]"])
    hs_ao = regmap.addr("HR", "io_control.ao[0]", scaled=True)
    ir_do = regmap.addr("IR", "io_state.cb_do")
    di_do = regmap.addr("DI", "io_state.cb_do[1]")
    ir_tool_do = regmap.addr("IR", "io_state.tool_do")
    ir_tool_di = regmap.addr("IR", "io_state.tool_di")
    di_tool_do = regmap.addr("DI", "io_state.tool_do[1]")
    di_tool_di = regmap.addr("DI", "io_state.tool_di[1]")
    ir_type = regmap.addr("IR", "io_state.aio_type.ao0")
    di_type = regmap.addr("DI", "io_state.aio_type.ao0")
    ir_ao = regmap.addr("IR", "io_state.ao[0]")
    ir_ai = regmap.addr("IR", "io_state.ai[0]")
    irs_ao = regmap.addr("IR", "io_state.ao[0]", scaled=True)

    # coils
    do = 0xA5C3
    ok(gw.pm.write_coils(co_do, [bool((do >> i) & 1) for i in range(16)], slave=1))
    ok(gw.pm.write_coils(co_tool, [True, False, True, False, True, True], slave=1))
    ok(gw.pm.write_coils(co_type, [True, False], slave=1))
    wait_regs(gw, 4, ir_do, [do], "io_state.cb_do")
    assert read_regs(gw.pm, 3, hr_do, 1) == [do]
    assert read_bits(gw.pm, 2, di_do, 16) == [(do >> i) & 1 for i in range(16)]
    wait_regs(gw, 4, ir_tool_do, [0x35], "io_state.tool_do")
    assert read_regs(gw.pm, 3, hr_tool, 1) == [0x35]
    assert read_bits(gw.pm, 2, di_tool_do, 6) == [1, 0, 1, 0, 1, 1]
    # the gripper on tool DO1/DO2 reports on tool DI1/DI2
    assert read_regs(gw.pm, 4, ir_tool_di, 1) == [0x01]
    assert read_bits(gw.pm, 2, di_tool_di, 2) == [1, 0]
    wait_regs(gw, 4, ir_type, [1, 0], "io_state.aio_type.ao0/ao1")
    assert read_bits(gw.pm, 2, di_type, 2) == [1, 0]
    assert read_regs(gw.pm, 3, hr_type, 2) == [1, 0]
    w = struct.unpack_from("<I", robot(gw, "io_control"), 0)[0]
    assert w == do | 0x35 << 16 | 1 << 24

    # registers
    ok(gw.pm.write_register(hr_do, 0x0F0F, slave=1))
    ok(gw.pm.write_register(hr_tool, 0x3E, slave=1))
    ok(gw.pm.write_registers(hr_type, [0, 1], slave=1))
    ok(gw.pm.write_registers(hr_ao, real_regs(4.25, gw.order) + real_regs(-7.5, gw.order),
                             slave=1))
    wait_regs(gw, 4, ir_do, [0x0F0F], "io_state.cb_do from the packed register")
    wait_regs(gw, 4, ir_tool_do, [0x3E], "io_state.tool_do from the packed register")
    assert read_regs(gw.pm, 4, ir_tool_di, 1) == [0x02]
    assert read_bits(gw.pm, 1, co_tool, 6) == [0, 1, 1, 1, 1, 1]
    wait_regs(gw, 4, ir_type, [0, 1], "io_state.aio_type from registers")
    wait_regs(gw, 4, ir_ao, real_regs(4.25, gw.order) + real_regs(-7.5, gw.order),
              "io_state.ao[0..1]")
    assert read_regs(gw.pm, 4, irs_ao, 2) == [425, (-750) & 0xFFFF]
    # AI0 reads AO0 back (with a little noise)
    wait_for(lambda: abs(regs_real(read_regs(gw.pm, 4, ir_ai, 2), gw.order) - 4.25) < 0.01,
             10, "io_state.ai[0] to follow ao[0]")
    io = robot(gw, "io_control")
    assert struct.unpack_from("<I2f", io, 0) == (0x0F0F | 0x3E << 16 | 1 << 25, 4.25, -7.5)
    # the scaled view of ao[0]
    ok(gw.pm.write_register(hs_ao, (-1234) & 0xFFFF, slave=1))
    wait_regs(gw, 4, ir_ao, real_regs(f32(-12.34), gw.order), "io_state.ao[0] from x100")


def test_every_o2t_field_is_writable(regmap):
    """The map has a writable home for every O->T field and nothing else."""
    names = {(e["area"], e["name"], e["type"].startswith("INT16")) for e in regmap.entries
             if e["area"] in ("HR", "CO") and not e["name"].startswith("control.")}
    want = {("CO", "io_control.cb_do[%d]" % i, False) for i in range(1, 17)}
    want |= {("CO", "io_control.tool_do[%d]" % i, False) for i in range(1, 7)}
    want |= {("CO", "io_control.ao_type.ao%d" % i, False) for i in range(2)}
    want |= {("CO", "bit_in[%d]" % i, False) for i in range(64)}
    want |= {("HR", n, False) for n in ("io_control.cb_do", "io_control.tool_do",
                                        "io_control.ao_type.ao0", "io_control.ao_type.ao1",
                                        "bit_in")}
    for n in ["io_control.ao[%d]" % i for i in range(2)] + \
            ["float_in[%d]" % i for i in range(24)]:
        want |= {("HR", n, False), ("HR", n, True)}
    want |= {("HR", "int_in[%d]" % i, False) for i in range(24)}
    assert names == want


# ---- robot -> Modbus: everything the robot produces -------------------------------

def t2o_entries(regmap):
    return [e for e in regmap.entries if e["area"] in ("IR", "DI")
            and not e["name"].startswith(("status.", "test."))]


def blocks(entries, limit):
    """Runs of consecutive addresses, at most `limit` long."""
    out = []
    for e in sorted(entries, key=lambda e: e["address"]):
        if out and out[-1][0] + out[-1][1] == e["address"] and out[-1][1] + e["count"] <= limit:
            out[-1][1] += e["count"]
        else:
            out.append([e["address"], e["count"]])
    return out


def modbus_t2o(g, regmap):
    vals = {}
    for area, fc, limit in (("IR", 4, 125), ("DI", 2, 2000)):
        es = [e for e in t2o_entries(regmap) if e["area"] == area]
        raw = {}
        for start, count in blocks(es, limit):
            data = read_regs(g.pm, fc, start, count) if fc == 4 else \
                read_bits(g.pm, fc, start, count)
            raw.update({start + i: v for i, v in enumerate(data)})
        for e in es:
            a, t, n = e["address"], e["type"], e["name"]
            regs = [raw[a + i] for i in range(e["count"])]
            if t.startswith("REAL, 2"):
                vals[n] = regs_real(regs, g.order)
            elif t.startswith("DINT, 2"):
                vals[n] = regs_dint(regs, g.order)
            elif t.startswith("INT16 = REAL x"):
                vals["x%d:%s" % (int(t.rsplit("x", 1)[1]), n)] = int16(regs[0])
            elif t.startswith("bits"):
                vals[n] = sum(w << (16 * k) for k, w in enumerate(regs))
            else:
                assert e["count"] == 1, e
                vals[n] = regs[0]
    return vals


def robot_t2o(g):
    return decode_t2o({INSTANCE[n]: robot(g, n) for n in
                       ("io_state", "joint_state", "task_state", "bit_out", "int_out",
                        "float_out")})


def test_t2o_matches_the_robot(gw, regmap):
    """Every T->O register and bit against the robot's own images, read just
    before and just after (the arm moves: a value must lie between the two,
    give or take drsim's noise). Fields that miss are tried again."""
    gw.pm.write_registers(regmap.addr("HR", "float_in[0]"),
                          [w for i in range(24) for w in real_regs(f32(i * 1.25 - 9), gw.order)],
                          slave=1)
    gw.pm.write_registers(regmap.addr("HR", "int_in[0]"),
                          [w for i in range(24) for w in dint_regs(i * 99991 - 7, gw.order)],
                          slave=1)
    wait_for(lambda: list(struct.unpack("<24i", robot(gw, "int_out"))) ==
             [i * 99991 - 7 for i in range(24)], 10, "int_out echo")
    wait_for(lambda: list(struct.unpack("<24f", robot(gw, "float_out"))) ==
             [f32(i * 1.25 - 9) for i in range(24)], 10, "float_out echo")
    wait_for(lambda: modbus_t2o(gw, regmap)["int_out[23]"] == 23 * 99991 - 7, 10,
             "int_out echo through the gateway")
    first = modbus_t2o(gw, regmap)
    assert set(k.split(":", 1)[-1] for k in first) == set(e["name"] for e in t2o_entries(regmap))
    pending = set(first)
    misses = {}
    for attempt in range(15):
        before = robot_t2o(gw)
        time.sleep(0.05)  # the gateway's copy is now newer than `before`
        got = modbus_t2o(gw, regmap)
        after = robot_t2o(gw)
        for key in list(pending):
            name = key.split(":", 1)[-1]
            a, b, x = before[name], after[name], got[key]
            if key.startswith("x"):
                scale = int(key[1:key.index(":")])
                a, b = (max(-32767, min(32767, v * scale)) for v in (a, b))
                good = between(x, a, b, 1.0 + 2 * noise_of(name) * scale + 1e-3 * abs(x))
            elif isinstance(x, float):
                good = between(x, a, b, 2 * noise_of(name) + 1e-4 * abs(x) + 1e-6)
            else:
                good = x in (a, b)
            if good:
                pending.discard(key)
            else:
                misses[key] = (x, a, b)
        if not pending:
            break
    assert not pending, {k: misses[k] for k in sorted(pending)}
    # the echoed registers are exact
    assert [first["float_out[%d]" % i] for i in range(24)] == [f32(i * 1.25 - 9) for i in range(24)]
    assert [first["int_out[%d]" % i] for i in range(24)] == [i * 99991 - 7 for i in range(24)]


# ---- the printed map ------------------------------------------------------------------

def test_print_map_formats_agree(regmap):
    """--print-map in its three formats lists the same rows; names are
    unique per area and view; a packed mask is described as a whole."""
    import re
    import subprocess
    from gwlib import DRGATEWAYD
    text = subprocess.run([str(DRGATEWAYD), "--print-map"], capture_output=True, text=True,
                          check=True).stdout.splitlines()
    md = subprocess.run([str(DRGATEWAYD), "--print-map", "--markdown"], capture_output=True,
                        text=True, check=True).stdout
    rows = re.findall(r"^\| (\d+)(?:-(\d+))? \| (\d{5})(?:-(\d{5}))? \| `([^`]+)` \| ([^|]*) \|",
                      md, re.M)
    assert len(text) == len(rows) == len(regmap.entries)
    prefix = {"CO": 0, "DI": 1, "HR": 4, "IR": 3}
    for e, (a0, a1, m0, m1, name, typ) in zip(regmap.entries, rows):
        assert int(a0) == e["address"] and name == e["name"] and typ.strip() == e["type"]
        assert int(a1 or a0) == e["address"] + e["count"] - 1
        # the Modicon reference: 0-based address + 1 after the table's digit
        assert int(m0) == prefix[e["area"]] * 10000 + e["address"] + 1
        assert int(m1 or m0) == int(m0) + e["count"] - 1
    assert "bits 0-63 packed" in regmap.entry("HR", "bit_in")["type"]
    assert "bits 0-63 packed" in regmap.entry("IR", "bit_out")["type"]
    assert regmap.entry("IR", "io_state.cb_di")["type"] == "bits 1-16 packed (bit 0 = [1])"
    assert regmap.entry("HR", "io_control.ao_type.ao0")["type"] == "BOOL (0/1)"
    assert regmap.entry("IR", "io_state.version.major")["type"] == "USINT (0..255)"


def test_scaled_view_examples_in_the_docs(regmap):
    """The worked examples of the scaled INT16 view in the docs name the
    addresses --print-map gives: "`FIELD` at IR A-B is IR C" means the
    REAL of FIELD is at A-B and its scaled register at C. (The docs once
    said "1000 above its REAL", which reads joint 5 for
    joint_state.position[3]: its REAL is at IR 204, its scaled register at
    IR 1202.)"""
    import re
    from gwlib import TOP
    pat = re.compile(r"`([\w.\[\]]+)`\s+at\s+(IR|HR)\s+(\d+)-(\d+)\s+is\s+(?:also\s+)?(IR|HR)\s+(\d+)")
    seen = {}
    for doc in ("register-map.md", "fuzzing.md"):
        text = (TOP / "docs" / doc).read_text()
        examples = pat.findall(text)
        seen[doc] = len(examples)
        for name, area, a0, a1, sarea, saddr in examples:
            real = regmap.entry(area, name)
            assert real["type"].startswith("REAL"), (doc, name, real)
            assert (real["address"], real["address"] + real["count"] - 1) == (int(a0), int(a1)), \
                (doc, name, real)
            assert sarea == area and regmap.addr(area, name, scaled=True) == int(saddr), \
                (doc, name, regmap.entry(area, name, scaled=True))
        assert "1000 above its REAL" not in text, doc
    assert seen["register-map.md"] >= 5 and seen["fuzzing.md"] >= 1, seen
    # the rule the page states, for every scaled register
    starts = {}
    for e in regmap.entries:
        if e["type"].startswith("REAL"):
            starts.setdefault((e["area"], e["address"] // 100), []).append(e["name"])
    for (area, block), names in starts.items():
        for n, name in enumerate(names):
            assert regmap.addr(area, name, scaled=True) == block * 100 + 1000 + n, (area, name)


def test_cip_status_names_in_the_docs():
    """A CIP connection-manager status the docs name in words ("0x0106,
    ownership conflict", "0x01/0x0129 (invalid configuration application
    path)") is not given the name of another status of lib/status.c's
    table (the register map once called 0x0106 "connection in use", which
    is 0x0100)."""
    import re
    from gwlib import TOP
    src = (TOP / "lib" / "status.c").read_text()
    table = src.split("cip_connection[] = {")[1].split("};")[0]
    names = {int(c, 16): t for c, t in re.findall(r'\{0x([0-9A-F]{4}), "([^"]+)"\}', table)}
    assert names[0x0106] == "ownership conflict" and names[0x0100].startswith("connection in use")
    pat = re.compile(r"0x(?:01/0x)?([0-9A-F]{4})(?:,| \(|\)? \(| =) ?([a-z][a-z /-]+)")
    docs = sorted((TOP / "docs").glob("*.md")) + sorted((TOP / "man").glob("*.[18]"))
    checked = 0
    for doc in docs:
        for m in pat.finditer(doc.read_text()):
            code, words = int(m.group(1), 16), m.group(2).strip()
            if code not in names or len(words.split()) < 2:
                continue
            checked += 1
            others = [c for c, t in names.items() if c != code and t.startswith(words)]
            assert not others, "%s: 0x%04X called '%s', the name of 0x%04X (%s)" % (
                doc.name, code, words, others[0], names[others[0]])
    assert checked >= 5, checked
