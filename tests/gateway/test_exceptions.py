# SPDX-License-Identifier: MIT
"""Every Modbus exception drgatewayd sends, and when: requests are checked
completely before anything is applied, so a refused write changes nothing."""
import socket
import struct
import threading

import pytest

from gwlib import (EX_ILLEGAL_ADDRESS, EX_ILLEGAL_FUNCTION, EX_ILLEGAL_VALUE, EX_PATH_UNAVAILABLE,
                   GW_ADDR, INSTANCE, EnipReader, RawModbus, closed_by_peer, dint_regs, real_regs,
                   running, wait_for)


@pytest.fixture(scope="module")
def gw():
    """Strict about reserved addresses: every read of one is refused."""
    with running("exc", modbus="unmapped_read = exception\n") as g:
        yield g


@pytest.fixture
def m(gw):
    with gw.raw() as c:
        yield c


def exceptions_sent(g):
    st = g.status()
    return st[10] << 16 | st[11]


def rd(fc, addr, count):
    return struct.pack(">BHH", fc, addr, count)


def fc16(addr, values, count=None, nbytes=None):
    count = len(values) if count is None else count
    nbytes = 2 * len(values) if nbytes is None else nbytes
    return struct.pack(">BHHB", 0x10, addr, count, nbytes) + \
        struct.pack(">%dH" % len(values), *values)


def fc15(addr, bits, count=None):
    data = bytearray((len(bits) + 7) // 8)
    for i, b in enumerate(bits):
        data[i // 8] |= (1 << (i % 8)) if b else 0
    count = len(bits) if count is None else count
    return struct.pack(">BHHB", 0x0F, addr, count, len(data)) + bytes(data)


# ---- 0x01 illegal function -----------------------------------------------------------

@pytest.mark.parametrize("pdu", [
    bytes([0x2B, 0x0D, 0x00, 0x00]),                       # MEI type 13 (CANopen)
    bytes([0x07]),                                          # read exception status
    bytes([0x08, 0x00, 0x00, 0x12, 0x34]),                  # diagnostics
    bytes([0x0B]), bytes([0x11]),                           # comm event counter, slave id
    struct.pack(">BHHH", 0x16, 100, 0xFFFF, 0),             # mask write register
    struct.pack(">BH", 0x18, 0),                            # read FIFO queue
    bytes([0x00]), bytes([0x41, 1, 2, 3]), bytes([0x7F]),
], ids=lambda p: "fc%02x" % p[0] + ("-mei%02x" % p[1] if p[0] == 0x2B else ""))
def test_illegal_function(gw, pdu, m):
    assert m.exception(pdu) == EX_ILLEGAL_FUNCTION


def test_illegal_function_pymodbus(gw):
    pm = gw.pymodbus()
    try:
        r = pm.mask_write_register(address=100, and_mask=0xFFFF, or_mask=0, slave=1)
        assert r.isError() and r.exception_code == EX_ILLEGAL_FUNCTION
    finally:
        pm.close()


# ---- 0x02 illegal address ----------------------------------------------------------------
# With unmapped_read = exception (the module's gateway) any reserved address
# in a read is refused; with the default (zero) they read 0 and only reads
# past a table's last mapped address are (further below).

@pytest.mark.parametrize("fc,addr,count", [
    (4, 50, 1),        # between the test registers and io_state
    (4, 124, 2),       # io_state's last register and the gap after it
    (4, 43, 2),        # the status block's last register (after the test ones) and the gap
    (4, 2047, 1),      # inside the area, unmapped
    (4, 2040, 10),     # past the end of the area
    (4, 65535, 1),
    (4, 65500, 125),   # address + count past 65535
    (3, 2, 1),         # after the control registers
    (3, 448, 1),       # after float_in
    (3, 500, 2),       # int_out is an input register, not a holding one
    (1, 0, 1),         # no coil 0
    (1, 264, 1),       # after bit_in
    (1, 400, 1),       # bit_out is a discrete input, not a coil
    (2, 4, 1),         # after the status bits
    (2, 153, 1),       # after io_state's bits
    (2, 464, 1),       # after bit_out
])
def test_illegal_address_read(gw, fc, addr, count, m):
    assert m.exception(rd(fc, addr, count)) == EX_ILLEGAL_ADDRESS


def test_illegal_address_write(gw, regmap, m):
    f0 = regmap.addr("HR", "float_in[0]")
    i0 = regmap.addr("HR", "int_in[0]")
    ao = regmap.addr("HR", "io_control.ao[0]")
    last = regmap.addr("HR", "float_in[23]")
    cases = {
        "FC06 to an input register's address (int_out)": struct.pack(">BHH", 6, 500, 1),
        "FC05 to a discrete input's address (bit_out)": struct.pack(">BHH", 5, 400, 0xFF00),
        "FC05 past bit_in": struct.pack(">BHH", 5, 264, 0xFF00),
        "FC06 to an unmapped register": struct.pack(">BHH", 6, 2, 1),
        "FC06 first half of a REAL": struct.pack(">BHH", 6, f0, 0),
        "FC06 second half of a REAL": struct.pack(">BHH", 6, f0 + 1, 0),
        "FC06 half of a DINT": struct.pack(">BHH", 6, i0, 0),
        "FC06 half of io_control.ao[0]": struct.pack(">BHH", 6, ao, 0),
        "FC16 starting in the middle of a REAL": fc16(f0 + 1, [0, 0]),
        "FC16 ending in the middle of a REAL": fc16(f0, [0, 0, 0]),
        "FC16 ending in the middle of a DINT": fc16(i0 + 2, [0, 0, 0]),
        "FC16 running past float_in": fc16(last, [0, 0, 0, 0]),
        "FC16 past the area": fc16(2047, [0, 0]),
        "FC15 past bit_in": fc15(regmap.addr("CO", "bit_in[63]"), [1, 1]),
        "FC15 past the area": fc15(2040, [1] * 10),
    }
    got = {k: m.exception(p) for k, p in cases.items()}
    assert got == {k: EX_ILLEGAL_ADDRESS for k in cases}


# ---- 0x03 illegal value ------------------------------------------------------------------

NANS_AND_INFS = [0x7FC00000, 0xFFC00000, 0x7F800001, 0x7FFFFFFF, 0x7F800000, 0xFF800000]


def test_illegal_value_real(gw, regmap, m):
    for name in ("float_in[0]", "float_in[23]", "io_control.ao[1]"):
        a = regmap.addr("HR", name)
        for bits in NANS_AND_INFS:
            regs = dint_regs(struct.unpack(">i", struct.pack(">I", bits))[0], "abcd")
            assert m.exception(fc16(a, regs)) == EX_ILLEGAL_VALUE, (name, hex(bits))


def test_illegal_value_bits(gw, regmap, m):
    for name in ("io_control.ao_type.ao0", "io_control.ao_type.ao1"):
        a = regmap.addr("HR", name)
        for v in (2, 3, 0x100, 0xFFFF):
            assert m.exception(struct.pack(">BHH", 6, a, v)) == EX_ILLEGAL_VALUE, (name, v)
        m.write_reg(a, 1)
        m.write_reg(a, 0)
    tool = regmap.addr("HR", "io_control.tool_do")
    for v in (0x40, 0x7F, 0x80, 0xFFC0, 0xFFFF):
        assert m.exception(struct.pack(">BHH", 6, tool, v)) == EX_ILLEGAL_VALUE, hex(v)
    m.write_reg(tool, 0x3F)
    m.write_reg(tool, 0)
    # the fault reset register takes 0 or 1
    assert m.exception(struct.pack(">BHH", 6, 1, 2)) == EX_ILLEGAL_VALUE
    # FC05 takes 0xFF00 or 0x0000 only
    co = regmap.addr("CO", "bit_in[0]")
    for v in (0x0001, 0x00FF, 0x1234, 0xFFFF):
        assert m.exception(struct.pack(">BHH", 5, co, v)) == EX_ILLEGAL_VALUE, hex(v)


@pytest.mark.parametrize("pdu", [
    rd(1, 100, 0), rd(2, 100, 0), rd(3, 400, 0), rd(4, 100, 0),
    rd(1, 0, 2001), rd(2, 0, 2001), rd(3, 400, 126), rd(4, 100, 126),
    rd(4, 0, 0xFFFF),
    fc16(400, [], count=0, nbytes=0),
    fc16(300, [0, 0], count=124, nbytes=248),    # more than 123 registers
    fc16(300, [0, 0], nbytes=3),                 # byte count does not match
    fc16(300, [0, 0], count=4),                  # quantity does not match the data
    fc15(200, [], count=0),
    fc15(200, [0] * 1969),                       # more than 1968 coils
    struct.pack(">BHHB", 0x0F, 200, 9, 1) + b"\x00",  # 9 coils in 1 byte
    rd(3, 400, 1)[:4],                           # a read one byte short
    rd(3, 400, 1) + b"\x00",                     # a read one byte long
    struct.pack(">BHHB", 6, 2, 0, 0),            # FC06 one byte long
], ids=lambda p: p.hex()[:24])
def test_illegal_value_quantity(gw, pdu, m):
    assert m.exception(pdu) == EX_ILLEGAL_VALUE


def test_quantity_limits_are_inclusive(gw, m):
    # 125 registers, 2000 bits, 123 registers written: allowed (where mapped)
    assert m.exception(rd(4, 200, 125)) in (None, EX_ILLEGAL_ADDRESS)
    assert m.exception(rd(4, 500, 125)) == EX_ILLEGAL_ADDRESS  # 548.. unmapped
    assert m.exception(rd(3, 400, 48)) is None
    assert len(m.read(4, 200, 72)) == 72


# ---- a refused write changes nothing -------------------------------------------------------

def test_refused_fc16_changes_nothing(gw, regmap, m):
    enip = EnipReader("127.0.0.2", gw.sim.tcp)
    try:
        f0 = regmap.addr("HR", "float_in[0]")
        good = [w for v in (1.5, 2.5, 3.5, 4.5) for w in real_regs(v, "abcd")]
        m.write_regs(f0, good)
        wait_for(lambda: struct.unpack_from("<4f", enip.get(INSTANCE["float_in"])) ==
                 (1.5, 2.5, 3.5, 4.5), 10, "float_in[0..3] at the robot")
        for bad in (
            [w for v in (9.0, 9.0) for w in real_regs(v, "abcd")] + [0x7FC0, 0] +
            real_regs(9.0, "abcd"),                                      # NaN third
            [w for v in (9.0, 9.0, 9.0) for w in real_regs(v, "abcd")] + [0x7F80, 0],  # inf last
        ):
            assert m.exception(fc16(f0, bad)) == EX_ILLEGAL_VALUE
            assert m.read(3, f0, 8) == good
        # running into unmapped registers: nothing of the good part either
        last = regmap.addr("HR", "float_in[22]")
        before = m.read(3, last, 4)
        assert m.exception(fc16(last, real_regs(7.0, "abcd") + real_regs(8.0, "abcd") +
                                [0, 0])) == EX_ILLEGAL_ADDRESS
        assert m.read(3, last, 4) == before
        # ending on half a REAL
        assert m.exception(fc16(f0, real_regs(7.0, "abcd") + [0x4100])) == EX_ILLEGAL_ADDRESS
        assert m.read(3, f0, 8) == good
        # io_control: a good cb_do and a bad tool_do in one request
        do = regmap.addr("HR", "io_control.cb_do")
        m.write_regs(do, [0x00F0, 0x0001])
        assert m.exception(fc16(do, [0x0F00, 0x0040])) == EX_ILLEGAL_VALUE
        assert m.read(3, do, 2) == [0x00F0, 0x0001]
        # coils running past the end
        co = regmap.addr("CO", "io_control.ao_type.ao0")
        m.write_coils(co, [0, 0])
        assert m.exception(fc15(co, [1, 1, 1])) == EX_ILLEGAL_ADDRESS
        assert m.read(1, co, 2) == [0, 0]
        # and the robot never saw any of it
        assert struct.unpack_from("<4f", enip.get(INSTANCE["float_in"])) == (1.5, 2.5, 3.5, 4.5)
        wait_for(lambda: struct.unpack_from("<I", enip.get(INSTANCE["io_control"]))[0]
                 == 0x00F0 | 1 << 16, 10, "io_control at the robot")
    finally:
        enip.close()


# ---- 0x0A unknown unit -------------------------------------------------------------------

@pytest.mark.parametrize("unit", [0, 2, 9, 247, 255])
def test_unknown_unit(gw, unit, m):
    assert m.exception(rd(4, 0, 1), unit=unit) == EX_PATH_UNAVAILABLE
    assert m.exception(rd(3, 400, 2), unit=unit) == EX_PATH_UNAVAILABLE
    assert m.exception(struct.pack(">BHH", 6, 0, 1), unit=unit) == EX_PATH_UNAVAILABLE


def test_unknown_unit_pymodbus(gw):
    pm = gw.pymodbus()
    try:
        r = pm.read_input_registers(0, count=1, slave=9)
        assert r.isError() and r.exception_code == EX_PATH_UNAVAILABLE
        r = pm.read_input_registers(0, count=1, slave=1)
        assert not r.isError() and r.registers == [1]
    finally:
        pm.close()


def test_exceptions_are_counted(gw, m):
    before = exceptions_sent(gw)
    for _ in range(5):
        assert m.exception(rd(4, 50, 1)) == EX_ILLEGAL_ADDRESS
    # the status block is refreshed 10 times a second
    wait_for(lambda: exceptions_sent(gw) >= before + 5, 10, "the exception counter")


def test_connection_survives_exceptions(gw, m):
    """An exception answers the request; the connection stays for the next."""
    for pdu in (bytes([0x2B, 0x0E, 5, 0]), rd(4, 50, 1), rd(3, 400, 0),
                struct.pack(">BHH", 6, 102, 2)):
        assert m.exception(pdu) is not None
        assert m.exception(rd(4, 0, 1), unit=77) == EX_PATH_UNAVAILABLE
        assert m.read(4, 32, 1) == [0x1234]


# ---- read-only clients and the allowlist ------------------------------------------------

def connect_from(src, port):
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.bind((src, 0))
    s.settimeout(10)
    s.connect((GW_ADDR, port))
    m = RawModbus.__new__(RawModbus)
    m.sock = s
    m.tid = 1
    m.lock = threading.Lock()
    return m


@pytest.fixture(scope="module")
def gw_ro():
    with running("exc-ro", modbus="allow = 127.0.0.3/32 rw\nallow = 127.0.0.0/8 ro\n") as g:
        yield g


def test_read_only_client(gw_ro, regmap):
    with connect_from("127.0.0.1", gw_ro.port) as m:
        f0 = regmap.addr("HR", "float_in[0]")
        assert m.read(4, 32, 1) == [0x1234]
        assert m.read(3, f0, 2) == [0, 0]
        assert m.read(1, 200, 8) == [0] * 8
        for pdu in (struct.pack(">BHH", 6, 0, 1), fc16(f0, [0x3F80, 0]),
                    struct.pack(">BHH", 5, 200, 0xFF00), fc15(200, [1, 0, 1])):
            assert m.exception(pdu) == EX_ILLEGAL_FUNCTION, pdu.hex()
        assert m.read(3, f0, 2) == [0, 0]
    # the read-write network
    with connect_from("127.0.0.3", gw_ro.port) as m:
        m.write_regs(regmap.addr("HR", "float_in[0]"), [0x3F80, 0])
        assert m.read(3, regmap.addr("HR", "float_in[0]"), 2) == [0x3F80, 0]
    assert "connected (read-only)" in gw_ro.log()
    assert "connected (read-write)" in gw_ro.log()


def test_read_only_client_pymodbus(gw_ro):
    pm = gw_ro.pymodbus()
    try:
        r = pm.write_register(0, 5, slave=1)
        assert r.isError() and r.exception_code == EX_ILLEGAL_FUNCTION
    finally:
        pm.close()


@pytest.fixture(scope="module")
def gw_allow():
    with running("exc-allow", modbus="allow = 127.0.0.1/32 rw\n") as g:
        yield g


def test_allowlist_refuses_other_networks(gw_allow):
    for src in ("127.0.0.5", "127.0.0.9"):
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.bind((src, 0))
        s.connect((GW_ADDR, gw_allow.port))
        s.sendall(struct.pack(">HHHB", 1, 0, 6, 1) + rd(4, 0, 1))
        assert closed_by_peer(s), "a client outside the allowlist must be closed"
        s.close()
    wait_for(lambda: "refused 127.0.0.9" in gw_allow.log(), 10, "the refusal in the log")
    assert "not in the allowlist" in gw_allow.log()
    with connect_from("127.0.0.1", gw_allow.port) as m:
        assert m.read(4, 32, 1) == [0x1234]


# ---- reserved addresses with the default unmapped_read = zero ------------------------------

@pytest.fixture(scope="module")
def gw_zero():
    with running("exc-zero") as g:
        yield g


def extents(regmap):
    """One past the last mapped address of each table."""
    ext = {}
    for e in regmap.entries:
        ext[e["area"]] = max(ext.get(e["area"], 0), e["address"] + e["count"])
    return ext


@pytest.mark.parametrize("fc,addr,count,want", [
    (4, 50, 1, [0]),          # between the test registers and io_state
    (4, 44, 56, [0] * 56),    # the whole gap
    (3, 2, 3, [0, 0, 0]),     # after the control registers
    (1, 0, 2, [0, 0]),        # no coil 0 or 1
    (2, 4, 3, [0, 0, 0]),     # after the status bits
])
def test_reserved_addresses_read_zero(gw_zero, fc, addr, count, want):
    with gw_zero.raw() as m:
        assert m.read(fc, addr, count) == want


def test_125_register_reads_across_blocks(gw_zero, regmap):
    """A PLC reads 125 registers in one request: the blocks inside keep
    their values, the reserved registers between them read 0."""
    test0 = regmap.addr("IR", "test.u16 = 0x1234")
    ver = regmap.addr("IR", "io_state.version.major")
    with gw_zero.raw() as m:
        whole = m.read(4, 0, 125)
        assert whole[test0:test0 + 8] == m.read(4, test0, 8)
        assert whole[ver:ver + 3] == [2, 12, 3]
        mapped = {a for e in regmap.area("IR")
                  for a in range(e["address"], e["address"] + e["count"])}
        gaps = [a for a in range(125) if a not in mapped]
        assert len(gaps) >= 56 and [whole[a] for a in gaps] == [0] * len(gaps)
        # int_in (HR 300-347), the gap, float_in (HR 400-424): what was written is read
        i0, f0 = regmap.addr("HR", "int_in[0]"), regmap.addr("HR", "float_in[0]")
        m.write_regs(i0, dint_regs(-5, "abcd"))
        m.write_regs(f0, real_regs(2.5, "abcd"))
        hr = m.read(3, i0, 125)
        assert hr[0:2] == dint_regs(-5, "abcd")
        assert hr[f0 - i0:f0 - i0 + 2] == real_regs(2.5, "abcd")
        assert hr[48:f0 - i0] == [0] * (f0 - i0 - 48)


def test_reads_past_the_map_are_refused(gw_zero, regmap):
    ext = extents(regmap)
    with gw_zero.raw() as m:
        for area, fc in (("CO", 1), ("DI", 2), ("HR", 3), ("IR", 4)):
            e = ext[area]
            assert m.exception(rd(fc, e, 1)) == EX_ILLEGAL_ADDRESS, area
            assert m.exception(rd(fc, e - 1, 2)) == EX_ILLEGAL_ADDRESS, area
            assert m.exception(rd(fc, e - 1, 1)) is None, area
        assert m.exception(rd(4, 65500, 125)) == EX_ILLEGAL_ADDRESS
        assert m.exception(rd(4, 2040, 10)) == EX_ILLEGAL_ADDRESS


def test_writes_to_reserved_addresses_are_refused(gw_zero, regmap):
    """Reading a gap is harmless; writing one is still an error, and a
    write that runs into a gap changes nothing."""
    # the packed bit_in words (one register each may be written) end at a gap
    last = regmap.entry("HR", "bit_in")
    end = last["address"] + last["count"]
    with gw_zero.raw() as m:
        before = m.read(3, end - 1, 1)
        assert m.exception(struct.pack(">BHH", 6, 2, 1)) == EX_ILLEGAL_ADDRESS
        assert m.exception(fc16(end - 1, [before[0] ^ 1, 0])) == EX_ILLEGAL_ADDRESS
        assert m.read(3, end - 1, 1) == before
        assert m.exception(struct.pack(">BHH", 5, 0, 0xFF00)) == EX_ILLEGAL_ADDRESS
