# SPDX-License-Identifier: MIT
"""Modbus RTU over a pseudo-terminal pair (socat pty,raw,echo=0): the
gateway is the slave on one end, independent masters on the other:
pymodbus's serial client, Debian's mbpoll -m rtu, and a raw framer written
here (CRC-16/MODBUS by hand). Two robots on one line: r0 at slave address
5 (robots = r0:5), r1 at its unit_id 2.

A pty has no baud rate: the t3.5 rule is tested with gaps made here, far
from the 4 ms of 9600 baud 8N2 (a frame split by a pause of 400 ms is two
broken frames; a frame written at once is one), so that a loaded machine
does not change the outcome."""
import contextlib
import os
import select
import shutil
import struct
import subprocess
import termios
import time

import pytest

from gwlib import (DRGATEWAYD, crc16, GW_ADDR, free_port, EX_ILLEGAL_ADDRESS, EX_ILLEGAL_FUNCTION, INSTANCE, LOGDIR, Drsim,
                   EnipReader, Gateway, REAL_123456, spawn, timeout, wait_for)

SOCAT = shutil.which("socat")
MBPOLL = shutil.which("mbpoll")
pytestmark = pytest.mark.skipif(SOCAT is None, reason="socat is not installed (make test-deps)")

BAUD = 9600
R0, R1 = 5, 2  # slave addresses


@contextlib.contextmanager
def pty_pair(name):
    """socat's two linked ptys: (the gateway's end, the master's end)."""
    LOGDIR.mkdir(parents=True, exist_ok=True)
    a, b = LOGDIR / ("%s.ttyA" % name), LOGDIR / ("%s.ttyB" % name)
    for p in (a, b):
        if p.exists() or p.is_symlink():
            p.unlink()
    proc = spawn([SOCAT, "-d", "-d", "pty,raw,echo=0,link=%s" % a, "pty,raw,echo=0,link=%s" % b],
                 LOGDIR / ("%s.socat.log" % name))
    try:
        wait_for(lambda: a.exists() and b.exists(), 10, "socat's ptys")
        yield str(a), str(b)
    finally:
        proc.kill()
        proc.wait()


class RawRtu:
    """A master on the pty, framing by hand."""

    def __init__(self, path):
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        attr = termios.tcgetattr(self.fd)
        attr[0] = attr[1] = attr[3] = 0  # raw: no input, output or local processing
        termios.tcsetattr(self.fd, termios.TCSANOW, attr)

    def close(self):
        os.close(self.fd)

    def drain(self):
        while select.select([self.fd], [], [], 0.05)[0]:
            os.read(self.fd, 512)

    def send(self, frame):
        os.write(self.fd, frame)

    def recv(self, seconds):
        """Bytes until the line is quiet for 100 ms (after the first), or
        nothing within `seconds`."""
        out = b""
        wait = timeout(seconds)
        while select.select([self.fd], [], [], wait)[0]:
            got = os.read(self.fd, 512)
            if not got:
                break
            out += got
            wait = 0.1
        return out

    def request(self, addr, pdu):
        self.drain()
        self.send(bytes([addr]) + pdu + crc16(bytes([addr]) + pdu))
        rsp = self.recv(5)
        assert len(rsp) >= 5, "no reply from slave %d" % addr
        assert rsp[-2:] == crc16(rsp[:-2]), "bad CRC in the reply %s" % rsp.hex()
        assert rsp[0] == addr
        return rsp[1:-2]

    def read(self, fc, addr, count, slave):
        pdu = self.request(slave, struct.pack(">BHH", fc, addr, count))
        assert pdu[0] == fc, "exception %s" % pdu.hex()
        if fc in (1, 2):
            return [(pdu[2 + i // 8] >> (i % 8)) & 1 for i in range(count)]
        return list(struct.unpack(">%dH" % count, pdu[2:2 + 2 * count]))


def rtu_section(dev, extra=""):
    # no parity, two stop bits (the specification's other 11-bit frame):
    # pyserial cannot reconfigure a pty set to even parity (EINVAL), and
    # pymodbus reconfigures after opening; the word-order tests below run
    # on the default, 8E1
    return ("\n[modbus_rtu line1]\ndevice = %s\nbaud = %d\nparity = none\nstop_bits = 2\n"
            "robots = r0:%d, r1\n%s" % (dev, BAUD, R0, extra))


@pytest.fixture(scope="module")
def gw():
    sims = [Drsim("rtu-%d" % i).start() for i in range(2)]
    with pty_pair("rtu") as (dev, master):
        g = Gateway("rtu", sims, extra=rtu_section(dev))
        try:
            g.start()
            g.master = master
            g.raw_rtu = RawRtu(master)
            g.enip = [EnipReader("127.0.0.2", s.tcp) for s in sims]
            yield g
            g.raw_rtu.close()
            for e in g.enip:
                e.close()
        finally:
            g.kill()
            for s in sims:
                s.kill()


def pymodbus_rtu(path):
    from pymodbus.client import ModbusSerialClient
    c = ModbusSerialClient(path, baudrate=BAUD, parity="N", stopbits=2, bytesize=8,
                           timeout=timeout(3), retries=0)
    assert c.connect()
    return c


def test_reads_of_both_robots(gw):
    # t3.5 at 9600 baud, 11 bits a character: 3.5 x 11 / 9600 s
    assert "(9600 8N2, 2 robot(s), t3.5 4010 us)" in gw.log()
    m = gw.raw_rtu
    for slave in (R0, R1):
        assert m.read(4, 32, 8, slave)[:3] == [0x1234, 0x1234, 0x5678]
        st = m.read(4, 0, 2, slave)
        assert st == [1, 2]  # layout version, link up
    # the unit answering at R0 is robot r0 (FC 43 object 0x80: its name)
    for slave, name in ((R0, b"r0"), (R1, b"r1")):
        pdu = m.request(slave, bytes([0x2B, 0x0E, 4, 0x80]))
        assert pdu[:3] == bytes([0x2B, 0x0E, 4]) and pdu[7] == 0x80 and pdu[9:] == name


def test_pymodbus_every_read_and_write_path(gw, regmap):
    c = pymodbus_rtu(gw.master)
    try:
        r = c.read_input_registers(32, count=8, slave=R0)
        assert not r.isError() and r.registers[3:5] == REAL_123456["abcd"]
        # holding registers: FC 16 (a DINT) and 6 (a packed bit word),
        # read back with FC 3; FC 23 reads after it writes
        a = regmap.addr("HR", "int_in[0]")
        w = regmap.addr("HR", "bit_in")
        assert not c.write_registers(a, [0, 11], slave=R0).isError()
        assert not c.write_register(w + 1, 13, slave=R0).isError()
        assert c.read_holding_registers(a, count=2, slave=R0).registers == [0, 11]
        assert c.read_holding_registers(w + 1, count=1, slave=R0).registers == [13]
        r = c.readwrite_registers(read_address=a, read_count=4, write_address=a + 2,
                                  values=[0, 22], slave=R0)
        assert not r.isError() and r.registers == [0, 11, 0, 22]
        # coils: FC 15 and 5, read back with FC 1; discrete inputs FC 2
        b = regmap.addr("CO", "bit_in[0]")
        assert not c.write_coils(b, [True, False, True], slave=R1).isError()
        assert not c.write_coil(b + 1, True, slave=R1).isError()
        assert c.read_coils(b, count=3, slave=R1).bits[:3] == [True, True, True]
        assert not c.read_discrete_inputs(0, count=2, slave=R1).isError()
        # a REAL in the configured word order, and it reached the robot
        f = regmap.addr("HR", "float_in[2]")
        assert not c.write_registers(f, REAL_123456["abcd"], slave=R0).isError()
        wait_for(lambda: struct.unpack_from("<f", gw.enip[0].get(INSTANCE["float_in"]), 8)[0]
                 == 123456.0, 10, "float_in[2] at robot r0")
        wait_for(lambda: struct.unpack_from("<2i", gw.enip[0].get(INSTANCE["int_in"]), 0)
                 == (11, 22), 10, "int_in[0..1] at robot r0")
        # the other robot's image did not move
        assert struct.unpack_from("<f", gw.enip[1].get(INSTANCE["float_in"]), 8)[0] != 123456.0
    finally:
        c.close()


def test_exceptions_as_on_tcp(gw):
    m = gw.raw_rtu
    assert m.request(R0, struct.pack(">BHH", 4, 2000, 10)) == bytes([0x84, EX_ILLEGAL_ADDRESS])
    assert m.request(R0, bytes([0x08, 0, 0, 0x12, 0x34])) == bytes([0x88, EX_ILLEGAL_FUNCTION])
    # a write to a read-only area: FC 6 to an input register's address is a
    # holding register, but FC 5 to a discrete input's number past the map
    assert m.request(R1, struct.pack(">BHH", 5, 2047, 0xFF00))[0] == 0x85


def counters(g, unit=1):
    """Status IR 40-41 and 42-43 (over TCP): frames dropped, frames for
    other slaves; 32-bit, high word first."""
    st = g.status(unit)
    return st[40] << 16 | st[41], st[42] << 16 | st[43]


def test_bad_crc_dropped_silently_and_counted(gw):
    m = gw.raw_rtu
    crc0, other0 = counters(gw)
    frame = bytes([R0, 4, 0, 32, 0, 1])
    m.drain()
    m.send(frame + bytes([crc16(frame)[0] ^ 0xFF, crc16(frame)[1]]))
    assert m.recv(0.5) == b""
    wait_for(lambda: counters(gw)[0] >= crc0 + 1, 5, "rtu_frames_dropped + 1")
    assert counters(gw) == (crc0 + 1, other0)
    assert m.read(4, 32, 1, R0) == [0x1234]  # the line still works


def test_other_slave_ignored_and_counted(gw):
    m = gw.raw_rtu
    crc0, other0 = counters(gw)
    m.drain()
    frame = bytes([9, 4, 0, 32, 0, 1])
    m.send(frame + crc16(frame))
    assert m.recv(0.5) == b""
    wait_for(lambda: counters(gw)[1] >= other0 + 1, 5, "rtu_frames_other_slave + 1")
    assert counters(gw) == (crc0, other0 + 1)
    # robot r1 counts the same line
    assert counters(gw, 2) == counters(gw)


def test_counters_are_32_bit(gw):
    """300 frames for another slave: the counter goes past 255. Sent 30
    at a time, each batch counted before the next, so that no read of the
    port brings more than the framer's 256 bytes."""
    m = gw.raw_rtu
    crc0, other0 = counters(gw)
    frame = bytes([9, 4, 0, 32, 0, 1])
    frame += crc16(frame)
    m.drain()
    for k in range(1, 11):
        m.send(frame * 30)
        wait_for(lambda: counters(gw)[1] >= other0 + 30 * k, 5, "%d frames counted" % (30 * k))
    assert m.recv(0.5) == b""
    assert counters(gw) == (crc0, other0 + 300)
    assert counters(gw, 2) == counters(gw)


def test_broadcast_write_applied_without_reply(gw, regmap):
    m = gw.raw_rtu
    a = regmap.addr("HR", "bit_in") + 2  # a packed bit word
    m.drain()
    frame = bytes([0]) + struct.pack(">BHH", 6, a, 4321)
    m.send(frame + crc16(frame))
    assert m.recv(0.5) == b""
    for slave in (R0, R1):
        wait_for(lambda: m.read(3, a, 1, slave) == [4321], 5, "the broadcast at %d" % slave)
    # a read to address 0 is not answered either
    frame = bytes([0]) + struct.pack(">BHH", 4, 32, 1)
    m.send(frame + crc16(frame))
    assert m.recv(0.5) == b""


def test_t35_gap_splits_a_frame(gw):
    m = gw.raw_rtu
    crc0, other0 = counters(gw)
    frame = bytes([R0, 4, 0, 32, 0, 1])
    frame += crc16(frame)
    m.drain()
    m.send(frame[:3])
    time.sleep(0.4)  # 100 x t3.5 at 9600 baud
    m.send(frame[3:])
    assert m.recv(0.5) == b"", "a frame split by a silence was answered"
    wait_for(lambda: counters(gw)[0] >= crc0 + 2, 5, "two broken frames")
    assert counters(gw) == (crc0 + 2, other0)
    # written at once: one frame
    m.send(frame)
    rsp = m.recv(5)
    assert rsp == bytes([R0, 4, 2, 0x12, 0x34]) + crc16(bytes([R0, 4, 2, 0x12, 0x34]))


def test_back_to_back_frames_both_answered(gw):
    """Two requests in one write (no gap at all: a master must leave
    t3.5, but the lengths their codes give still separate them)."""
    m = gw.raw_rtu
    f1 = bytes([R0, 4, 0, 32, 0, 1])
    f2 = bytes([R1, 4, 0, 32, 0, 1])
    m.drain()
    m.send(f1 + crc16(f1) + f2 + crc16(f2))
    rsp = m.recv(5)
    r1 = bytes([R0, 4, 2, 0x12, 0x34])
    r2 = bytes([R1, 4, 2, 0x12, 0x34])
    assert rsp == r1 + crc16(r1) + r2 + crc16(r2)


@pytest.mark.skipif(MBPOLL is None, reason="mbpoll is not installed (make test-deps)")
def test_mbpoll_rtu(gw, regmap):
    base = [MBPOLL, "-m", "rtu", "-b", str(BAUD), "-P", "none", "-d", "8", "-s", "2",
            "-0", "-o", "3"]
    r = subprocess.run(base + ["-a", str(R1), "-t", "3:float", "-B", "-r", "35", "-c", "2",
                               "-1", gw.master], capture_output=True, text=True,
                       timeout=timeout(30), stdin=subprocess.DEVNULL)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "123456" in r.stdout and "-1.5" in r.stdout
    a = regmap.addr("HR", "bit_in") + 3  # bits 48-63
    r = subprocess.run(base + ["-a", str(R1), "-t", "4", "-r", str(a), gw.master, "--", "77"],
                       capture_output=True, text=True, timeout=timeout(30),
                       stdin=subprocess.DEVNULL)
    assert r.returncode == 0 and "Written 1 references" in r.stdout, r.stdout + r.stderr
    wait_for(lambda: struct.unpack_from("<H", gw.enip[1].get(INSTANCE["bit_in"]), 6)[0] == 77,
             10, "bit_in[48..63] at robot r1")
    # an exception as mbpoll reports it
    r = subprocess.run(base + ["-a", str(R1), "-t", "3", "-r", "2040", "-1", gw.master],
                       capture_output=True, text=True, timeout=timeout(30),
                       stdin=subprocess.DEVNULL)
    assert r.returncode != 0 and "Illegal data address" in r.stdout + r.stderr


@pytest.mark.parametrize("order", ["cdab", "dcba"])
def test_word_order_on_rtu(order):
    sim = Drsim("rtu-wo-%s" % order).start()
    with pty_pair("rtu-wo-%s" % order) as (dev, master):
        g = Gateway("rtu-wo-%s" % order, sim, modbus="word_order = %s\n" % order,
                    extra="\n[modbus_rtu l]\ndevice = %s\nbaud = %d\n" % (dev, BAUD))
        try:
            g.start()
            m = RawRtu(master)
            assert m.read(4, 35, 2, 1) == REAL_123456[order]  # slave = unit_id 1
            assert m.read(4, 28, 1, 1) == [["abcd", "cdab", "badc", "dcba"].index(order)]
            m.close()
        finally:
            g.kill()
            sim.kill()


def test_rs485_refusal_reported():
    """A pty has no RS-485 mode: the daemon asks, logs the refusal and
    serves all the same."""
    sim = Drsim("rtu-485").start()
    with pty_pair("rtu-485") as (dev, master):
        g = Gateway("rtu-485", sim, extra="\n[modbus_rtu l]\ndevice = %s\nbaud = 115200\n"
                    "rs485 = yes\nrts_delay_before_ms = 1\n" % dev)
        try:
            g.start()
            g.log_wait("refuses RS-485 mode (TIOCSRS485")
            assert "t3.5 1750 us" in g.log()  # fixed above 19200 baud
            m = RawRtu(master)
            assert m.read(4, 32, 1, 1) == [0x1234]
            m.close()
        finally:
            g.kill()
            sim.kill()


def test_missing_port_is_a_startup_error():
    sim = Drsim("rtu-noport").start()
    g = Gateway("rtu-noport", sim, extra="\n[modbus_rtu l]\ndevice = /dev/nonexistent-tty\n")
    try:
        g.port, g.local_udp = free_port(GW_ADDR, udp=False), [free_port(GW_ADDR, tcp=False)]
        g.write_config()
        proc = spawn([DRGATEWAYD, "-c", g.conf], g.log_path)
        assert proc.wait(timeout(10)) == 1
        assert "modbus_rtu l: cannot open /dev/nonexistent-tty" in g.log()
    finally:
        sim.kill()


def test_reload_moves_a_slave_address_and_keeps_unchanged_lines():
    """SIGHUP: line l2 changes (r0 from 1 to 7) and is opened again; line
    l1 is unchanged and keeps its port (no 'closing' for it)."""
    sim = Drsim("rtu-reload").start()
    with pty_pair("rtu-reload-1") as (dev1, m1), pty_pair("rtu-reload-2") as (dev2, m2):
        # 8N2: a pty refuses a second tcsetattr with even parity (EINVAL),
        # and a changed line is opened again before the old one closes
        line1 = "\n[modbus_rtu l1]\ndevice = %s\nbaud = %d\n" % (dev1, BAUD)
        line2 = "\n[modbus_rtu l2]\ndevice = %s\nbaud = %d\nparity = none\nstop_bits = 2\n" \
                "robots = r0%s\n"
        g = Gateway("rtu-reload", sim, extra=line1 + line2 % (dev2, BAUD, ""))
        try:
            g.start()
            a, b = RawRtu(m1), RawRtu(m2)
            assert b.read(4, 32, 1, 1) == [0x1234]
            g.extra = line1 + line2 % (dev2, BAUD, ":7")
            g.write_config(g.config_text())
            mark = len(g.log())
            g.signal(__import__("signal").SIGHUP)
            g.log_wait("reloaded (generation 1)", start=mark)
            assert "closing %s" % dev2 in g.log()[mark:]
            assert "closing %s" % dev1 not in g.log()[mark:]
            assert b.read(4, 32, 1, 7) == [0x1234]
            b.drain()
            frame = bytes([1, 4, 0, 32, 0, 1])
            b.send(frame + crc16(frame))
            assert b.recv(0.5) == b""  # 1 is no longer on l2
            assert a.read(4, 32, 1, 1) == [0x1234]  # l1 as before
            a.close()
            b.close()
        finally:
            g.kill()
            sim.kill()
