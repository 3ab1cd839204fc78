#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Robots per core (issue 15), run by `make bench-scale`.

drgatewayd against N simulated robots, N = 1, 2, 4, 8, 16, 32, at RPI
10 ms and 2 ms, everything on loopback:

- one drsim per robot, each on its own address 127.0.15.(N+1) with its own
  encapsulation and Class 1 ports; all of them start once and wait idle
  (no connection, no packets) while they are not used;
- for every point a fresh daemon with N [robot] sections (unit IDs 1..N,
  six Class 1 connections each); the robots share one local Class 1 UDP
  port on 127.0.15.1, as every robot's default local_udp_port (2222) makes
  them share it in a plant (up to 32 on one port, DR_UDP_PORT_MAX_CLIENTS
  in lib/include/drgate/config.h, as many as the daemon's robots);
- a light Modbus load, as a PLC polling every robot: one TCP client in this
  process reads, every 100 ms and for every unit, the status block (IR 0-25)
  and 125 input registers of robot data (IR 200-324).

Over each point's window (--seconds, after every link is up and --settle
seconds): the daemon's CPU time (/proc/PID/schedstat; the median of its
share in five windows, and their range) and the time it was runnable but
waiting for a CPU; the measuring side's CPU (every drsim and
this process, the poller) apart; the machine's busy and idle time from
/proc/stat; T->O packets/s and lost packets from each unit's status block;
connection timeouts: the daemon's "link down" log lines, drsim's closes
"(O->T timeout)" and status samples with a connection not established.

A point is machine-limited when the machine had less than 10 % of its CPU
time idle over the window and it shows: the daemon waited for a CPU more
than 10 % of the time, the robots sent less than 95 % of their packets, or
a connection timed out. The figure then measures the machine, not the
daemon: such points are shown, marked (with who kept the machine busy: the
bench itself or other jobs), and left out of the linearity and the goal.
A busy machine whose daemon still got a CPU whenever it wanted one gives a
figure, marked "busy".

Goals (issue 15, restated as ratios in issue 20): the daemon's CPU per
robot at every N within 20 % of the CPU per robot at the smallest N with
reliable figures (judged as "no more than 1.20 times": cheaper per robot
is fine), and at RPI 10 ms 32 robots with no connection timeout and the
daemon's CPU at most that of the 32 drsims over the same window: they are
the other end of the same connections (the same datagrams each way), each
drsim wakes at least once per RPI for its own production timer, and the
daemon, on one shared port, at most once per robot's T->O burst
(docs/performance.md, "How the CPU goals are set"). The daemon's wake-ups
per RPI (voluntary context switches) are printed beside it.

usage: gw_scale.py --build DIR [--seconds S] [--settle S] [--counts 1,2,..]
                   [--rpis 10,2] [--quick] [--write-doc]
"""
import argparse
import datetime
import os
import platform
import shutil
import socket
import statistics
import struct
import sys
import tempfile
import threading
import time

# The child-process, free-port and doc-writing helpers of the gateway bench,
# beside this file.
from gw_bench import Proc, free_port, write_between

TOP = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(TOP, "docs", "performance.md")
NET = "127.0.15."          # 127.0.15.1 the daemon, .2 onwards the robots
GW_ADDR = NET + "1"
COUNTS = (1, 2, 4, 8, 16, 32)
RPIS = (10, 2)
CONNS = 6                  # Class 1 connections per robot
ROBOTS_PER_PORT = 32       # DR_UDP_PORT_MAX_CLIENTS: all robots on one port
WINDOWS = 5                # the daemon's CPU share: median of this many windows
POLL_S = 0.1               # the light Modbus load: every unit every 100 ms
DATA_WINDOW = (200, 125)   # IR 200-324: joint_state and the start of task_state
STATUS_REGS = 26           # IR 0-25: through conn_state[9]
IDLE_MIN = 10.0            # % of the machine idle below which it is busy
WAIT_MAX = 10.0            # % of the time the daemon may wait for a CPU
RATE_MIN = 0.95            # share of the expected T->O packets the robots must send

# Goals from issue 15.
GOAL_LINEAR = 1.20
GOAL_N, GOAL_RPI, GOAL_CPU_VS_SIMS = 32, 10, 1.0


def log(msg):
    print(f"bench-scale: {msg}", flush=True)


# ---- CPU accounting -----------------------------------------------------------

def schedstat(pid, task=None):
    """(ns on a CPU, ns runnable but waiting for one) of a process's main
    thread, or of one of its threads."""
    path = f"/proc/{pid}/task/{task}/schedstat" if task else f"/proc/{pid}/schedstat"
    with open(path) as f:
        run, wait = f.read().split()[:2]
    return int(run), int(wait)


def wakeups(pid):
    """Voluntary context switches of a process's main thread: the times its
    loop went to sleep (a wake-up each)."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("voluntary_ctxt_switches:"):
                return int(line.split()[1])
    return 0


def own_cpu_ns():
    """This process's CPU time, all threads (the Modbus poller is one)."""
    pid = os.getpid()
    return sum(schedstat(pid, t)[0] for t in os.listdir(f"/proc/{pid}/task"))


def machine_times():
    """(busy, all) jiffies of the whole machine; steal counts as busy, it
    was not ours to use."""
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    idle = v[3] + v[4]
    return sum(v[:8]) - idle, sum(v[:8])


# ---- Modbus, by hand ------------------------------------------------------------

class Modbus:
    """A Modbus TCP client: FC04 reads, one outstanding."""

    def __init__(self, port):
        self.s = socket.create_connection((GW_ADDR, port), timeout=1.0)
        self.s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.tid = 0

    def close(self):
        self.s.close()

    def read_ir(self, unit, addr, count):
        self.tid = (self.tid + 1) & 0xFFFF
        self.s.sendall(struct.pack(">HHHBBHH", self.tid, 0, 6, unit, 4, addr, count))
        buf = b""
        while len(buf) < 6 or len(buf) < 6 + struct.unpack(">H", buf[4:6])[0]:
            chunk = self.s.recv(512)
            if not chunk:
                raise OSError("Modbus connection closed")
            buf += chunk
        if struct.unpack(">H", buf[:2])[0] != self.tid or buf[7] != 4:
            raise OSError(f"unit {unit}: bad answer {buf[:9].hex()}")
        return struct.unpack(f">{count}H", buf[9:9 + 2 * count])


class Poller(threading.Thread):
    """The light Modbus load; it also keeps each unit's latest status."""

    def __init__(self, port, units):
        super().__init__(daemon=True)
        self.port, self.units = port, units
        self.stop_ev = threading.Event()
        self.lock = threading.Lock()
        self.latest = {}          # unit -> (monotonic time, status registers)
        self.not_up = 0           # status samples with a connection not established
        self.errors = 0
        self.requests = 0

    def run(self):
        mb = None
        while not self.stop_ev.is_set():
            t0 = time.monotonic()
            try:
                mb = mb or Modbus(self.port)
                for u in self.units:
                    st = mb.read_ir(u, 0, STATUS_REGS)
                    mb.read_ir(u, *DATA_WINDOW)
                    with self.lock:
                        self.requests += 2
                        self.latest[u] = (time.monotonic(), st)
                        if st[1] != 2 or any(c != 2 for c in st[16:16 + CONNS]):
                            self.not_up += 1
            except OSError:
                with self.lock:
                    self.errors += 1
                if mb:
                    mb.close()
                mb = None
            self.stop_ev.wait(max(0.0, POLL_S - (time.monotonic() - t0)))
        if mb:
            mb.close()

    def snapshot(self):
        with self.lock:
            return dict(self.latest), self.not_up, self.errors, self.requests


def counter(st, hi):
    return st[hi] << 16 | st[hi + 1]


# ---- the bench -------------------------------------------------------------------

class Bench:
    def __init__(self, args):
        self.args = args
        b = args.build if os.path.isabs(args.build) else os.path.join(TOP, args.build)
        self.sim_bin = os.path.join(b, "drsim")
        self.gw_bin = args.gateway or os.path.join(b, "bench", "drgatewayd-scale")
        for p in (self.sim_bin, self.gw_bin):
            if not os.access(p, os.X_OK):
                raise RuntimeError(f"{p} not built")
        self.tmp = tempfile.mkdtemp(prefix="bench-scale-")
        self.sims = []
        self.points = []

    def start_sims(self, n):
        for i in range(n):
            addr = NET + str(i + 2)
            tcp = free_port(addr, [socket.SOCK_STREAM, socket.SOCK_DGRAM])
            udp = free_port(addr, [socket.SOCK_DGRAM])
            # -v: drsim logs the connections it closes ("O->T timeout")
            p = Proc(f"drsim{i + 1}", [self.sim_bin, "-v", "--address", addr, "--tcp-port",
                                       str(tcp), "--udp-port", str(udp), "--seed", str(i + 1)],
                     self.tmp)
            p.addr, p.tcp, p.udp = addr, tcp, udp
            self.sims.append(p)
        time.sleep(0.3)
        for p in self.sims:
            if not p.alive():
                raise RuntimeError(f"{p.name} exited:\n{p.log()}")

    def write_ini(self, n, rpi, name):
        mb_port = free_port(GW_ADDR, [socket.SOCK_STREAM])
        ports = [free_port(GW_ADDR, [socket.SOCK_DGRAM])
                 for _ in range((n + ROBOTS_PER_PORT - 1) // ROBOTS_PER_PORT)]
        text = f"[daemon]\nlog_level = info\n\n[modbus]\nlisten = {GW_ADDR}\nport = {mb_port}\n"
        for i, sim in enumerate(self.sims[:n]):
            text += (f"\n[robot r{i + 1:02d}]\nhost = {sim.addr}\ntcp_port = {sim.tcp}\n"
                     f"udp_port = {sim.udp}\nlocal_address = {GW_ADDR}\n"
                     f"local_udp_port = {ports[i // ROBOTS_PER_PORT]}\n"
                     f"unit_id = {i + 1}\nrpi_ms = {rpi}\n")
        path = os.path.join(self.tmp, name + ".ini")
        with open(path, "w") as f:
            f.write(text)
        return path, mb_port

    def wait_up(self, gw, port, n, timeout):
        """Until every unit's link is up; False if that does not happen."""
        end = time.monotonic() + timeout
        pending = set(range(1, n + 1))
        while pending and time.monotonic() < end and gw.alive():
            try:
                mb = Modbus(port)
                try:
                    pending = {u for u in pending if mb.read_ir(u, 1, 1)[0] != 2}
                finally:
                    mb.close()
            except OSError:
                pass
            if pending:
                time.sleep(0.1)
        return not pending

    def sims_log_count(self, n, what):
        return sum(p.log().count(what) for p in self.sims[:n])

    def point(self, n, rpi):
        a = self.args
        name = f"gw-{n}-{rpi}"
        ini, port = self.write_ini(n, rpi, name)
        gw = Proc(name, [self.gw_bin, "-c", ini], self.tmp)
        pt = {"n": n, "rpi": rpi, "up": False}
        poller = None
        try:
            pt["up"] = self.wait_up(gw, port, n, a.up_timeout)
            if not pt["up"]:
                pt["why"] = "daemon exited" if not gw.alive() else "links not all up"
                log(f"N={n} RPI {rpi} ms: {pt['why']} within {a.up_timeout:g} s; "
                    f"the daemon's log ends:\n{gw.log()[-1500:]}")
                return pt
            poller = Poller(port, list(range(1, n + 1)))
            poller.start()
            time.sleep(a.settle)
            self.measure(pt, gw, poller)
        finally:
            if poller:
                poller.stop_ev.set()
                poller.join(5)
            gw.stop()
        self.report_point(pt)
        return pt

    def measure(self, pt, gw, poller):
        n, a = pt["n"], self.args
        sims = self.sims[:n]
        downs0 = gw.log().count("link down")
        o2t0 = self.sims_log_count(n, "(O->T timeout)")
        st0, nu0, err0, rq0 = poller.snapshot()
        t0 = time.monotonic()
        g0 = schedstat(gw.pid)
        w0 = wakeups(gw.pid)
        s0 = sum(schedstat(p.pid)[0] for p in sims)
        b0 = own_cpu_ns()
        m0 = machine_times()
        # the daemon's share in five windows: their median, and their range
        shares, tw, cw = [], t0, g0[0]
        for _ in range(WINDOWS):
            time.sleep(a.seconds / WINDOWS)
            t, c = time.monotonic(), schedstat(gw.pid)[0]
            shares.append((c - cw) / 1e7 / (t - tw))
            tw, cw = t, c
        m1 = machine_times()
        b1 = own_cpu_ns()
        s1 = sum(schedstat(p.pid)[0] for p in sims)
        g1 = schedstat(gw.pid)
        w1 = wakeups(gw.pid)
        t1 = time.monotonic()
        st1, nu1, err1, rq1 = poller.snapshot()
        dt = t1 - t0
        ncpu = os.cpu_count()
        pt["gw_pct"] = statistics.median(shares)
        pt["gw_range"] = (min(shares), max(shares))
        gw_all = (g1[0] - g0[0]) / 1e7 / dt          # the whole window, for the sums
        pt["gw_wait_pct"] = (g1[1] - g0[1]) / 1e7 / dt
        pt["sim_pct"] = (s1 - s0) / 1e7 / dt
        pt["gw_vs_sims"] = (g1[0] - g0[0]) / max(s1 - s0, 1)     # the same window
        pt["wake_per_rpi"] = (w1 - w0) / (dt * 1000.0 / pt["rpi"])
        pt["poll_pct"] = (b1 - b0) / 1e7 / dt
        busy, total = m1[0] - m0[0], m1[1] - m0[1]
        pt["machine_pct"] = busy / total * 100 * ncpu     # % of one core, all CPUs
        pt["idle_pct"] = 100 - busy / total * 100         # share of the machine idle
        pt["others_pct"] = max(0.0, pt["machine_pct"] - gw_all - pt["sim_pct"]
                               - pt["poll_pct"])
        rx = lost = 0
        span = []
        for u in range(1, n + 1):
            if u in st0 and u in st1:
                rx += counter(st1[u][1], 6) - counter(st0[u][1], 6)
                lost += counter(st1[u][1], 8) - counter(st0[u][1], 8)
                span.append(st1[u][0] - st0[u][0])
        pt["rx_per_s"] = rx / (sum(span) / len(span)) if span else 0.0
        pt["expected_per_s"] = n * CONNS * 1000.0 / pt["rpi"]
        pt["lost"] = lost
        pt["link_downs"] = gw.log().count("link down") - downs0
        pt["o2t_timeouts"] = self.sims_log_count(n, "(O->T timeout)") - o2t0
        pt["not_up"] = nu1 - nu0
        pt["mb_errors"] = err1 - err0
        pt["mb_per_s"] = (rq1 - rq0) / dt
        pt["timeouts"] = pt["link_downs"] + pt["o2t_timeouts"] + pt["not_up"]
        # A busy machine alone does not spoil the figure: the daemon may
        # still have got a CPU whenever it wanted one. It does when the
        # daemon waited for one, the robots did not send at their rate, or
        # connections timed out.
        ours = gw_all + pt["sim_pct"] + pt["poll_pct"]
        pt["busy_by"] = "the bench" if ours >= pt["others_pct"] else "other jobs"
        starved = (pt["gw_wait_pct"] > WAIT_MAX or pt["timeouts"] > 0
                   or pt["rx_per_s"] < RATE_MIN * pt["expected_per_s"])
        pt["limited"] = pt["busy_by"] if pt["idle_pct"] < IDLE_MIN and starved else None

    def report_point(self, pt):
        if "gw_pct" not in pt:
            return
        tag = f"  MACHINE-LIMITED ({pt['limited']})" if pt["limited"] else \
            f"  busy ({pt['busy_by']})" if pt["idle_pct"] < IDLE_MIN else ""
        log(f"N={pt['n']:2d} RPI {pt['rpi']:2d} ms: daemon {pt['gw_pct']:5.1f} % "
            f"[{pt['gw_range'][0]:.1f}-{pt['gw_range'][1]:.1f}] "
            f"({pt['gw_pct'] / pt['n']:.2f} per robot, waiting {pt['gw_wait_pct']:.1f} %), "
            f"{pt['wake_per_rpi']:.1f} wake-ups per RPI, drsims {pt['sim_pct']:.1f} % "
            f"(daemon/drsims {pt['gw_vs_sims']:.2f}x), poller {pt['poll_pct']:.1f} %, "
            f"others {pt['others_pct']:.0f} %, machine idle {pt['idle_pct']:.0f} %, "
            f"T->O {pt['rx_per_s']:.0f}/s of {pt['expected_per_s']:.0f}, "
            f"Modbus {pt['mb_per_s']:.0f} req/s, "
            f"timeouts {pt['timeouts']}{tag}")

    def run(self):
        a = self.args
        t_begin = time.monotonic()
        self.load_before = os.getloadavg()
        self.start_sims(max(a.counts))
        for rpi in a.rpis:
            for n in a.counts:
                self.points.append(self.point(n, rpi))
        self.load_after = os.getloadavg()
        self.elapsed = time.monotonic() - t_begin

    def cleanup(self):
        for p in self.sims:
            p.stop()
        self.sims = []

    # ---- verdicts ------------------------------------------------------------------
    def reliable(self, pt):
        return pt["up"] and "gw_pct" in pt and not pt["limited"]

    def linearity(self, rpi):
        """(reference point, [(point, ratio)]) over the reliable points."""
        pts = [p for p in self.points if p["rpi"] == rpi and self.reliable(p)]
        if not pts:
            return None, []
        ref = pts[0]
        per = ref["gw_pct"] / ref["n"]
        return ref, [(p, p["gw_pct"] / p["n"] / per) for p in pts[1:]]

    def fit(self, rpi):
        """Least squares CPU = fixed + per_robot * N over the reliable points."""
        pts = [(p["n"], p["gw_pct"]) for p in self.points if p["rpi"] == rpi and self.reliable(p)]
        if len(pts) < 2:
            return None
        mx = sum(x for x, _ in pts) / len(pts)
        my = sum(y for _, y in pts) / len(pts)
        sxx = sum((x - mx) ** 2 for x, _ in pts)
        slope = sum((x - mx) * (y - my) for x, y in pts) / sxx
        return my - slope * mx, slope

    def goal_lines(self):
        """(text, verdict) for every goal; verdict met, MISSED or not judged."""
        out = []
        for rpi in self.args.rpis:
            ref, ratios = self.linearity(rpi)
            if not ratios:
                out.append((f"linearity, RPI {rpi} ms: fewer than two reliable points",
                            "not judged"))
                continue
            worst, r = max(ratios, key=lambda x: x[1])
            low = min(x[1] for x in ratios)
            out.append((f"linearity, RPI {rpi} ms: CPU per robot vs N={ref['n']}: "
                        f"{low:.2f}x to {r:.2f}x (worst at N={worst['n']}), "
                        f"goal <= {GOAL_LINEAR:.2f}x", "met" if r <= GOAL_LINEAR else "MISSED"))
        pt = next((p for p in self.points if p["n"] == GOAL_N and p["rpi"] == GOAL_RPI), None)
        what = f"{GOAL_N} robots at RPI {GOAL_RPI} ms"
        goal = (f"goal daemon <= {GOAL_CPU_VS_SIMS:.1f}x the {GOAL_N} drsims' CPU, "
                f"no connection timeout")
        if pt is None:
            out.append((f"{what}: not measured in this run, {goal}", "not judged"))
        elif not pt["up"] or "gw_pct" not in pt:
            out.append((f"{what}: {pt.get('why', 'no figures')}, {goal}", "MISSED"))
        elif pt["limited"]:
            out.append((f"{what}: machine-limited ({pt['limited']}; daemon "
                        f"{pt['gw_pct']:.1f} %, {pt['timeouts']} timeouts), {goal}",
                        "not judged"))
        else:
            ok = pt["gw_vs_sims"] <= GOAL_CPU_VS_SIMS and pt["timeouts"] == 0
            out.append((f"{what}: daemon {pt['gw_vs_sims']:.2f}x the drsims' CPU "
                        f"({pt['gw_pct']:.1f} % of a core against {pt['sim_pct']:.1f} %), "
                        f"{pt['timeouts']} timeouts, {goal}", "met" if ok else "MISSED"))
        return out

    # ---- report ----------------------------------------------------------------------
    def markdown(self, goals=True):
        a = self.args
        out = ["| RPI | robots | daemon, % of a core | per robot | T->O packets/s "
               "(expected) | timeouts | drsims + poller, % | others, % | machine idle |",
               "|---|---|---|---|---|---|---|---|---|"]
        for p in self.points:
            if "gw_pct" not in p:
                out.append(f"| {p['rpi']} ms | {p['n']} | {p.get('why', '?')} | | | | | | |")
                continue
            cpu = (f"{p['gw_pct']:.1f} ({p['gw_range'][0]:.1f}-{p['gw_range'][1]:.1f}; "
                   f"waiting {p['gw_wait_pct']:.0f})")
            per = f"{p['gw_pct'] / p['n']:.2f}"
            if p["limited"]:
                cpu = f"machine-limited ({p['limited']}): [{p['gw_pct']:.1f}]"
                per = "-"
            elif p["idle_pct"] < IDLE_MIN:
                cpu += f", busy ({p['busy_by']})"
            out.append(f"| {p['rpi']} ms | {p['n']} | {cpu} | {per} | "
                       f"{p['rx_per_s']:.0f} ({p['expected_per_s']:.0f}) | "
                       f"{p['timeouts']} | {p['sim_pct']:.0f} + {p['poll_pct']:.1f} | "
                       f"{p['others_pct']:.0f} | {p['idle_pct']:.0f} % |")
        out.append("")
        for rpi in a.rpis:
            f = self.fit(rpi)
            if f:
                out.append(f"- Fit at RPI {rpi} ms (reliable points): {f[0]:.2f} % fixed + "
                           f"{f[1]:.2f} % of a core per robot.")
        for text, verdict in self.goal_lines() if goals else ():
            out.append(f"- {text}: **{verdict}**.")
        out.append("")
        timeouts = sum(p.get("link_downs", 0) for p in self.points)
        closes = sum(p.get("o2t_timeouts", 0) for p in self.points)
        lost = sum(p.get("lost", 0) for p in self.points)
        errs = sum(p.get("mb_errors", 0) for p in self.points)
        out.append(f"Run: {datetime.datetime.now().strftime('%Y-%m-%d %H:%M')}, "
                   f"{os.cpu_count()} CPUs, Linux {platform.release()}, load average "
                   f"{self.load_before[0]:.2f} before / {self.load_after[0]:.2f} after, "
                   f"{a.seconds:g} s per point after {a.settle:g} s of settling, "
                   f"{self.elapsed:.0f} s in all. Over all points: {timeouts} link losses "
                   f"logged by the daemon, {closes} connections closed by a robot for want "
                   f"of O->T packets, {lost} T->O packets lost, {errs} Modbus poll errors.")
        return "\n".join(out)


BEGIN = "<!-- bench-scale results: begin (rewritten by make bench-scale SCALE_BENCH_ARGS=--write-doc) -->"
END = "<!-- bench-scale results: end -->"


def write_doc(md):
    """The results of the "Robots per core" section (its markers must be
    there: the rest of the section is written by hand)."""
    write_between(DOC, BEGIN, END, md)


def int_list(s):
    return tuple(int(x) for x in s.split(","))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--gateway", help="drgatewayd to measure instead of the build's "
                    "bench/drgatewayd-scale (one with room for the robots)")
    ap.add_argument("--counts", type=int_list, default=COUNTS, help="robot counts, e.g. 1,2,4")
    ap.add_argument("--rpis", type=int_list, default=RPIS, help="RPIs in ms, e.g. 10,2")
    ap.add_argument("--seconds", type=float, default=5.0, help="measured seconds per point")
    ap.add_argument("--settle", type=float, default=1.0, help="seconds after the links are up")
    ap.add_argument("--up-timeout", type=float, default=20.0,
                    help="seconds for every link to come up")
    ap.add_argument("--quick", action="store_true", help="N = 1, 2, 4 only, 2 s per point")
    ap.add_argument("--write-doc", action="store_true", help=f"write the results into {DOC}")
    args = ap.parse_args()
    if args.quick:
        args.counts, args.seconds, args.settle = (1, 2, 4), 2.0, 0.5
        if args.write_doc:
            ap.error("--write-doc needs the whole run")
    if max(args.counts) > 253:
        ap.error("at most 253 robots (127.0.15.2-254)")
    b = Bench(args)
    try:
        b.run()
    except Exception as e:  # noqa: BLE001 -- report, clean up, fail
        b.cleanup()
        for p in sorted(os.listdir(b.tmp)):
            if p.endswith(".log") and p.startswith("gw-"):
                sys.stderr.write(f"--- {p}\n" + open(os.path.join(b.tmp, p)).read()[-2000:])
        log(f"FAILED: {e}")
        return 1
    b.cleanup()
    shutil.rmtree(b.tmp, ignore_errors=True)
    print()
    print(b.markdown(goals=False))  # the goals once, below, for make bench's summary
    print()
    verdicts = b.goal_lines()
    for text, verdict in verdicts:
        print(f"  {text}   {verdict}")
    if args.write_doc:
        write_doc(b.markdown())
        log(f"written to {os.path.relpath(DOC, TOP)}")
    missed = [t for t, v in verdicts if v == "MISSED"]
    if missed:
        log(f"{len(missed)} goal(s) MISSED")
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
