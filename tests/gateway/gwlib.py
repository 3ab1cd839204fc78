# SPDX-License-Identifier: MIT
"""Helpers for the drgatewayd end-to-end tests: processes (drsim and
drgatewayd on free loopback ports), an independent Modbus TCP framer, an
independent EtherNet/IP reader, the register map from `--print-map --json`,
and the robot's assemblies written down again from the vendor tables
(docs/assemblies.md), not taken from the codec under test.

Everything that waits polls for a condition with a generous deadline
(scaled by GW_TIMEOUT_SCALE); nothing relies on a fixed sleep being
"long enough".
"""
import contextlib
import ctypes
import ctypes.util
import json
import math
import os
import shutil
import random
import signal
import socket
import struct
import subprocess
import threading
import time
from pathlib import Path

import pytest

TOP = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("GW_BUILD", TOP / "build"))
DRGATEWAYD = Path(os.environ.get("DRGATEWAYD", BUILD / "drgatewayd"))
DRSIM = Path(os.environ.get("DRSIM", BUILD / "drsim"))
# The tests' independent reader of the robot (drcli get/list), from the same
# build as the daemon (make check-gateway and check-gateway-asan build it).
DRCLI = Path(os.environ.get("DRCLI", BUILD / "drcli"))
# Under pytest-xdist (make check runs the suite with two workers, `-n 2`)
# each worker keeps its files in a folder of its own (gw0, gw1, ...), since
# tests name their configurations and logs after themselves, and takes
# ports of its own (see free_port).
LOGROOT = Path(os.environ.get("GW_LOGDIR", BUILD / "tests" / "gateway"))
WORKER = os.environ.get("PYTEST_XDIST_WORKER", "")
WORKERS = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
LOGDIR = LOGROOT / WORKER if WORKER else LOGROOT
SCALE = float(os.environ.get("GW_TIMEOUT_SCALE", "1"))

SIM_ADDR = "127.0.0.2"   # drsim
GW_ADDR = "127.0.0.1"    # drgatewayd: Modbus and its Class 1 socket

ORDERS = ("abcd", "cdab", "badc", "dcba")
ORDER_INDEX = {o: i for i, o in enumerate(ORDERS)}

# The worked example of the docs, by hand: REAL 123456.0 = 0x47F12000.
REAL_123456 = {
    "abcd": [0x47F1, 0x2000],
    "cdab": [0x2000, 0x47F1],
    "badc": [0xF147, 0x0020],
    "dcba": [0x0020, 0xF147],
}

EX_ILLEGAL_FUNCTION = 0x01
EX_ILLEGAL_ADDRESS = 0x02
EX_ILLEGAL_VALUE = 0x03
EX_DEVICE_FAILURE = 0x04
EX_PATH_UNAVAILABLE = 0x0A
EX_TARGET_FAILED = 0x0B

# drgatewayd exit codes
EXIT_OK, EXIT_RUNTIME, EXIT_USAGE, EXIT_CONFIG = 0, 1, 2, 78


def timeout(seconds):
    return seconds * SCALE


def wait_for(cond, seconds=10.0, what="a condition", interval=0.02):
    """Polls cond() until it returns something true; returns that value.
    Fails the test after `seconds` (scaled)."""
    deadline = time.monotonic() + timeout(seconds)
    last_exc = None
    while True:
        try:
            v = cond()
            if v:
                return v
        except (OSError, ModbusError) as e:  # a peer still starting
            last_exc = e
        if time.monotonic() > deadline:
            raise AssertionError("timed out after %.1f s waiting for %s%s" % (
                timeout(seconds), what, " (last error: %s)" % last_exc if last_exc else ""))
        time.sleep(interval)


# ---- word orders, by hand ---------------------------------------------------

def words_of(be4, order):
    """Four big-endian bytes A B C D as two registers in `order`."""
    a, b, c, d = be4
    return {
        "abcd": [a << 8 | b, c << 8 | d],
        "cdab": [c << 8 | d, a << 8 | b],
        "badc": [b << 8 | a, d << 8 | c],
        "dcba": [d << 8 | c, b << 8 | a],
    }[order]


def bytes_of(regs, order):
    """Two registers in `order` back to the big-endian bytes A B C D."""
    r0, r1 = regs
    x0, y0, x1, y1 = r0 >> 8, r0 & 0xFF, r1 >> 8, r1 & 0xFF
    return bytes({
        "abcd": (x0, y0, x1, y1),
        "cdab": (x1, y1, x0, y0),
        "badc": (y0, x0, y1, x1),
        "dcba": (y1, x1, y0, x0),
    }[order])


def real_regs(f, order):
    return words_of(struct.pack(">f", f), order)


def dint_regs(i, order):
    return words_of(struct.pack(">i", i), order)


def regs_real(regs, order):
    return struct.unpack(">f", bytes_of(regs, order))[0]


def regs_dint(regs, order):
    return struct.unpack(">i", bytes_of(regs, order))[0]


def crc16(data):
    """Modbus RTU CRC-16 (polynomial 0xA001, initial 0xFFFF), as the two
    bytes that end a frame, low byte first."""
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return struct.pack("<H", crc)


def f32(x):
    """x rounded to binary32, as the robot stores it."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def int16(u):
    return u - 0x10000 if u & 0x8000 else u


# ---- free ports ---------------------------------------------------------------

_taken = set()


def _port_range():
    """Below the kernel's ephemeral range: a port from that range can be
    taken at any moment by any socket that sends without binding first
    (bound to 0.0.0.0, it blocks 127.0.0.2 too), and drsim restarted on
    its old ports must find them free."""
    try:
        lo, hi = (int(x) for x in Path("/proc/sys/net/ipv4/ip_local_port_range")
                  .read_text().split())
    except (OSError, ValueError):
        lo, hi = 32768, 60999
    if lo - 1 - 10000 >= 2000:
        return 10000, lo - 1
    return hi + 1, 65535


def _worker_index():
    """This process's share of the port range: worker gwN of a pytest-xdist
    run takes the ports p with p % WORKERS == N, so two workers never pick
    the same port (a process of the machine may still take one: see below)."""
    if WORKER.startswith("gw") and WORKER[2:].isdigit() and WORKERS > 1:
        return int(WORKER[2:]) % WORKERS
    return None


def free_port(addr, tcp=True, udp=True):
    """A port that is free on addr now (TCP and/or UDP). Others may take it
    before we bind it: callers that start a process retry with new ports."""
    rnd = random.SystemRandom()
    first, last = _port_range()
    share = _worker_index()
    for _ in range(500):
        p = rnd.randint(first, last)
        if share is not None:
            p -= (p - share) % WORKERS
            if p < first:
                continue
        if p in _taken:
            continue
        ok = True
        for kind, want in ((socket.SOCK_STREAM, tcp), (socket.SOCK_DGRAM, udp)):
            if not want:
                continue
            s = socket.socket(socket.AF_INET, kind)
            try:
                s.bind((addr, p))
            except OSError:
                ok = False
            finally:
                s.close()
        if ok:
            _taken.add(p)
            return p
    raise RuntimeError("no free port on %s" % addr)


# ---- processes ------------------------------------------------------------------

def _die_with_parent():
    # PR_SET_PDEATHSIG: a child must not outlive an aborted test run.
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL, 0, 0, 0)
    except OSError:
        pass


_procs = []


def spawn(argv, log_path, env=None):
    LOGDIR.mkdir(parents=True, exist_ok=True)
    log = open(log_path, "ab")
    p = subprocess.Popen([str(a) for a in argv], stdin=subprocess.DEVNULL, stdout=log,
                         stderr=subprocess.STDOUT, preexec_fn=_die_with_parent, env=env)
    log.close()
    _procs.append(p)
    return p


def kill_all():
    for p in _procs:
        if p.poll() is None:
            p.kill()
            p.wait()


def read_text(path):
    try:
        return Path(path).read_text(errors="replace")
    except FileNotFoundError:
        return ""


class Drsim:
    """drsim on 127.0.0.2 with its own ports, logging with -v."""

    def __init__(self, name, *extra):
        self.name = name
        self.extra = list(extra)
        self.log_path = LOGDIR / ("%s.drsim.log" % name)
        self.proc = None
        self.tcp = self.udp = None
        if self.log_path.exists():
            self.log_path.unlink()

    def start(self, same_ports=False):
        for _ in range(50 if same_ports else 20):
            if not same_ports or self.tcp is None:
                self.tcp = free_port(SIM_ADDR)
                self.udp = free_port(SIM_ADDR, tcp=False)
            mark = len(self.log())
            self.proc = spawn([DRSIM, "-a", SIM_ADDR, "-p", self.tcp, "-u", self.udp, "-v"]
                              + self.extra, self.log_path)
            ok = wait_for(lambda: self.proc.poll() is not None or
                          "listening on" in self.log()[mark:],
                          10, "drsim to listen")
            if self.proc.poll() is None:
                return self
            # a port was taken in the meantime: the same ports may come
            # free a moment later; new ones are simply tried
            time.sleep(0.2)
        raise RuntimeError("drsim did not start: %s" % self.log()[-2000:])

    def log(self):
        return read_text(self.log_path)

    def kill(self):
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    def stop(self):
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout(10))
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


class Gateway:
    """drgatewayd with a config written here: Modbus on 127.0.0.1 (a free
    port), one robot (drsim) or several."""

    def __init__(self, name, sims, modbus="", robot="", extra="", unit_ids=None):
        self.name = name
        self.sims = sims if isinstance(sims, (list, tuple)) else [sims]
        self.modbus_extra = modbus
        self.robot_extra = robot
        self.extra = extra
        self.unit_ids = unit_ids or list(range(1, len(self.sims) + 1))
        self.port = None
        self.local_udp = [None] * len(self.sims)
        self.conf = LOGDIR / ("%s.ini" % name)
        self.log_path = LOGDIR / ("%s.gateway.log" % name)
        self.proc = None
        if self.log_path.exists():
            self.log_path.unlink()
        # the daemon's state (Sparkplug's bdSeq file), as systemd's
        # StateDirectory gives it: one per test, empty at its start
        self.state_dir = LOGDIR / ("%s.state" % name)
        shutil.rmtree(self.state_dir, ignore_errors=True)

    def config_text(self, modbus=None, robot=None, extra=None, port=None, listen=None):
        modbus = self.modbus_extra if modbus is None else modbus
        robot = self.robot_extra if robot is None else robot
        extra = self.extra if extra is None else extra
        text = ("; written by tests/gateway\n[modbus]\nlisten = %s\nport = %d\n%s\n"
                % (listen or GW_ADDR, port or self.port, modbus))
        if "timeout_multiplier" not in robot:
            # x64: 640 ms at RPI 10 ms, so that a loaded test machine does
            # not time connections out (tests of timeouts set their own)
            robot = "timeout_multiplier = 4\n" + robot
        for i, sim in enumerate(self.sims):
            text += ("\n[robot r%d]\nhost = %s\ntcp_port = %d\nudp_port = %d\n"
                     "local_address = %s\nlocal_udp_port = %d\nunit_id = %d\n%s\n"
                     % (i, SIM_ADDR, sim.tcp, sim.udp, GW_ADDR, self.local_udp[i],
                        self.unit_ids[i], robot))
        return text + extra

    def write_config(self, text=None):
        LOGDIR.mkdir(parents=True, exist_ok=True)
        self.conf.write_text(self.config_text() if text is None else text)

    def start(self, wait_link=True, args=(), env=None):
        for _ in range(20):
            self.port = free_port(GW_ADDR, udp=False)
            self.local_udp = [free_port(GW_ADDR, tcp=False) for _ in self.sims]
            self.write_config()
            mark = len(self.log())
            self.state_dir.mkdir(parents=True, exist_ok=True)
            run_env = dict(os.environ if env is None else env)
            run_env.setdefault("STATE_DIRECTORY", str(self.state_dir))
            self.proc = spawn([DRGATEWAYD, "-c", self.conf] + list(args), self.log_path,
                              run_env)
            wait_for(lambda: self.proc.poll() is not None or self.listening(), 10,
                     "drgatewayd to start")
            if self.proc.poll() is None:
                break
            if "cannot listen" not in self.log()[mark:] and \
               "cannot create" not in self.log()[mark:]:
                raise RuntimeError("drgatewayd exited: %s" % self.log()[mark:])
        else:
            raise RuntimeError("drgatewayd did not start: %s" % self.log()[-2000:])
        if wait_link:
            for u in self.unit_ids:
                self.wait_link(True, unit=u)
        return self

    def log(self):
        return read_text(self.log_path)

    def listening(self, port=None):
        try:
            socket.create_connection((GW_ADDR, port or self.port), timeout=timeout(2)).close()
            return True
        except OSError:
            return False

    def alive(self):
        return self.proc is not None and self.proc.poll() is None

    def signal(self, sig):
        self.proc.send_signal(sig)

    def stop(self, seconds=10):
        """SIGTERM; returns (exit status, seconds it took)."""
        t0 = time.monotonic()
        self.proc.terminate()
        try:
            rc = self.proc.wait(timeout(seconds))
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            return None, time.monotonic() - t0
        return rc, time.monotonic() - t0

    def kill(self):
        if self.alive():
            # make coverage (mk/coverage.mk): a daemon built with --coverage
            # writes its counts only when it exits, so it gets SIGTERM first
            if os.environ.get("GW_COVERAGE"):
                self.proc.terminate()
                try:
                    self.proc.wait(timeout(10))
                    return
                except subprocess.TimeoutExpired:
                    pass
            self.proc.kill()
            self.proc.wait()

    def raw(self, **kw):
        return RawModbus(GW_ADDR, self.port, **kw)

    def pymodbus(self):
        from pymodbus.client import ModbusTcpClient
        c = ModbusTcpClient(GW_ADDR, port=self.port, timeout=timeout(5), retries=0)
        assert c.connect(), "pymodbus cannot connect to port %d" % self.port
        return c

    def status(self, unit=1):
        with self.raw() as m:
            return m.read(4, 0, 44, unit=unit)  # status, test registers, status

    def wait_link(self, up, unit=1, seconds=20):
        def check():
            st = self.status(unit)
            return (st[1] == 2 and st[2] == 1) if up else (st[1] != 2 and st[2] == 0)
        return wait_for(check, seconds, "link %s (unit %d)" % ("up" if up else "down", unit))

    def log_wait(self, text, seconds=10, start=0):
        return wait_for(lambda: text in self.log()[start:], seconds,
                        "'%s' in the gateway's log" % text)


# ---- an independent Modbus TCP framer --------------------------------------------

class ModbusError(Exception):
    def __init__(self, fc, code):
        super().__init__("exception 0x%02X to function 0x%02X" % (code, fc))
        self.fc = fc
        self.code = code


class RawModbus:
    """Modbus TCP frames built and parsed here with struct: for exact
    requests (bad quantities, odd function codes, malformed headers)."""

    def __init__(self, host, port, connect_timeout=5.0, source=None):
        self.sock = socket.create_connection((host, port), timeout=timeout(connect_timeout),
                                             source_address=(source, 0) if source else None)
        self.sock.settimeout(timeout(10))
        self.tid = random.randint(0, 0xFFFF)
        self.lock = threading.Lock()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        self.sock.close()

    def send_adu(self, pdu, unit=1, proto=0, length=None):
        self.tid = (self.tid + 1) & 0xFFFF
        ln = len(pdu) + 1 if length is None else length
        self.sock.sendall(struct.pack(">HHHB", self.tid, proto, ln, unit) + pdu)
        return self.tid

    def recv_exact(self, n):
        buf = b""
        while len(buf) < n:
            got = self.sock.recv(n - len(buf))
            if not got:
                raise ConnectionError("closed by the gateway")
            buf += got
        return buf

    def recv_adu(self):
        hdr = self.recv_exact(7)
        tid, proto, ln, unit = struct.unpack(">HHHB", hdr)
        pdu = self.recv_exact(ln - 1)
        return tid, proto, unit, pdu

    def request(self, pdu, unit=1):
        """Sends one request; returns the response PDU or raises ModbusError.
        One request at a time per connection, whatever the threads."""
        with self.lock:
            tid = self.send_adu(pdu, unit)
            rtid, proto, runit, rpdu = self.recv_adu()
        assert (rtid, proto, runit) == (tid, 0, unit), "MBAP of the reply: %r" % (((rtid, proto, runit, rpdu.hex()), (tid, 0, unit)),)
        if rpdu[0] & 0x80:
            assert rpdu[0] == pdu[0] | 0x80 and len(rpdu) == 2, rpdu.hex()
            raise ModbusError(pdu[0], rpdu[1])
        assert rpdu[0] == pdu[0], rpdu.hex()
        return rpdu

    def exception(self, pdu, unit=1):
        """The exception code a request gets (None if it succeeded)."""
        try:
            self.request(pdu, unit)
        except ModbusError as e:
            return e.code
        return None

    def read(self, fc, addr, count, unit=1):
        rpdu = self.request(struct.pack(">BHH", fc, addr, count), unit)
        n = rpdu[1]
        data = rpdu[2:]
        assert len(data) == n
        if fc in (1, 2):
            assert n == (count + 7) // 8
            return [(data[i // 8] >> (i % 8)) & 1 for i in range(count)]
        assert n == 2 * count
        return list(struct.unpack(">%dH" % count, data))

    def write_regs(self, addr, values, unit=1):
        pdu = struct.pack(">BHHB", 0x10, addr, len(values), 2 * len(values)) + \
            struct.pack(">%dH" % len(values), *values)
        r = self.request(pdu, unit)
        assert struct.unpack(">HH", r[1:5]) == (addr, len(values))

    def write_reg(self, addr, value, unit=1):
        r = self.request(struct.pack(">BHH", 0x06, addr, value), unit)
        assert struct.unpack(">HH", r[1:5]) == (addr, value)

    def write_coils(self, addr, bits, unit=1):
        data = bytearray((len(bits) + 7) // 8)
        for i, b in enumerate(bits):
            if b:
                data[i // 8] |= 1 << (i % 8)
        pdu = struct.pack(">BHHB", 0x0F, addr, len(bits), len(data)) + bytes(data)
        r = self.request(pdu, unit)
        assert struct.unpack(">HH", r[1:5]) == (addr, len(bits))

    def write_coil(self, addr, on, unit=1):
        self.request(struct.pack(">BHH", 0x05, addr, 0xFF00 if on else 0), unit)


def closed_by_peer(sock, seconds=10):
    """True once the peer has closed (EOF or reset), False if it stayed open
    for `seconds` (scaled). Data the peer sends first is skipped."""
    deadline = time.monotonic() + timeout(seconds)
    while time.monotonic() < deadline:
        sock.settimeout(max(0.01, deadline - time.monotonic()))
        try:
            if sock.recv(512) == b"":
                return True
        except socket.timeout:
            return False
        except (ConnectionResetError, BrokenPipeError):
            return True
    return False


# ---- an independent EtherNet/IP explicit reader --------------------------------

def drcli_identity(sim):
    """drcli identity --json against drsim itself: its Identity object
    ({"vendor", "device_type", "product_code", "revision", "status",
    "serial", "product_name"})."""
    out = subprocess.run([str(DRCLI), "-H", SIM_ADDR, "--port", str(sim.tcp), "identity",
                          "--json"], capture_output=True, text=True, timeout=timeout(30),
                         check=True).stdout
    return json.loads(out)["identity"]


class EnipReader:
    """RegisterSession + SendRRData Get_Attribute_Single(class 4, instance,
    attribute 3): the robot's own view of an assembly, read beside the
    gateway (drsim serves several TCP sessions)."""

    def __init__(self, host, port):
        self.sock = socket.create_connection((host, port), timeout=timeout(5))
        self.session = 0
        rep = self._encap(0x65, struct.pack("<HH", 1, 0))
        self.session = struct.unpack_from("<I", rep, 4)[0]

    def close(self):
        try:
            self._send(0x66, b"")
        except OSError:
            pass
        self.sock.close()

    def _send(self, cmd, data):
        self.sock.sendall(struct.pack("<HHII8sI", cmd, len(data), self.session, 0,
                                      b"drgatetst", 0) + data)

    def _encap(self, cmd, data):
        self._send(cmd, data)
        hdr = b""
        while len(hdr) < 24:
            got = self.sock.recv(24 - len(hdr))
            if not got:
                raise ConnectionError("drsim closed the session")
            hdr += got
        rcmd, ln, session, status = struct.unpack_from("<HHII", hdr)
        body = b""
        while len(body) < ln:
            got = self.sock.recv(ln - len(body))
            if not got:
                raise ConnectionError("drsim closed the session")
            body += got
        assert rcmd == cmd and status == 0, (rcmd, status)
        return hdr + body

    def get(self, instance):
        path = bytes([0x20, 0x04, 0x24, instance, 0x30, 0x03]) if instance < 256 else \
            bytes([0x20, 0x04, 0x25, 0x00]) + struct.pack("<H", instance) + bytes([0x30, 0x03])
        cip = bytes([0x0E, len(path) // 2]) + path
        data = struct.pack("<IHHHHHH", 0, 0, 2, 0, 0, 0xB2, len(cip)) + cip
        rep = self._encap(0x6F, data)[24:]
        items = struct.unpack_from("<H", rep, 6)[0]
        assert items == 2
        ln = struct.unpack_from("<H", rep, 14)[0]
        cip_rep = rep[16:16 + ln]
        assert cip_rep[0] == 0x8E and cip_rep[2] == 0, cip_rep[:4].hex()
        return cip_rep[4 + 2 * cip_rep[3]:]


# ---- the register map -------------------------------------------------------------

@contextlib.contextmanager
def running(name, sim_args=(), start=True, **gw_kw):
    """drsim NAME (with sim_args) and a Gateway NAME in front of it (gw_kw
    as for Gateway), started unless start is False; g.sim is the drsim.
    Both are killed on the way out, whatever happened."""
    sim = Drsim(name, *sim_args).start()
    g = Gateway(name, sim, **gw_kw)
    g.sim = sim
    try:
        if start:
            g.start()
        yield g
    finally:
        g.kill()
        sim.kill()


class RegMap:
    """`drgatewayd --print-map --json`: addresses looked up by name."""

    def __init__(self):
        out = subprocess.run([str(DRGATEWAYD), "--print-map", "--json"], check=True,
                             capture_output=True, timeout=timeout(30)).stdout
        self.entries = json.loads(out)
        self.by = {}
        for e in self.entries:
            scaled = e["type"].startswith("INT16 = REAL")
            key = (e["area"], e["name"], scaled)
            assert key not in self.by, "name twice in one area: %s" % (key,)
            self.by[key] = e

    def entry(self, area, name, scaled=False):
        return self.by[(area, name, scaled)]

    def addr(self, area, name, scaled=False):
        return self.entry(area, name, scaled)["address"]

    def area(self, area):
        return [e for e in self.entries if e["area"] == area]

    def span(self, area, names, scaled=False):
        """(first address, count) of consecutive entries; asserts they are."""
        es = [self.entry(area, n, scaled) for n in names]
        for a, b in zip(es, es[1:]):
            assert b["address"] == a["address"] + a["count"], (a, b)
        return es[0]["address"], es[-1]["address"] + es[-1]["count"] - es[0]["address"]

    def scale(self, area, name):
        t = self.entry(area, name, True)["type"]
        return int(t.rsplit("x", 1)[1])


# ---- the assemblies, written down from the vendor tables ------------------------

INSTANCE = {"io_state": 101, "joint_state": 102, "task_state": 103, "bit_out": 104,
            "int_out": 105, "float_out": 106, "io_control": 107, "bit_in": 108,
            "int_in": 109, "float_in": 110}

_J = ["position", "velocity", "motor_current", "motor_temperature", "torque",
      "external_torque"]
JOINT_REALS = ["joint_state.%s[%d]" % (g, j) for g in _J for j in range(1, 7)]
TASK_REALS = ["task_state.%s.%s" % (g, a) for g, axes in (
    ("position", "xyz"), ("orientation", "abc"), ("velocity", "xyz"),
    ("angular_velocity", ("rx", "ry", "rz")), ("tool_offset", "xyzabc"),
    ("external_force", "xyz"), ("external_moment", "xyz")) for a in axes]
FLOAT_OUT = ["float_out[%d]" % i for i in range(24)]
INT_OUT = ["int_out[%d]" % i for i in range(24)]


def decode_t2o(imgs):
    """The robot's T->O images (instance -> bytes) as name -> value: REALs as
    floats, DINTs and USINTs as ints, masks as ints, bits as 0/1."""
    v = {}
    io = imgs[101]
    w0, w24, w32 = (struct.unpack_from("<I", io, o)[0] for o in (0, 24, 32))
    v["io_state.cb_di"] = w0 & 0xFFFF
    v["io_state.cb_do"] = w0 >> 16
    for i in range(16):
        v["io_state.cb_di[%d]" % (i + 1)] = (w0 >> i) & 1
        v["io_state.cb_do[%d]" % (i + 1)] = (w0 >> (16 + i)) & 1
    for i, n in enumerate(("ai0", "ai1", "ao0", "ao1")):
        v["io_state.aio_type.%s" % n] = (io[4] >> i) & 1
    for i in range(2):
        v["io_state.ai[%d]" % i] = struct.unpack_from("<f", io, 8 + 4 * i)[0]
        v["io_state.ao[%d]" % i] = struct.unpack_from("<f", io, 16 + 4 * i)[0]
    v["io_state.tool_di"] = w24 & 0x3F
    v["io_state.tool_do"] = (w24 >> 16) & 0x3F
    for i in range(6):
        v["io_state.tool_di[%d]" % (i + 1)] = (w24 >> i) & 1
        v["io_state.tool_do[%d]" % (i + 1)] = (w24 >> (16 + i)) & 1
    v["io_state.version.major"], v["io_state.version.minor"], v["io_state.version.patch"] = \
        io[28], io[29], io[30]
    v["io_state.robot_state"] = io[32]
    for i, n in enumerate(("servo_on", "safety_stopped", "emergency_stopped",
                           "direct_teach_pressed", "power_button_pressed")):
        v["io_state.%s" % n] = (w32 >> (16 + i)) & 1
    for i, n in enumerate(JOINT_REALS):
        v[n] = struct.unpack_from("<f", imgs[102], 4 * i)[0]
    for i, n in enumerate(TASK_REALS):
        v[n] = struct.unpack_from("<f", imgs[103], 4 * i)[0]
    bits = struct.unpack_from("<Q", imgs[104], 0)[0]
    v["bit_out"] = bits
    for i in range(64):
        v["bit_out[%d]" % i] = (bits >> i) & 1
    for i in range(24):
        v["int_out[%d]" % i] = struct.unpack_from("<i", imgs[105], 4 * i)[0]
        v["float_out[%d]" % i] = struct.unpack_from("<f", imgs[106], 4 * i)[0]
    return v


# Noise drsim adds (sim/robot.c): a value may differ from both samples
# around it by up to twice this.
NOISE = {"motor_current": 0.02, "external_torque": 0.3, "external_force": 1.0,
         "external_moment": 0.1, "io_state.ai[0]": 0.002}


def noise_of(name):
    for k, amp in NOISE.items():
        if k in name:
            return amp
    return 0.0


def between(x, a, b, tol):
    if any(math.isnan(t) for t in (x, a, b)):
        return math.isnan(x) and (math.isnan(a) or math.isnan(b))
    return min(a, b) - tol <= x <= max(a, b) + tol


# ---- libmodbus's own client, through ctypes ---------------------------------


def libmodbus():
    """libmodbus (a build dependency) with the prototypes of the client calls
    the tests use: a C client of the ecosystem most PLC tools build on."""
    name = ctypes.util.find_library("modbus")
    if name is None:
        raise RuntimeError("libmodbus not found (libmodbus-dev is a build dependency)")
    lib = ctypes.CDLL(name, use_errno=True)
    lib.modbus_new_tcp.restype = ctypes.c_void_p
    lib.modbus_new_tcp.argtypes = [ctypes.c_char_p, ctypes.c_int]
    for f in ("modbus_connect", "modbus_close", "modbus_free"):
        getattr(lib, f).argtypes = [ctypes.c_void_p]
    lib.modbus_set_slave.argtypes = [ctypes.c_void_p, ctypes.c_int]
    lib.modbus_set_response_timeout.argtypes = [ctypes.c_void_p, ctypes.c_uint32, ctypes.c_uint32]
    u16p = ctypes.POINTER(ctypes.c_uint16)
    lib.modbus_read_registers.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, u16p]
    lib.modbus_write_register.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_uint16]
    lib.modbus_write_and_read_registers.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int,
                                                    u16p, ctypes.c_int, ctypes.c_int, u16p]
    lib.modbus_strerror.restype = ctypes.c_char_p
    lib.modbus_strerror.argtypes = [ctypes.c_int]
    return lib


# ---- network namespaces -------------------------------------------------------

CLONE_NEWNET = 0x40000000
_libc = ctypes.CDLL(None, use_errno=True)


@contextlib.contextmanager
def in_netns(path):
    """This thread in the network namespace at path (/proc/PID/ns/net or
    /run/netns/NAME), and back in its own afterwards: sockets made
    meanwhile stay in that namespace whoever uses them."""
    mine = os.open("/proc/thread-self/ns/net", os.O_RDONLY)
    theirs = os.open(path, os.O_RDONLY)
    try:
        if _libc.setns(theirs, CLONE_NEWNET) != 0:
            raise OSError(ctypes.get_errno(), "setns %s" % path)
        try:
            yield
        finally:
            if _libc.setns(mine, CLONE_NEWNET) != 0:
                raise OSError(ctypes.get_errno(), "setns back")
    finally:
        os.close(mine)
        os.close(theirs)


def status_read_latencies(m, seconds):
    """Seconds per Modbus read of the status block (IR 0-30) on the open
    RawModbus m, one every 2 ms for `seconds`, sorted: how long a PLC's
    poll waits while something else loads the daemon."""
    lat = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        t0 = time.perf_counter()
        m.read(4, 0, 31)
        lat.append(time.perf_counter() - t0)
        time.sleep(0.002)
    return sorted(lat)


def yescrypt(password, cost=0):
    """A yescrypt hash of password by libcrypt itself (Python 3.13 has no
    crypt module): cost 0 is libcrypt's default ($y$j9T$, 16 MiB, as
    `mkpasswd -m yescrypt` makes it), 7 the hash policy's most memory
    (64 MiB, core/passwd.h: some 80 ms a check here)."""
    lc = ctypes.CDLL("libcrypt.so.1")
    lc.crypt_gensalt.restype = ctypes.c_char_p
    lc.crypt_gensalt.argtypes = [ctypes.c_char_p, ctypes.c_ulong, ctypes.c_char_p, ctypes.c_int]
    lc.crypt.restype = ctypes.c_char_p
    lc.crypt.argtypes = [ctypes.c_char_p, ctypes.c_char_p]
    return lc.crypt(password.encode(), lc.crypt_gensalt(b"$y$", cost, None, 0)).decode()


class NetnsCell:
    """A network namespace of its own, held by a sleeping process, with
    loopback up and `addresses` (/32 each) on it: no route out, so nothing
    sent in it leaves the machine. spawn() runs a program in it, sock() a
    TCP connection from it; close() ends them and the namespace."""

    def __init__(self, addresses):
        self.addresses = list(addresses)
        self.holder = subprocess.Popen(
            ["unshare", "-n", "sh", "-c", " && ".join(
                ["ip link set lo up"] + ["ip addr add %s/32 dev lo" % a for a in self.addresses]
                + ["exec sleep 100000"])])
        self.ns = "/proc/%d/ns/net" % self.holder.pid
        self.procs = []
        wait_for(self.addresses_up, 10, "the namespace's addresses")

    @staticmethod
    def possible():
        return subprocess.run(["unshare", "-n", "true"], capture_output=True).returncode == 0

    def addresses_up(self):
        out = subprocess.run(["nsenter", "--net=" + self.ns, "ip", "-o", "addr"],
                             capture_output=True, text=True).stdout
        return all(a + "/32" in out for a in self.addresses)

    def spawn(self, argv, log):
        if log.exists():
            log.unlink()
        p = spawn(["nsenter", "--net=" + self.ns] + [str(a) for a in argv], log)
        self.procs.append(p)
        return p

    def stop(self, p):
        p.kill()
        p.wait()
        self.procs.remove(p)

    def sock(self, addr, port, src=None):
        with in_netns(self.ns):
            s = socket.socket()
            s.settimeout(timeout(10))
            if src:
                s.bind((src, 0))
            s.connect((addr, port))
        return s

    def close(self):
        for p in self.procs:
            p.kill()
            p.wait()
        self.holder.kill()
        self.holder.wait()


def skip(name, reason):
    """The SKIPPED banner of tests/skip.sh for a test this machine cannot
    run; under CI (CI set) a failure, since CI machines run every check."""
    banner = "#" * 67
    print("\n%s\n### %s SKIPPED: %s\n%s" % (banner, name, reason, banner))
    if os.environ.get("CI"):
        pytest.fail("skipped in CI: %s" % reason)
    pytest.skip(reason)


def thread_of(pid, name):
    """The id of process pid's thread called name (its comm), or None."""
    for t in Path("/proc/%d/task" % pid).iterdir():
        try:
            if (t / "comm").read_text().strip() == name:
                return int(t.name)
        except OSError:  # (a thread that ended meanwhile)
            pass
    return None
