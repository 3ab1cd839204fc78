#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""drgatewayd's benchmark (issue 5, "Done when"), run by `make bench-gw`.

Side by side in one run, on loopback, with drsim as the robot:

1. CPU share and RSS: drgatewayd with one robot, six Class 1 connections at
   RPI 2 ms, no Modbus client, for --idle seconds (CPU time from
   /proc/PID/schedstat, which counts nanoseconds, and utime+stime from
   /proc/PID/stat as a cross-check; VmRSS, and VmHWM after the load runs).
   Its baseline is drsim over the same windows: the other end of the same
   six connections, which receives every packet the daemon sends and sends
   every packet it receives (the mirror work); the goal is the ratio of
   the two, and the wake-ups per RPI (voluntary context switches) of both
   are printed beside it.
2. Modbus throughput: bench/gw_load (C, one epoll loop, each connection
   keeps one request outstanding) against drgatewayd (the six connections
   still running), a plain select-loop libmodbus server
   (bench/gw_plain_server.c) and a pymodbus 3.8 async server
   (bench/gw_pymodbus_server.py), all with the gateway's register counts,
   with 1, 8 and 64 clients. The servers take turns (interleaved, order
   rotated every round), --rounds rounds; medians are reported, the ratios
   are the medians of the per-round ratios.
3. Latency from a robot packet's arrival to Modbus visibility: a build of
   drgatewayd with bench/gw_lat.c (a link observer) takes, for every
   T->O packet, the kernel's receive timestamp of the datagram (SIOCGSTAMPNS
   on the Class 1 socket: when the packet entered this host's network
   stack) and the time its data has been copied into the unit image that
   every Modbus read answers from. Measured with no Modbus load and under
   8 and 64 clients.

The request mix: FC03 and FC04 reads of 125 registers, alternating, on all
three servers, at the addresses where 125 registers hold the most mapped
ones (from `drgatewayd --print-map --json`; the reserved registers between
the gateway's blocks read 0).

usage: gw_bench.py --build DIR [--rounds N] [--duration S] [--idle S]
                   [--lat-phase S] [--write-doc] [--quick]
"""
import argparse
import datetime
import json
import os
import platform
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time

TOP = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIM_ADDR = "127.0.42.2"  # drsim (the robot)
GW_ADDR = "127.0.42.1"   # Modbus servers, gateway's Class 1 socket, clients
CLIENTS = (1, 8, 64)
RPI_MS = 2
DOC = os.path.join(TOP, "docs", "performance.md")

# Goals from issue 5.
GOAL_PLAIN = 0.9
GOAL_PYMODBUS = 3.0
# Robot packet -> Modbus visible, p99, over the same path with no gateway
# in it (bench/lat_bare.c: UDP -> epoll -> shared memory), run beside it in
# the same window (docs/performance.md, "Latency against a bare
# baseline"). Was "< 100 us" (issue 30 item 6).
GOAL_LAT_VS_BARE = 2.0
GOAL_RSS_KB = 4096
# The daemon's CPU over drsim's in the same windows (docs/performance.md,
# "How the CPU goals are set"): the same datagrams each way, and at most
# the same wake-ups (one per RPI, O->T sent with the T->O arrivals, batched)
# where drsim also wakes for its own production timer: no more than drsim.
GOAL_CPU_VS_SIM = 1.0
# The Modbus request log (issue 33): req/s of the daemon built without it
# over the real one's, 8 clients.
GOAL_REQLOG = 1.05
REQLOG_CLIENTS = 8


def log(msg):
    print(f"bench-gw: {msg}", flush=True)


def free_port(addr, kinds):
    """A port free for every socket type in kinds on addr."""
    for _ in range(200):
        socks = []
        try:
            s = socket.socket(socket.AF_INET, kinds[0])
            socks.append(s)
            s.bind((addr, 0))
            port = s.getsockname()[1]
            for k in kinds[1:]:
                o = socket.socket(socket.AF_INET, k)
                socks.append(o)
                o.bind((addr, port))
            return port
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
    raise RuntimeError(f"no free port on {addr}")


class Proc:
    """A child process with its output in a log file."""

    def __init__(self, name, argv, tmp, env=None):
        self.name = name
        self.logpath = os.path.join(tmp, name + ".log")
        self.logf = open(self.logpath, "w")
        self.p = subprocess.Popen(argv, stdout=self.logf, stderr=subprocess.STDOUT,
                                  env=env, cwd=TOP)
        self.pid = self.p.pid

    def log(self):
        with open(self.logpath) as f:
            return f.read()

    def alive(self):
        return self.p.poll() is None

    def stop(self):
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGTERM)
            try:
                self.p.wait(5)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
        self.logf.close()


def wait_for(what, cond, timeout=10.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return
        time.sleep(0.05)
    raise RuntimeError(f"timed out waiting for {what}")


def accepts(port):
    try:
        with socket.create_connection((GW_ADDR, port), timeout=0.5):
            return True
    except OSError:
        return False


def cpu_ns(pid):
    with open(f"/proc/{pid}/schedstat") as f:
        return int(f.read().split()[0])


def run_delay_ns(pid):
    """Time spent runnable but waiting for a CPU (a busy machine)."""
    with open(f"/proc/{pid}/schedstat") as f:
        return int(f.read().split()[1])


def wakeups(pid):
    """Voluntary context switches: the times the process went to sleep
    waiting for something (a wake-up each)."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("voluntary_ctxt_switches:"):
                return int(line.split()[1])
    return 0


def cpu_ticks(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])  # utime, stime (fields 14, 15)


def status_kb(pid, key):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


def read_input_registers(port, addr, count, unit=1):
    """One FC04 read with a raw socket (status block checks)."""
    with socket.create_connection((GW_ADDR, port), timeout=2) as s:
        s.sendall(bytes([0, 1, 0, 0, 0, 6, unit, 4, addr >> 8, addr & 0xFF, 0, count]))
        buf = b""
        while len(buf) < 9 or len(buf) < 6 + int.from_bytes(buf[4:6], "big"):
            chunk = s.recv(512)
            if not chunk:
                raise RuntimeError("status read: connection closed")
            buf += chunk
    if buf[7] != 4:
        raise RuntimeError(f"status read: exception 0x{buf[8]:02x}")
    return [int.from_bytes(buf[9 + 2 * i:11 + 2 * i], "big") for i in range(count)]


def read_windows(gw_bin, count=125):
    """FC03 and FC04 reads of `count` registers where they cover the most
    mapped registers, inside the map (reads past its end are refused)."""
    out = subprocess.run([gw_bin, "--print-map", "--json"], check=True,
                         capture_output=True, text=True).stdout
    best = {}
    for area in ("HR", "IR"):
        addrs = set()
        for e in json.loads(out):
            if e["area"] == area:
                addrs.update(range(e["address"], e["address"] + e["count"]))
        end = max(addrs) + 1
        starts = [a for a in sorted(addrs) if a + count <= end]
        best[area] = max(starts, key=lambda s: (len(addrs & set(range(s, s + count))), -s))
    return (f"3:{best['HR']}:{count}", f"4:{best['IR']}:{count}")


def pct(xs, p):
    if not xs:
        return float("nan")
    return xs[min(len(xs) - 1, int(p / 100.0 * (len(xs) - 1) + 0.5))]


class Bench:
    def __init__(self, args):
        self.args = args
        b = os.path.join(TOP, args.build) if not os.path.isabs(args.build) else args.build
        self.bin = {n: os.path.join(b, n) for n in ("drsim", "drgatewayd")}
        for n in ("gw_load", "gw_plain_server", "drgatewayd-lat", "lat_bare",
                  "drgatewayd-noreqlog"):
            self.bin[n] = os.path.join(b, "bench", n)
        if args.gateway:
            self.bin["drgatewayd"] = os.path.abspath(args.gateway)
        if args.gateway_lat:
            self.bin["drgatewayd-lat"] = os.path.abspath(args.gateway_lat)
        for n, p in self.bin.items():
            if not os.access(p, os.X_OK):
                raise RuntimeError(f"{p} not built")
        self.tmp = tempfile.mkdtemp(prefix="bench-gw-")
        self.procs = []
        self.notes = []
        self.failures = []
        self.fifo_ok = False

    def start(self, name, argv, env=None):
        p = Proc(name, argv, self.tmp, env)
        self.procs.append(p)
        return p

    def stop(self, p):
        p.stop()
        self.procs.remove(p)

    def cleanup(self):
        for p in reversed(self.procs):
            p.stop()
        self.procs = []

    # ---- processes -----------------------------------------------------------
    def start_gateway(self, binary, name, env=None, sim=None):
        sim_tcp, sim_udp = sim or (self.sim_tcp, self.sim_udp)
        mb_port = free_port(GW_ADDR, [socket.SOCK_STREAM])
        local_udp = free_port(GW_ADDR, [socket.SOCK_DGRAM])
        ini = os.path.join(self.tmp, name + ".ini")
        with open(ini, "w") as f:
            f.write(f"""[modbus]
listen = {GW_ADDR}
port = {mb_port}
max_clients = 100

[robot bench]
host = {SIM_ADDR}
tcp_port = {sim_tcp}
udp_port = {sim_udp}
local_address = {GW_ADDR}
local_udp_port = {local_udp}
rpi_ms = {RPI_MS}
""")
        p = self.start(name, [binary, "-c", ini], env)
        p.port = mb_port
        wait_for(f"{name}: link up", lambda: "link up" in p.log() or not p.alive())
        if not p.alive():
            raise RuntimeError(f"{name} exited:\n{p.log()}")
        wait_for(f"{name}: Modbus port", lambda: accepts(mb_port))
        return p

    def load(self, port, clients, reqs, duration, label, warm=0.5):
        argv = [self.bin["gw_load"], "-H", GW_ADDR, "-p", str(port), "-c", str(clients),
                "-d", str(duration), "-w", str(warm), "-l", label]
        for r in reqs:
            argv += ["-r", r]
        return argv

    def run_load(self, port, clients, reqs, duration, label):
        r = subprocess.run(self.load(port, clients, reqs, duration, label), capture_output=True,
                           text=True, timeout=duration + 60)
        try:
            res = json.loads(r.stdout)
        except json.JSONDecodeError:
            raise RuntimeError(f"gw_load {label}: {r.stderr.strip()}")
        if r.returncode != 0 or res["errors"]:
            self.failures.append(f"{label}: {res['errors']} bad answers "
                                 f"({res.get('first_exception', '')}) {r.stderr.strip()}")
        return res

    def run_bare(self):
        """One run of bench/lat_bare for --lat-phase seconds: the p50, p99,
        p99.9 and max of packet -> written into shared memory (the point
        where drgatewayd-lat takes "visible"), of the writer's own part,
        and of packet -> read by the reader (us)."""
        a = self.args
        r = subprocess.run([self.bin["lat_bare"], "-a", GW_ADDR, "-s", str(a.lat_phase),
                            "-w", "0", "-r", str(RPI_MS * 1000)],
                           capture_output=True, text=True, timeout=a.lat_phase + 60)
        try:
            return json.loads(r.stdout)
        except json.JSONDecodeError:
            raise RuntimeError(f"lat_bare: {r.stderr.strip()}")

    # ---- phases --------------------------------------------------------------
    def run_modbus(self, sim):
        """CPU and RSS, then the throughput runs (parts 1 and 2)."""
        a, reqs = self.args, self.reqs
        gw = self.start_gateway(self.bin["drgatewayd"], "drgatewayd")
        plain_port = free_port(GW_ADDR, [socket.SOCK_STREAM])
        plain = self.start("plain", [self.bin["gw_plain_server"], str(plain_port), GW_ADDR])
        py_port = free_port(GW_ADDR, [socket.SOCK_STREAM])
        py = self.start("pymodbus", [a.python, os.path.join(TOP, "bench", "gw_pymodbus_server.py"),
                                     str(py_port), GW_ADDR])
        wait_for("plain server", lambda: accepts(plain_port))
        wait_for("pymodbus server", lambda: accepts(py_port), timeout=20)
        self.pymodbus_version = py.log().split("pymodbus ")[-1].split()[0] if "pymodbus " in py.log() else "?"

        # 1. CPU and RSS with no Modbus load.
        time.sleep(1.0)
        log(f"CPU share of drgatewayd, 6 connections at RPI {RPI_MS} ms, no Modbus load, "
            f"{a.idle:g} s")
        t0, c0, k0 = time.monotonic(), cpu_ns(gw.pid), cpu_ticks(gw.pid)
        r0 = run_delay_ns(gw.pid)
        s0, w0, ws0 = cpu_ns(sim.pid), wakeups(gw.pid), wakeups(sim.pid)
        # five windows: the median of their shares, and their range; drsim
        # over the same windows, and the ratio of each window
        shares, sim_shares, ratios, tw, cw, sw = [], [], [], t0, c0, s0
        for _ in range(5):
            time.sleep(a.idle / 5)
            t, c, s = time.monotonic(), cpu_ns(gw.pid), cpu_ns(sim.pid)
            shares.append((c - cw) / 1e9 / (t - tw) * 100)
            sim_shares.append((s - sw) / 1e9 / (t - tw) * 100)
            ratios.append((c - cw) / max(s - sw, 1))
            tw, cw, sw = t, c, s
        t1, k1 = time.monotonic(), cpu_ticks(gw.pid)
        periods = (t1 - t0) * 1000 / RPI_MS
        self.wake_per_rpi = (wakeups(gw.pid) - w0) / periods
        self.sim_wake_per_rpi = (wakeups(sim.pid) - ws0) / periods
        self.idle_rq = (run_delay_ns(gw.pid) - r0) / 1e9 / (t1 - t0) * 100
        self.cpu_pct = statistics.median(shares)
        self.cpu_range = (min(shares), max(shares))
        self.sim_cpu_pct = statistics.median(sim_shares)
        self.cpu_vs_sim = statistics.median(ratios)
        self.cpu_ticks_pct = (k1 - k0) / os.sysconf("SC_CLK_TCK") / (t1 - t0) * 100
        self.rss_idle = status_kb(gw.pid, "VmRSS")
        log(f"  {self.cpu_pct:.2f} % of a core (utime+stime: {self.cpu_ticks_pct:.1f} %), "
            f"{self.wake_per_rpi:.2f} wake-ups per RPI; drsim {self.sim_cpu_pct:.2f} %, "
            f"{self.sim_wake_per_rpi:.2f} wake-ups per RPI; ratio {self.cpu_vs_sim:.2f}x; "
            f"VmRSS {self.rss_idle} kB")
        st0 = read_input_registers(gw.port, 0, 16)

        # 2. Throughput, interleaved.
        servers = [("gw", gw.port, reqs), ("plain", plain_port, reqs),
                   ("pymodbus", py_port, reqs)]
        self.tput = {(s[0], c): [] for s in servers for c in CLIENTS}
        self.tput_lat = {(s[0], c): [] for s in servers for c in CLIENTS}
        self.tput_p50 = {(s[0], c): [] for s in servers for c in CLIENTS}
        for rnd in range(a.rounds):
            order = servers[rnd % len(servers):] + servers[:rnd % len(servers)]
            for c in CLIENTS:
                line = []
                for name, port, rq in order:
                    res = self.run_load(port, c, rq, a.duration, f"{name}/{c}")
                    self.tput[(name, c)].append(res["rps"])
                    self.tput_lat[(name, c)].append(res["p99_us"])
                    self.tput_p50[(name, c)].append(res["p50_us"])
                    line.append(f"{name} {res['rps']:.0f}")
                log(f"round {rnd + 1}/{a.rounds}, {c:2d} client(s): " + ", ".join(line))
        self.rss_hwm = status_kb(gw.pid, "VmHWM")
        self.rss_after = status_kb(gw.pid, "VmRSS")
        st1 = read_input_registers(gw.port, 0, 16)
        self.enip_check = {
            "link_state": st1[1], "fresh": st1[2],
            "rx": (st1[6] << 16 | st1[7]) - (st0[6] << 16 | st0[7]),
            "lost": (st1[8] << 16 | st1[9]) - (st0[8] << 16 | st0[9]),
            "link_down_logged": gw.log().count("link down:"),
            "robot_o2t_timeouts": sim.log().count("(O->T timeout)"),
        }
        log(f"ENIP during the load runs: {self.enip_check}")
        self.stop(gw)
        self.stop(plain)
        self.stop(py)

    def run_reqlog(self):
        """The request log's cost (issue 33): the daemon and the same
        daemon built without the log (-DGW_MB_NO_REQLOG), each with its own
        drsim, take turns under REQLOG_CLIENTS clients, --rounds rounds."""
        a = self.args
        tcp2 = free_port(SIM_ADDR, [socket.SOCK_STREAM, socket.SOCK_DGRAM])
        udp2 = free_port(SIM_ADDR, [socket.SOCK_DGRAM])
        sim2 = self.start("drsim-2", [self.bin["drsim"], "--address", SIM_ADDR, "--tcp-port",
                                      str(tcp2), "--udp-port", str(udp2)])
        gw = self.start_gateway(self.bin["drgatewayd"], "drgatewayd-reqlog")
        nolog = self.start_gateway(self.bin["drgatewayd-noreqlog"], "drgatewayd-noreqlog",
                                   sim=(tcp2, udp2))
        pairs = [("log", gw.port), ("nolog", nolog.port)]
        self.reqlog = {"log": [], "nolog": []}
        for rnd in range(a.rounds):
            for name, port in pairs[rnd % 2:] + pairs[:rnd % 2]:
                res = self.run_load(port, REQLOG_CLIENTS, self.reqs, a.duration,
                                    f"reqlog-{name}/{REQLOG_CLIENTS}")
                self.reqlog[name].append(res["rps"])
            log(f"request log, round {rnd + 1}/{a.rounds}, {REQLOG_CLIENTS} clients: with "
                f"{self.reqlog['log'][-1]:.0f}, without {self.reqlog['nolog'][-1]:.0f} req/s")
        for p in (gw, nolog, sim2):
            self.stop(p)

    def reqlog_row(self, ok):
        r = statistics.median(n / w for n, w in zip(self.reqlog["nolog"], self.reqlog["log"]))
        return (f"Modbus request log's cost, FC03/FC04 req/s, {REQLOG_CLIENTS} clients: "
                f"without the log over with it",
                f"{statistics.median(self.reqlog['log']):.0f}",
                f"{statistics.median(self.reqlog['nolog']):.0f} (without)",
                f"{r:.3f}x", f"<= {GOAL_REQLOG}x", ok(r <= GOAL_REQLOG))

    def run(self):
        a = self.args
        t_begin = time.monotonic()
        self.sim_tcp = free_port(SIM_ADDR, [socket.SOCK_STREAM, socket.SOCK_DGRAM])
        self.sim_udp = free_port(SIM_ADDR, [socket.SOCK_DGRAM])
        self.load_before = os.getloadavg()
        reqs = read_windows(self.bin["drgatewayd"])
        self.reqs = reqs
        log(f"request mix: {' and '.join(reqs)} (FC:address:count)")

        # -v: drsim logs its connections' opening and closing (O->T timeouts)
        sim = self.start("drsim", [self.bin["drsim"], "-v", "--address", SIM_ADDR, "--tcp-port",
                                   str(self.sim_tcp), "--udp-port", str(self.sim_udp)])
        self.sim = sim
        time.sleep(0.3)
        if not sim.alive():
            raise RuntimeError(f"drsim exited:\n{sim.log()}")
        if not a.latency_only:
            self.run_reqlog()
        if a.reqlog_only:
            self.enip_check = None
            self.cleanup()
            return
        if not a.latency_only:
            self.run_modbus(sim)
        else:
            self.enip_check = None

        # 3. Latency, instrumented build. During the first phase (no
        # Modbus load) the bare baseline runs beside it (bench/lat_bare.c):
        # the same path shape, a UDP datagram through epoll into shared
        # memory and out to a reader, with no gateway in it, on the same
        # CPUs at the same moments (issue 30 item 6).
        latfile = os.path.join(self.tmp, "latency.txt")
        env = dict(os.environ, GW_BENCH_LATENCY_FILE=latfile)
        gwl = self.start_gateway(self.bin["drgatewayd-lat"], "drgatewayd-lat", env)
        time.sleep(1.0)
        windows = []
        phases = [(None, 0)] + [(None, c) for c in (8, 64)]
        if a.fifo:
            phases += [("fifo", 0)] + [("fifo", c) for c in (8, 64)]
        for pol, c in phases:
            if pol == "fifo" and not self.fifo_ok:
                r = subprocess.run(["chrt", "-f", "-p", "10", str(gwl.pid)],
                                   capture_output=True, text=True)
                self.fifo_ok = r.returncode == 0
                if not self.fifo_ok:
                    self.notes.append(f"chrt -f failed: {r.stderr.strip()}")
                    break
            sched = "SCHED_FIFO" if pol else "default scheduling"
            rq0, m0 = run_delay_ns(gwl.pid), time.monotonic_ns()
            if c == 0:
                log(f"latency: {sched}, no Modbus load, {a.lat_phase:g} s"
                    + (", the bare baseline beside it" if pol is None else ""))
                t = time.time_ns()
                if pol is None:
                    self.bare = self.run_bare()
                else:
                    time.sleep(a.lat_phase)
                rq = (run_delay_ns(gwl.pid) - rq0) / (time.monotonic_ns() - m0) * 100
                windows.append((sched, "no Modbus load", t, time.time_ns(), rq))
                continue
            log(f"latency: {sched}, {c} Modbus clients, {a.lat_phase:g} s")
            t = time.time_ns()
            p = subprocess.Popen(self.load(gwl.port, c, reqs, a.lat_phase, f"lat/{c}"),
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            out, err = p.communicate(timeout=a.lat_phase + 60)
            try:
                res = json.loads(out)
            except json.JSONDecodeError:
                raise RuntimeError(f"gw_load lat/{c}: {err.strip()}")
            # the measured part of the load run: after its warm-up, 0.1 s margins
            rq = (run_delay_ns(gwl.pid) - rq0) / (time.monotonic_ns() - m0) * 100
            windows.append((sched, f"{c} Modbus clients ({res['rps'] / 1000:.0f}k req/s)",
                            t + int(0.7e9), t + int((0.5 + a.lat_phase - 0.1) * 1e9), rq))
        self.lat_link_down = gwl.log().count("link down:")
        self.lat_o2t_timeouts = sim.log().count("(O->T timeout)") - (
            self.enip_check["robot_o2t_timeouts"] if self.enip_check else 0)
        self.stop(gwl)
        samples = []
        with open(latfile) as f:
            for line in f:
                at, wake, vis = (int(x) for x in line.split())
                samples.append((at, wake, vis))
        self.lat = []
        for sched, name, lo, hi, rq in windows:
            sel = [s for s in samples if lo <= s[0] < hi]
            xs = sorted((vis - at) / 1000.0 for at, wake, vis in sel)
            # in the loop: from the later of arrival and the loop's wake-up
            ys = sorted((vis - max(at, wake)) / 1000.0 for at, wake, vis in sel)
            self.lat.append((sched, name, len(xs), pct(xs, 50), pct(xs, 99), pct(xs, 99.9),
                             xs[-1] if xs else float("nan"), pct(ys, 99), rq))
        self.cleanup()
        self.load_after = os.getloadavg()
        self.elapsed = time.monotonic() - t_begin

    # ---- report --------------------------------------------------------------
    def table(self):
        med = {k: statistics.median(v) for k, v in getattr(self, "tput", {}).items()}
        rows = []

        def ok(x):
            return "met" if x else "MISSED"

        def ratio(a, b, c):
            return statistics.median(x / y for x, y in zip(self.tput[(a, c)], self.tput[(b, c)]))

        def spread(name, c):
            v = self.tput[(name, c)]
            return f"{min(v) / 1000:.1f}-{max(v) / 1000:.1f}k"

        if hasattr(self, "reqlog"):
            rows.append(self.reqlog_row(ok))
        if self.args.reqlog_only:
            return rows
        for c in CLIENTS if self.enip_check else ():
            r = ratio("gw", "plain", c)
            rows.append((f"FC03/FC04 req/s, {c} client{'s' if c > 1 else ''}: vs plain libmodbus",
                         f"{med[('gw', c)]:.0f} ({spread('gw', c)})",
                         f"{med[('plain', c)]:.0f} ({spread('plain', c)})",
                         f"{r:.2f}x", f">= {GOAL_PLAIN}x", ok(r >= GOAL_PLAIN)))
        for c in CLIENTS if self.enip_check else ():
            r = ratio("gw", "pymodbus", c)
            goal = c >= 8
            rows.append((f"FC03/FC04 req/s, {c} client{'s' if c > 1 else ''}: vs pymodbus {self.pymodbus_version}",
                         f"{med[('gw', c)]:.0f}",
                         f"{med[('pymodbus', c)]:.0f} ({spread('pymodbus', c)})",
                         f"{r:.2f}x", f">= {GOAL_PYMODBUS}x" if goal else "(none)",
                         ok(r >= GOAL_PYMODBUS) if goal else "-"))
        bare99 = self.bare["written"]["p99"]
        for i, (sched, name, n, p50, p99, p999, mx, loop99, rq) in enumerate(self.lat):
            # The goal is judged on the first phase (no Modbus load, the
            # daemon scheduled as it would be), against the bare baseline
            # run just before and just after the instrumented daemon; the
            # other phases are for insight.
            goal = i == 0
            r = p99 / bare99
            if goal:
                b = self.bare
                base = (f"bare UDP -> epoll -> shared memory, beside it: "
                        f"{b['written']['p99']:.0f} us (p50 {b['written']['p50']:.0f}, "
                        f"p99.9 {b['written']['p999']:.0f}, max {b['written']['max']:.0f}; "
                        f"the writer's part p99 {b['loop']['p99']:.0f}; read by the "
                        f"reader p99 {b['read']['p99']:.0f}; n={b['written']['n']})")
            else:
                base = ""
            rows.append((f"latency packet -> Modbus visible, p99, {name}, {sched}"
                         + (": vs the bare baseline" if goal else ""),
                         f"{p99:.0f} us (p50 {p50:.0f}, p99.9 {p999:.0f}, max {mx:.0f}; "
                         f"in the loop p99 {loop99:.0f}; waiting for a CPU {rq:.0f} % "
                         f"of the time; n={n})",
                         base, f"{r:.2f}x" if goal else "",
                         f"<= {GOAL_LAT_VS_BARE:g}x" if goal else "(info)",
                         ok(r <= GOAL_LAT_VS_BARE) if goal else "-"))
        if not self.enip_check:
            return rows
        rows.append(("RSS (VmRSS idle / VmHWM after the load runs)",
                     f"{self.rss_idle} kB / {self.rss_hwm} kB", "", "",
                     f"< {GOAL_RSS_KB} kB", ok(max(self.rss_idle, self.rss_hwm) < GOAL_RSS_KB)))
        rows.append((f"CPU, 6 connections at RPI {RPI_MS} ms, no Modbus load: vs drsim "
                     f"(the other end of the same connections)",
                     f"{self.cpu_pct:.2f} % (range {self.cpu_range[0]:.1f}-"
                     f"{self.cpu_range[1]:.1f}; utime+stime {self.cpu_ticks_pct:.1f} %; waiting "
                     f"for a CPU {self.idle_rq:.1f} % of the time; {self.wake_per_rpi:.2f} "
                     f"wake-ups per RPI)",
                     f"{self.sim_cpu_pct:.2f} % ({self.sim_wake_per_rpi:.2f} wake-ups per RPI)",
                     f"{self.cpu_vs_sim:.2f}x", f"<= {GOAL_CPU_VS_SIM:g}x",
                     ok(self.cpu_vs_sim <= GOAL_CPU_VS_SIM)))
        e = self.enip_check
        rows.append(("robot link during the Modbus load runs",
                     f"{e['link_down_logged']} losses ({e['robot_o2t_timeouts']} connections "
                     f"closed by the robot for want of O->T packets); {e['rx']} T->O packets, "
                     f"{e['lost']} lost", "", "", "(info)", "-"))
        return rows

    def missed(self):
        return [r[0] for r in self.table() if r[5] == "MISSED"]

    def reference_rows(self):
        med = {k: statistics.median(v) for k, v in self.tput.items()}
        def m(d, k):
            return statistics.median(d[k])
        return [(c, med[("plain", c)], med[("pymodbus", c)], m(self.tput_p50, ("gw", c)),
                 m(self.tput_lat, ("gw", c)), m(self.tput_p50, ("plain", c)),
                 m(self.tput_lat, ("plain", c)))
                for c in CLIENTS]

    def markdown(self):
        a = self.args
        rows = self.table()
        out = []
        out.append("| measure | drgatewayd | baseline | ratio | goal | result |")
        out.append("|---|---|---|---|---|---|")
        for r in rows:
            out.append("| " + " | ".join(r) + " |")
        if not self.enip_check:
            return "\n".join(out)
        out.append("")
        out.append("The baselines in absolute terms (req/s, medians; the issue measured "
                   "about 13.6k with 1 client and 67k with 8 or 64 for the plain server, "
                   "17k for pymodbus), and the request latency the load generator saw, "
                   "p50 / p99 (medians over the rounds):")
        out.append("")
        out.append("| clients | plain | pymodbus | drgatewayd p50 / p99 | plain p50 / p99 |")
        out.append("|---|---|---|---|---|")
        for c, pm, ym, g50, g99, p50, p99 in self.reference_rows():
            out.append(f"| {c} | {pm:.0f} | {ym:.0f} | "
                       f"{g50:.0f} / {g99:.0f} us | {p50:.0f} / {p99:.0f} us |")
        out.append("")
        e = self.enip_check
        out.append(f"Run: {datetime.datetime.now().strftime('%Y-%m-%d %H:%M')}, "
                   f"{os.cpu_count()} CPUs, Linux {platform.release()}, load average "
                   f"{self.load_before[0]:.2f} before / {self.load_after[0]:.2f} after, "
                   f"{a.rounds} rounds of {a.duration:g} s per figure, "
                   f"{self.elapsed:.0f} s in all. Request mix: {' and '.join(self.reqs)} "
                   f"(FC:address:count). During the load runs the robot link stayed "
                   f"{'up' if e['link_state'] == 2 and not e['link_down_logged'] else 'NOT up'}: "
                   f"{e['rx']} T->O packets received, {e['lost']} lost, "
                   f"{e['link_down_logged']} link losses ({e['robot_o2t_timeouts']} connections "
                   f"closed by the robot for want of O->T packets); during the latency runs "
                   f"{self.lat_link_down} link losses ({self.lat_o2t_timeouts} such closes).")
        if self.notes:
            out.append("")
            out.append("Notes: " + "; ".join(self.notes))
        if self.failures:
            out.append("")
            out.append("Failures: " + "; ".join(self.failures))
        return "\n".join(out)


DOC_INTRO = """<!-- SPDX-License-Identifier: MIT -->
# Performance

Measured by `make bench`. Each part of the project has its own section,
written by its own benchmark; numbers come from whatever machine ran it
last, so read them as ratios and orders of magnitude.
"""

DOC_METHOD = """## Gateway

`make bench-gw` (part of `make bench`; `make bench-gw GW_BENCH_ARGS=--write-doc`
rewrites the results below) runs `bench/gw_bench.py`, everything on loopback:
drsim plays the robot, drgatewayd keeps six Class 1 connections to it at
RPI 2 ms (`rpi_ms = 2`).

- **Throughput**: `bench/gw_load.c`, a C load generator (one epoll loop,
  each connection keeps one request outstanding), reads with FC03 and FC04
  in turn against drgatewayd (its six connections running), against a plain
  select-loop libmodbus server with the same register counts and no robot
  (`bench/gw_plain_server.c`) and against a pymodbus 3.8 asyncio server
  (`bench/gw_pymodbus_server.py`), with 1, 8 and 64 clients. The servers take
  turns, round after round (order rotated); figures are medians, the range
  across rounds is in brackets, ratios are medians of the per-round ratios.
  Every request reads 125 registers (the issue's figure): FC03 and FC04 in
  turn, where 125 registers of the gateway's map hold the most mapped ones
  (its reserved registers between blocks read 0).
- **Latency**: a build with `bench/gw_lat.c` (a link observer; not the
  installed daemon) records, for every T->O packet, the kernel's receive
  timestamp of the datagram (`SIOCGSTAMPNS`: the packet entering this host's
  network stack) and the moment its data is in the unit image every Modbus
  read answers from. That is the time the packet waits in the socket, for
  the loop to wake up or finish other work, plus its processing.
- **RSS**: VmRSS of the idle daemon, VmHWM after the load runs (both include
  the pages of the shared libraries it maps).
- **CPU**: the daemon's CPU time (`/proc/PID/schedstat`; utime+stime as a
  cross-check) over the idle period, as a share of one core, and drsim's over
  the same five windows: drsim is the other end of the same six connections
  (it receives the six O->T packets a period the daemon sends and sends the
  six T->O packets it receives), so the ratio, the median of the five
  windows', is the goal: at most 1.0x ("How the CPU goals are set"). The
  wake-ups per RPI of both (voluntary context switches) show why. On
  loopback each side's send also pays for delivering its packets into the
  other's socket.

The machine is shared (2 CPUs, other test runs going on), so the figures
move by 10-30 % from run to run; the interleaving keeps the ratios fairer
than the absolute numbers.
"""


BEGIN = "<!-- bench-gw results: begin (rewritten by make bench-gw GW_BENCH_ARGS=--write-doc) -->"
END = "<!-- bench-gw results: end -->"


def write_between(doc, begin, end, md, missing=None):
    """Replace what stands between the marker lines begin and end of doc
    with md (a blank line either side); the prose around them is written
    by hand. Without the markers, missing(text, block) gives the whole
    document (block: md with its markers), or without missing that is an
    error. Shared with gw_scale.py, which writes the same document."""
    text = open(doc).read() if os.path.exists(doc) else ""
    block = begin + "\n\n" + md + "\n\n" + end
    b, e = text.find(begin), text.find(end)
    if b >= 0 and e > b:
        text = text[:b] + block + text[e + len(end):]
    elif missing is not None and b < 0 and e < 0:
        text = missing(text, block)
    else:
        raise RuntimeError(f"{doc}: the markers {begin!r} and {end!r} are missing or out of order")
    with open(doc, "w") as f:
        f.write(text)


def write_doc(md):
    """The results of the Gateway section; a missing section is created."""
    def add_section(text, block):
        text = text or DOC_INTRO
        return text.rstrip("\n") + "\n\n" + DOC_METHOD + "\n### Results\n\n" + block + "\n"
    write_between(DOC, BEGIN, END, md, missing=add_section)


def run_or_report(bench, log):
    """bench.run(); when it raises: bench.cleanup(), the tail of each .log
    in bench.tmp on stderr, and FAILED through the bench's own log. False
    then (the bench exits 1), True when the run went through. Shared with
    console_bench.py."""
    try:
        bench.run()
        return True
    except Exception as e:  # noqa: BLE001 -- report, clean up, fail
        bench.cleanup()
        for p in os.listdir(bench.tmp):
            if p.endswith(".log"):
                sys.stderr.write(f"--- {p}\n" + open(os.path.join(bench.tmp, p)).read()[-2000:])
        log(f"FAILED: {e}")
        return False


def show_results(bench, write, log):
    """Print bench.markdown(), write it into DOC with write(md) when write
    is given (--write-doc), and log the goals bench.missed() names; returns
    those goals. Shared with console_bench.py."""
    md = bench.markdown()
    print()
    print(md)
    if write:
        write(md)
        log(f"written to {os.path.relpath(DOC, TOP)}")
    missed = bench.missed()
    if missed:
        log("goals MISSED: " + "; ".join(missed))
    return missed


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--duration", type=float, default=1.5, help="seconds per load run")
    ap.add_argument("--idle", type=float, default=10.0, help="seconds of the CPU measurement")
    ap.add_argument("--lat-phase", type=float, default=5.0, help="seconds per latency phase")
    ap.add_argument("--no-fifo", dest="fifo", action="store_false",
                    help="latency with default scheduling only (no chrt -f)")
    ap.add_argument("--gateway", help="drgatewayd to measure instead of the build's")
    ap.add_argument("--gateway-lat", help="instrumented drgatewayd instead of the build's")
    ap.add_argument("--python", default=sys.executable, help="Python with pymodbus 3.8")
    ap.add_argument("--write-doc", action="store_true", help=f"write the section into {DOC}")
    ap.add_argument("--latency-only", action="store_true",
                    help="only the latency part (for work on it; --write-doc refuses)")
    ap.add_argument("--reqlog-only", action="store_true",
                    help="only the Modbus request log's cost (--write-doc refuses)")
    ap.add_argument("--quick", action="store_true", help="1 round of 1 s (a smoke test)")
    args = ap.parse_args()
    if args.quick:
        args.rounds, args.duration, args.idle, args.lat_phase = 1, 1.0, 3.0, 2.0
    if (args.latency_only or args.reqlog_only) and args.write_doc:
        ap.error("--write-doc needs the whole run")
    b = Bench(args)
    if not run_or_report(b, log):
        return 1
    shutil.rmtree(b.tmp, ignore_errors=True)
    missed = show_results(b, write_doc if args.write_doc else None, log)
    return 1 if b.failures or missed else 0


if __name__ == "__main__":
    sys.exit(main())
