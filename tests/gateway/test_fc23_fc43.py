# SPDX-License-Identifier: MIT
"""FC 23 (read/write multiple registers) and FC 43 / MEI 14 (read device
identification), issue 11 item 5: through pymodbus, through pyModbusTCP
(an independent Python implementation) and through libmodbus's own client
(C, via ctypes), and as raw frames for the exact exceptions. A FC 23 whose
write or read part is refused applies nothing."""
import ctypes
import struct
import subprocess

import pytest

from gwlib import (libmodbus, DRGATEWAYD, EX_ILLEGAL_ADDRESS, EX_ILLEGAL_FUNCTION, EX_ILLEGAL_VALUE,
                   EX_PATH_UNAVAILABLE, GW_ADDR, INSTANCE, EnipReader, dint_regs, regs_dint,
                   running, timeout, wait_for)


@pytest.fixture(scope="module")
def gw():
    with running("fc23-fc43") as g:
        g.enip = EnipReader("127.0.0.2", g.sim.tcp)
        yield g
        g.enip.close()


@pytest.fixture(scope="module")
def version():
    out = subprocess.run([str(DRGATEWAYD), "--version"], check=True, capture_output=True,
                         text=True, timeout=timeout(30)).stdout
    return out.split()[1].encode()


def robot_int_in(g, i):
    return struct.unpack_from("<i", g.enip.get(INSTANCE["int_in"]), 4 * i)[0]


def fc23(raddr, rcount, waddr, values, nbytes=None):
    return struct.pack(">BHHHHB", 0x17, raddr, rcount, waddr, len(values),
                       2 * len(values) if nbytes is None else nbytes) + \
        struct.pack(">%dH" % len(values), *values)


# ---- FC 23 ---------------------------------------------------------------------

def test_fc23_pymodbus_writes_then_reads(gw, regmap):
    a = regmap.addr("HR", "int_in[0]")
    c = gw.pymodbus()
    try:
        rr = c.readwrite_registers(read_address=a, read_count=4, write_address=a + 2,
                                   values=dint_regs(-5, "abcd"), slave=1)
        assert not rr.isError(), rr
        # the read is made after the write: int_in[1] reads what was written
        assert rr.registers[2:4] == dint_regs(-5, "abcd")
        wait_for(lambda: robot_int_in(gw, 1) == -5, 10, "int_in[1] at the robot")
    finally:
        c.close()


def test_fc23_refused_write_part_applies_nothing(gw, regmap):
    a = regmap.addr("HR", "int_in[0]")
    with gw.raw() as m:
        m.write_regs(a, dint_regs(11, "abcd") + dint_regs(22, "abcd"))
        before = m.read(3, a, 4)
        # half a DINT in the write part: 0x02, nothing written
        assert m.exception(fc23(a, 2, a + 1, [7])) == EX_ILLEGAL_ADDRESS
        # a valid write, but the read part past the table: 0x02, nothing written
        assert m.exception(fc23(2047, 2, a, dint_regs(99, "abcd"))) == EX_ILLEGAL_ADDRESS
        # malformed: byte count, quantities
        assert m.exception(fc23(a, 2, a, dint_regs(99, "abcd"), nbytes=3)) == EX_ILLEGAL_VALUE
        assert m.exception(fc23(a, 126, a, dint_regs(99, "abcd"))) == EX_ILLEGAL_VALUE
        assert m.exception(fc23(a, 0, a, dint_regs(99, "abcd"))) == EX_ILLEGAL_VALUE
        assert m.read(3, a, 4) == before
        assert robot_int_in(gw, 0) == 11 or wait_for(lambda: robot_int_in(gw, 0) == 11, 10)


def test_fc23_pymodbustcp(gw, regmap):
    from pyModbusTCP.client import ModbusClient
    a = regmap.addr("HR", "int_in[2]")
    c = ModbusClient(host=GW_ADDR, port=gw.port, unit_id=1, timeout=timeout(5), auto_open=True)
    try:
        regs = c.write_read_multiple_registers(a, dint_regs(424242, "abcd"), a, 2)
        assert regs is not None, c.last_error_as_txt
        assert regs_dint(regs, "abcd") == 424242
        wait_for(lambda: robot_int_in(gw, 2) == 424242, 10, "int_in[2] at the robot")
    finally:
        c.close()



def test_fc23_libmodbus_client(gw, regmap):
    """libmodbus's modbus_write_and_read_registers, a C client."""
    lib = libmodbus()
    a = regmap.addr("HR", "int_in[3]")
    ctx = lib.modbus_new_tcp(GW_ADDR.encode(), gw.port)
    assert ctx
    try:
        lib.modbus_set_slave(ctx, 1)
        lib.modbus_set_response_timeout(ctx, int(timeout(5)), 0)
        assert lib.modbus_connect(ctx) == 0
        src = (ctypes.c_uint16 * 2)(*dint_regs(-77777, "abcd"))
        dest = (ctypes.c_uint16 * 2)()
        rc = lib.modbus_write_and_read_registers(ctx, a, 2, src, a, 2, dest)
        assert rc == 2, lib.modbus_strerror(ctypes.get_errno())
        assert regs_dint(list(dest), "abcd") == -77777
        wait_for(lambda: robot_int_in(gw, 3) == -77777, 10, "int_in[3] at the robot")
        # a refused one: libmodbus reports the exception (EMBXILADD)
        rc = lib.modbus_write_and_read_registers(ctx, a + 1, 1, src, a, 2, dest)
        assert rc == -1
    finally:
        lib.modbus_close(ctx)
        lib.modbus_free(ctx)


# ---- FC 43 / MEI 14 ----------------------------------------------------------------

def test_fc43_pymodbus(gw, version):
    c = gw.pymodbus()
    try:
        basic = c.read_device_information(read_code=1, object_id=0, slave=1)
        assert not basic.isError(), basic
        assert basic.information == {0: b"drgate", 1: b"drgatewayd", 2: version}
        assert basic.conformity == 0x83
        regular = c.read_device_information(read_code=2, object_id=0, slave=1)
        assert regular.information[4].startswith(b"drgate")
        assert regular.information[6] == b"r0"          # the unit's robot
        assert 3 not in regular.information              # no VendorUrl
        ext = c.read_device_information(read_code=3, object_id=0, slave=1)
        assert ext.information[0x80] == b"r0"
        assert ext.information[0x81] == b"2.12.3"        # drsim's io_state.version
        one = c.read_device_information(read_code=4, object_id=0x81, slave=1)
        assert one.information == {0x81: b"2.12.3"}
    finally:
        c.close()


def test_fc43_pymodbustcp(gw, version):
    from pyModbusTCP.client import ModbusClient
    c = ModbusClient(host=GW_ADDR, port=gw.port, unit_id=1, timeout=timeout(5), auto_open=True)
    try:
        r = c.read_device_identification(read_code=3)
        assert r is not None, c.last_error_as_txt
        assert r.vendor_name == b"drgate" and r.product_code == b"drgatewayd"
        assert r.major_minor_revision == version and r.user_application_name == b"r0"
        assert r.objects_by_id[0x81] == b"2.12.3" and r.more_follows == 0
    finally:
        c.close()


def test_fc43_raw_frames_and_exceptions(gw):
    with gw.raw() as m:
        # stream access from an object the category lacks starts at 0
        r = m.request(bytes([0x2B, 0x0E, 0x02, 0x03]))
        assert r[:4] == bytes([0x2B, 0x0E, 0x02, 0x83]) and r[4:6] == b"\x00\x00"
        assert r[7] == 0x00 and r[9:15] == b"drgate"
        assert m.exception(bytes([0x2B, 0x0E, 0x04, 0x03])) == EX_ILLEGAL_ADDRESS  # no object
        assert m.exception(bytes([0x2B, 0x0E, 0x05, 0x00])) == EX_ILLEGAL_VALUE    # read code
        assert m.exception(bytes([0x2B, 0x0E, 0x01])) == EX_ILLEGAL_VALUE          # too short
        assert m.exception(bytes([0x2B, 0x0D, 0x00, 0x00])) == EX_ILLEGAL_FUNCTION  # CANopen
        assert m.exception(bytes([0x2B, 0x0E, 0x01, 0x00]), unit=9) == EX_PATH_UNAVAILABLE
        # the connection goes on
        assert m.read(4, 32, 1) == [0x1234]
