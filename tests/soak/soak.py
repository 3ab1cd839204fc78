# SPDX-License-Identifier: MIT
"""A bounded soak test of drgatewayd (make check-soak, mk/soak.mk,
docs/quality.md).

drsim drops 10 % of the Class 1 packets each way (--drop 10) and closes
every TCP session 5 s after accepting it (--drop-session-after 5);
drgatewayd talks to it over Class 1 (RPI 10 ms by default). Meanwhile:

  * three "confirming" Modbus clients each own six int_in DINTs, six
    float_in REALs and sixteen bit_in coils. They read the status block and
    robot data, and write unique values (FC 16, FC 6 on the scaled REAL
    view, FC 15, FC 5); after every acknowledged write they wait until
    drsim's echo (int_out / float_out / bit_out, read through the gateway)
    shows the value: each acknowledged write must reach drsim;
  * a "burst" client owns the rest and writes in bursts of 20 without
    waiting; the last write of each burst must reach drsim;
  * a "churn" client connects, reads, disconnects, and now and then sends
    a malformed MBAP header, which the gateway answers by closing;
  * halfway through, drsim is stopped for a few seconds and started again
    on the same ports: writes acknowledged while it is away must reach the
    new drsim once the gateway has reconnected (the O->T images are kept
    and sent again).

Afterwards: the last acknowledged value of every register is what drsim
holds (read from drsim directly with drcli, not through the gateway);
both processes are alive and exit 0 on SIGTERM; drgatewayd's descriptor
count and resident memory did not grow between the end of the warm-up and
the end of the run (small tolerance). Any Modbus error or timeout fails
the run. Four "passed failed label" lines go to the results file.

usage: soak.py --build DIR --results FILE --logdir DIR [--seconds 60]
               [--rpi-ms 10] [--mode implicit|explicit] [--no-restart]
"""
import argparse
import json
import logging
import random
import socket
import statistics
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import harness as H  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402

logging.getLogger("pymodbus").setLevel(logging.CRITICAL)

ECHO_TIMEOUT = 30.0   # s: an acknowledged write must show in the echo by then
MODBUS_TIMEOUT = 5.0  # s per request
FD_TOLERANCE = 2      # descriptors (a client connecting at the sampling instant)
RSS_TOLERANCE_KB = 512


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def regs_dint(v):
    return list(struct.unpack(">HH", struct.pack(">i", v)))


def regs_real(v):
    return list(struct.unpack(">HH", struct.pack(">f", v)))


def dint_of(regs):
    return struct.unpack(">i", struct.pack(">HH", *regs))[0]


def real_of(regs):
    return struct.unpack(">f", struct.pack(">HH", *regs))[0]


def int16(v):
    return v - 0x10000 if v & 0x8000 else v


class ModbusFailure(Exception):
    pass


class Shared:
    """State shared by the client threads and the main thread."""

    def __init__(self, port, deadline):
        self.port = port
        self.deadline = deadline
        self.lock = threading.Lock()
        # expected robot values: ("int", i) / ("real", i) / ("bit", i) -> value
        self.last_ack = {}
        self.writes_acked = 0
        self.writes_confirmed = 0
        self.acked_while_away = 0
        self.confirmed_while_away = 0
        self.latencies = []
        self.reads = 0
        self.status_reads = 0
        self.up_not_fresh = 0  # link up but data_fresh 0: reported, not an error
        self.glitches = 0      # link up but data_age_ms 65535: an error
        self.churn = 0
        self.errors = []
        self.robot_away = False   # drsim stopped on purpose
        self.stop = threading.Event()

    def error(self, what):
        with self.lock:
            self.errors.append(what)
        H.log("soak: ERROR: %s" % what)

    def ack(self, values, away):
        """One acknowledged write request that set these registers."""
        with self.lock:
            self.last_ack.update(values)
            self.writes_acked += 1
            if away:
                self.acked_while_away += 1


class Client:
    def __init__(self, sh, name):
        self.sh = sh
        self.name = name
        self.mb = None

    def connect(self):
        self.mb = ModbusTcpClient(H.GW_ADDR, port=self.sh.port, timeout=MODBUS_TIMEOUT,
                                  retries=0)
        if not self.mb.connect():
            raise ModbusFailure("%s: cannot connect" % self.name)

    def close(self):
        if self.mb is not None:
            self.mb.close()

    def call(self, what, fn, *args, **kw):
        try:
            r = fn(*args, slave=1, **kw)
        except Exception as e:  # pymodbus raises on timeouts and closed sockets
            raise ModbusFailure("%s: %s: %s: %s" % (self.name, what, type(e).__name__, e))
        if r.isError():
            raise ModbusFailure("%s: %s: %s" % (self.name, what, r))
        return r

    def read_some(self):
        st = self.call("read status", self.mb.read_input_registers, 0, count=32).registers
        if st[0] != 1:
            raise ModbusFailure("%s: layout_version %d" % (self.name, st[0]))
        # link up (IR 1 = 2) with data_age_ms (IR 3) at its 65535 cap cannot
        # be: the age wrapped around (fixed in gateway/core/link.c)
        with self.sh.lock:
            if st[1] == 2 and st[3] == 65535:
                if not self.sh.glitches:
                    H.log("soak: %s: status block: link up but data_age_ms 65535 "
                          "(data_fresh %d)" % (self.name, st[2]))
                self.sh.glitches += 1
            self.sh.status_reads += 1
            if st[1] == 2 and st[2] == 0:
                self.sh.up_not_fresh += 1
        self.call("read io_state", self.mb.read_input_registers, 100, count=25)
        self.call("read joint_state", self.mb.read_input_registers, 200, count=72)
        with self.sh.lock:
            self.sh.reads += 3

    # the robot's echo, through the gateway
    def echo(self, key):
        kind, i = key
        if kind == "int":
            return dint_of(self.call("read int_out", self.mb.read_input_registers,
                                     500 + 2 * i, count=2).registers)
        if kind == "real":
            return real_of(self.call("read float_out", self.mb.read_input_registers,
                                     600 + 2 * i, count=2).registers)
        return int(self.call("read bit_out", self.mb.read_discrete_inputs,
                             400 + i, count=1).bits[0])

    def wait_echo(self, keys_values, t_ack, away):
        deadline = t_ack + ECHO_TIMEOUT
        pending = dict(keys_values)
        while pending:
            for k in list(pending):
                if self.echo(k) == pending[k]:
                    del pending[k]
            if not pending:
                break
            if not away and self.sh.robot_away:
                # drsim was stopped before this write's echo came: the
                # write is checked against the restarted drsim at the end
                # (last_ack); the writer goes on writing while it is away,
                # which is what the test is for (under load every writer
                # could otherwise sit here through the whole absence)
                return False
            if time.monotonic() > deadline:
                self.sh.error("%s: acknowledged write(s) never reached drsim within %.0f s: %s"
                              % (self.name, ECHO_TIMEOUT, pending))
                return False
            time.sleep(0.005)
        with self.sh.lock:
            self.sh.writes_confirmed += 1
            self.sh.latencies.append(time.monotonic() - t_ack)
            if away:
                self.sh.confirmed_while_away += 1
        return True


def confirming_writer(sh, k, seed):
    """Owns int_in[6k..6k+5], float_in[6k..6k+5], bit_in[16k..16k+15]."""
    c = Client(sh, "writer%d" % k)
    rnd = random.Random(seed)
    n = 0
    try:
        c.connect()
        while not sh.stop.is_set() and time.monotonic() < sh.deadline:
            c.read_some()
            n += 1
            op = rnd.randrange(5)
            away = sh.robot_away
            if op == 0:    # FC 16: one DINT
                i = 6 * k + rnd.randrange(6)
                v = (k + 1) * 10000000 + n
                if n % 2:
                    v = -v
                c.call("write int_in[%d]" % i, c.mb.write_registers, 300 + 2 * i, regs_dint(v))
                want = {("int", i): v}
                sh.ack(want, away)
            elif op == 1:  # FC 16: one REAL
                i = 6 * k + rnd.randrange(6)
                v = f32((k + 1) * 1000000 + n + 0.5)
                c.call("write float_in[%d]" % i, c.mb.write_registers, 400 + 2 * i, regs_real(v))
                want = {("real", i): v}
                sh.ack(want, away)
            elif op == 2:  # FC 6: the scaled INT16 view of a REAL (x100)
                i = 6 * k + rnd.randrange(6)
                raw = rnd.randrange(-30000, 30000)
                c.call("write float_in[%d] scaled" % i, c.mb.write_register, 1400 + i,
                       raw & 0xFFFF)
                # the REAL is raw / 100; its scaled echo (IR 1600 + i) reads raw
                # again, so the robot's value is checked without rounding
                # questions: remember the REAL as drsim reports it, below
                t_ack = time.monotonic()
                deadline = t_ack + ECHO_TIMEOUT
                while int16(c.call("read float_out scaled", c.mb.read_input_registers,
                                   1600 + i, count=1).registers[0]) != raw:
                    if time.monotonic() > deadline:
                        sh.error("%s: scaled write float_in[%d] = %d never reached drsim"
                                 % (c.name, i, raw))
                        break
                    time.sleep(0.005)
                else:
                    sh.ack({("real", i): c.echo(("real", i))}, away)
                    with sh.lock:
                        sh.writes_confirmed += 1
                        sh.latencies.append(time.monotonic() - t_ack)
                        if away:
                            sh.confirmed_while_away += 1
                continue
            elif op == 3:  # FC 15: its sixteen coils
                bits = [rnd.random() < 0.5 for _ in range(16)]
                bits[n % 16] = not sh.last_ack.get(("bit", 16 * k + n % 16), 0)
                c.call("write bit_in[%d..]" % (16 * k), c.mb.write_coils, 200 + 16 * k, bits)
                want = {("bit", 16 * k + j): int(b) for j, b in enumerate(bits)}
                sh.ack(want, away)
            else:          # FC 5: one coil, flipped
                j = 16 * k + rnd.randrange(16)
                b = 1 - sh.last_ack.get(("bit", j), 0)
                c.call("write bit_in[%d]" % j, c.mb.write_coil, 200 + j, bool(b))
                want = {("bit", j): b}
                sh.ack(want, away)
            c.wait_echo(want, time.monotonic(), away)
    except ModbusFailure as e:
        sh.error(str(e))
    finally:
        c.close()


def burst_writer(sh, k, seed):
    """Owns int_in[18..23], float_in[18..23], bit_in[48..63]: bursts of 20
    writes without waiting; the last of each burst must reach drsim."""
    c = Client(sh, "burst")
    rnd = random.Random(seed)
    n = 0
    try:
        c.connect()
        while not sh.stop.is_set() and time.monotonic() < sh.deadline:
            c.read_some()
            want = {}
            away = sh.robot_away
            for _ in range(20):
                n += 1
                ints = [rnd.randrange(-2 ** 31, 2 ** 31) for _ in range(6)]
                reals = [f32(rnd.randrange(-2 ** 22, 2 ** 22) / 8.0) for _ in range(6)]
                bits = [rnd.random() < 0.5 for _ in range(16)]
                regs = []
                for v in ints:
                    regs += regs_dint(v)
                c.call("write int_in[18..23]", c.mb.write_registers, 300 + 36, regs)
                w = {("int", 18 + j): ints[j] for j in range(6)}
                sh.ack(w, away)
                want.update(w)
                regs = []
                for v in reals:
                    regs += regs_real(v)
                c.call("write float_in[18..23]", c.mb.write_registers, 400 + 36, regs)
                w = {("real", 18 + j): reals[j] for j in range(6)}
                sh.ack(w, away)
                want.update(w)
                c.call("write bit_in[48..63]", c.mb.write_coils, 248, bits)
                w = {("bit", 48 + j): int(bits[j]) for j in range(16)}
                sh.ack(w, away)
                want.update(w)
            c.wait_echo(want, time.monotonic(), away)
    except ModbusFailure as e:
        sh.error(str(e))
    finally:
        c.close()


def monitor(sh):
    """Reads the status block as fast as the gateway answers: a PLC that
    watches link_state, data_fresh and data_age_ms."""
    c = Client(sh, "monitor")
    try:
        c.connect()
        while not sh.stop.is_set() and time.monotonic() < sh.deadline:
            st = c.call("read status", c.mb.read_input_registers, 0, count=8).registers
            with sh.lock:
                if st[1] == 2 and st[3] == 65535:
                    if not sh.glitches:
                        H.log("soak: monitor: status block: link up but data_age_ms 65535 "
                              "(data_fresh %d)" % st[2])
                    sh.glitches += 1
                sh.status_reads += 1
                if st[1] == 2 and st[2] == 0:
                    sh.up_not_fresh += 1
    except ModbusFailure as e:
        sh.error(str(e))
    finally:
        c.close()


def churn(sh, seed):
    """Connect, read, disconnect; every tenth time a malformed MBAP
    header (protocol 1), which the gateway must answer by closing."""
    rnd = random.Random(seed)
    n = 0
    while not sh.stop.is_set() and time.monotonic() < sh.deadline:
        n += 1
        try:
            if n % 10 == 0:
                s = socket.create_connection((H.GW_ADDR, sh.port), timeout=MODBUS_TIMEOUT)
                s.sendall(struct.pack(">HHHBBHH", 1, 1, 6, 1, 4, 0, 1))
                s.settimeout(MODBUS_TIMEOUT)
                try:
                    got = s.recv(64)
                except ConnectionResetError:
                    got = b""
                s.close()
                if got:
                    sh.error("churn: a malformed MBAP header was answered: %s" % got.hex())
            else:
                c = Client(sh, "churn")
                c.connect()
                c.call("read status", c.mb.read_input_registers, 0, count=rnd.randrange(1, 33))
                c.close()
            with sh.lock:
                sh.churn += 1
        except (OSError, ModbusFailure) as e:
            sh.error("churn: %s" % e)
        time.sleep(0.05)


def drsim_values(drcli, port):
    """The robot's O->T images, from drsim itself (drcli, not the gateway)."""
    out = subprocess.run([str(drcli), "-H", H.SIM_ADDR, "--port", str(port), "--timeout",
                          "3000", "--json", "dump", "int_in", "float_in", "bit_in"],
                         capture_output=True, text=True, timeout=30)
    if out.returncode != 0:
        raise RuntimeError("drcli dump: exit %d: %s" % (out.returncode, out.stderr.strip()))
    d = json.loads(out.stdout)
    vals = {}
    for i in range(24):
        vals[("int", i)] = d["int_in[%d]" % i]
        vals[("real", i)] = f32(d["float_in[%d]" % i])
    for i in range(64):
        vals[("bit", i)] = int(d["bit_in[%d]" % i])
    return vals


def status_regs(port):
    mb = ModbusTcpClient(H.GW_ADDR, port=port, timeout=MODBUS_TIMEOUT, retries=0)
    try:
        if not mb.connect():
            return None
        r = mb.read_input_registers(0, count=32, slave=1)
        return None if r.isError() else r.registers
    finally:
        mb.close()


def wait_link_up(port, seconds):
    H.wait_for(lambda: (lambda st: st is not None and st[1] == 2 and st[2] == 1)(
        status_regs(port)), seconds, "the gateway's link (IR 1 = 2, IR 2 = 1)", interval=0.1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", required=True, type=Path)
    ap.add_argument("--results", default="")
    ap.add_argument("--logdir", required=True, type=Path)
    ap.add_argument("--seconds", type=float, default=60)
    ap.add_argument("--rpi-ms", type=int, default=10)
    ap.add_argument("--mode", default="implicit", choices=("implicit", "explicit"))
    ap.add_argument("--no-restart", action="store_true")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    a.logdir.mkdir(parents=True, exist_ok=True)
    t_start = time.monotonic()
    label = "soak %.0f s (%s, RPI %d ms, drsim --drop 10 --drop-session-after 5)" % (
        a.seconds, a.mode, a.rpi_ms)
    checks = {}
    try:
        checks = run(a)
    except Exception as e:
        H.log("soak: FAILED: %s: %s" % (type(e).__name__, e))
        checks = {"run": (False, "%s: %s" % (type(e).__name__, e))}
    finally:
        H.kill_all()
    ok = all(v[0] for v in checks.values())
    for name, (passed, detail) in checks.items():
        H.log("soak: %s %s: %s" % ("PASS" if passed else "FAIL", name, detail))
        H.append_result(a.results, 1 if passed else 0, 0 if passed else 1,
                        "%s: %s" % (label, name))
    H.log("soak: %s in %.0f s (logs in %s)" % ("PASS" if ok else "FAIL",
                                              time.monotonic() - t_start, a.logdir))
    return 0 if ok else 1


def run(a):
    sim_args = ["--drop", "10", "--drop-session-after", "5", "--seed", str(a.seed)]
    sim, sim_tcp, sim_udp = H.start_drsim(a.build / "drsim", a.logdir, "soak", sim_args)
    robot = "mode = %s\nrpi_ms = %d\n" % (a.mode, a.rpi_ms)
    gw, port, _ = H.start_gateway(a.build / "drgatewayd", a.logdir, "soak", sim_tcp, sim_udp,
                                  robot_extra=robot)
    H.log("soak: drsim (pid %d) on %s:%d, drgatewayd (pid %d) on %s:%d, %s, RPI %d ms, %.0f s"
          % (sim.pid, H.SIM_ADDR, sim_tcp, gw.pid, H.GW_ADDR, port, a.mode, a.rpi_ms,
             a.seconds))
    wait_link_up(port, 30)
    time.sleep(0.5)
    quiet_before = H.fd_count(gw.pid)

    t0 = time.monotonic()
    sh = Shared(port, t0 + a.seconds)
    threads = [threading.Thread(target=confirming_writer, args=(sh, k, a.seed * 100 + k),
                                name="writer%d" % k) for k in range(3)]
    threads.append(threading.Thread(target=burst_writer, args=(sh, 3, a.seed * 100 + 3),
                                    name="burst"))
    threads.append(threading.Thread(target=churn, args=(sh, a.seed * 100 + 4), name="churn"))
    threads.append(threading.Thread(target=monitor, args=(sh,), name="monitor"))
    for t in threads:
        t.start()

    warm = min(10.0, a.seconds / 6)
    restart_at = a.seconds / 2
    samples = []
    base = None
    restarted = a.no_restart
    sims = [sim]
    # the last sample is taken a second before the clients stop, so both
    # samples see the same clients connected
    while time.monotonic() < sh.deadline - 1.0 and not sh.errors:
        time.sleep(0.5)
        el = time.monotonic() - t0
        if not gw.alive():
            sh.error("drgatewayd died (exit %s)" % gw.p.returncode)
            break
        if not sims[-1].alive():
            sh.error("drsim died (exit %s)" % sims[-1].p.returncode)
            break
        s = (round(el, 1), H.fd_count(gw.pid), H.rss_kb(gw.pid))
        samples.append(s)
        if base is None and el >= warm:
            base = s
            H.log("soak: after warm-up (%.0f s): %d descriptors, VmRSS %d kB" % s)
        if not restarted and el >= restart_at:
            restarted = True
            H.log("soak: stopping drsim for 3 s (writes go on)")
            sh.robot_away = True
            rc = sims[-1].stop(10)
            if rc != 0:
                sh.error("drsim exited %s on SIGTERM" % rc)
            time.sleep(3)
            # The point is writes acknowledged while drsim is away: on a
            # loaded machine the writers may all still wait for the echo of
            # their last write before the stop, so wait (bounded) until one
            # has written again (make check: 0 in 3 s once, beside check-fresh)
            t_away = time.monotonic() + 10
            while sh.acked_while_away == 0 and time.monotonic() < t_away:
                time.sleep(0.05)
            new = None
            for _ in range(50):  # the same ports: they come free at once
                new = H.Proc([a.build / "drsim", "-a", H.SIM_ADDR, "-p", sim_tcp, "-u", sim_udp,
                              "-v"] + sim_args, a.logdir / "soak.drsim2.log")
                H.wait_for(lambda: not new.alive() or "listening on" in new.log(), 10,
                           "drsim to listen again")
                if new.alive():
                    break
                time.sleep(0.2)
            sims.append(new)
            H.log("soak: drsim restarted (pid %d)" % new.pid)
            wait_link_up(port, 30)
            sh.robot_away = False
            H.log("soak: link up again %.1f s after the restart" % (time.monotonic() - t0 - el - 3))
    end = (round(time.monotonic() - t0, 1), H.fd_count(gw.pid), H.rss_kb(gw.pid)) \
        if gw.alive() else None
    sh.stop.set()
    for t in threads:
        t.join(ECHO_TIMEOUT + 2 * MODBUS_TIMEOUT + 10)
        if t.is_alive():
            sh.error("client thread %s did not finish" % t.name)

    # every client has closed: the gateway's descriptors are back where
    # they were before the clients came (its TCP session to drsim may be
    # between a drop and the next connect: one fewer is fine)
    time.sleep(1.0)
    quiet_after = H.fd_count(gw.pid) if gw.alive() else None

    checks = {}
    # ---- no lost writes: drsim holds the last acknowledged value of each register
    lost = {}
    if gw.alive() and sims[-1].alive():
        wait_link_up(port, 30)
        deadline = time.monotonic() + 15
        while True:
            have = drsim_values(a.build / "drcli", sim_tcp)
            lost = {k: (v, have[k]) for k, v in sh.last_ack.items() if have[k] != v}
            if not lost or time.monotonic() > deadline:
                break
            time.sleep(0.2)
    lat = sorted(sh.latencies)
    lat_txt = ("ack to echo p50 %.0f ms, p99 %.0f ms, max %.0f ms" % (
        1000 * statistics.median(lat), 1000 * lat[int(0.99 * (len(lat) - 1))],
        1000 * lat[-1])) if lat else "no latencies"
    detail = ("%d write requests acknowledged, %d echo confirmations (%d requests "
              "acknowledged while drsim was away, %d confirmations of those by the restarted "
              "drsim's echo); %d registers checked "
              "against drsim directly%s; %d reads, %d churn connections; %s; %d Modbus errors"
              % (sh.writes_acked, sh.writes_confirmed, sh.acked_while_away,
                 sh.confirmed_while_away, len(sh.last_ack),
                 ", %d differ: %s" % (len(lost), sorted(lost.items())[:8]) if lost else "",
                 sh.reads, sh.churn, lat_txt, len(sh.errors)))
    wrote_enough = sh.writes_confirmed >= 20 and (a.no_restart or sh.confirmed_while_away > 0)
    checks["no lost writes"] = (not lost and not sh.errors and wrote_enough and
                                len(sh.last_ack) == 24 + 24 + 64,
                                detail + ("" if not sh.errors else "; first errors: %s" %
                                          "; ".join(sh.errors[:5])))

    # ---- the status block: link up never comes with a wrapped-around age
    checks["status block consistent"] = (
        sh.glitches == 0 and sh.status_reads > 0,
        "%d status block reads: %d with link up (IR 1 = 2) and data_age_ms 65535; %d with "
        "link up and data_fresh 0 (a timeout being noticed; not an error)"
        % (sh.status_reads, sh.glitches, sh.up_not_fresh))

    # ---- no crash: both alive now, and both exit 0 on SIGTERM
    alive = gw.alive() and sims[-1].alive()
    gw_rc = gw.stop(15)
    sim_rc = sims[-1].stop(15)
    gwlog = gw.log()
    checks["no crash"] = (alive and gw_rc == 0 and sim_rc == 0,
                          "both alive at the end, exit %s (drgatewayd) and %s (drsim) on "
                          "SIGTERM; gateway log: %d 'link down', %d 'link up'"
                          % (gw_rc, sim_rc, gwlog.count("link down"), gwlog.count("link up")))

    # ---- no fd or memory growth of drgatewayd
    if base is None or end is None:
        checks["no fd growth"] = (False, "no samples (warm-up not reached)")
        checks["no memory growth"] = (False, "no samples (warm-up not reached)")
    else:
        fds = [s[1] for s in samples if s[0] >= base[0]]
        rss = [s[2] for s in samples if s[0] >= base[0]]
        checks["no fd growth"] = (
            end[1] <= base[1] + FD_TOLERANCE and quiet_after is not None and
            quiet_after <= quiet_before,
            "drgatewayd descriptors under load: %d after warm-up (%.0f s), %d at the end "
            "(%.0f s), range %d..%d; without clients: %d before, %s after"
            % (base[1], base[0], end[1], end[0], min(fds), max(fds), quiet_before,
               quiet_after))
        rss_tol = max(RSS_TOLERANCE_KB, base[2] // 20)
        checks["no memory growth"] = (
            end[2] <= base[2] + rss_tol,
            "drgatewayd VmRSS %d kB after warm-up, %d kB at the end (tolerance %d kB), "
            "range %d..%d kB" % (base[2], end[2], rss_tol, min(rss), max(rss)))
    return checks


if __name__ == "__main__":
    sys.exit(main())
