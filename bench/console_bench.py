#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The console's cost (issue 21), run by `make bench-console` (in `make bench`).

Everything on loopback, drsim as the robot at RPI 2 ms (as bench/gw_bench.py),
drgatewayd with [http]:

1. Ten live robot pages: ten Server-Sent Event streams of
   /api/v1/events?robot=NAME read to the end of every event, each with the
   page's own poll of /api/v1/robots/NAME every 2 s (what
   gateway/http/www/console.js asks while a robot page is open). Plain
   readers, not ten chromium tabs: the tabs would cost this 2-CPU machine
   more than the daemon does and take its CPU away, so the daemon's figures
   would measure chromium; what the daemon sees from a tab is exactly these
   requests. The pages' readers run in this process (one selector loop).
2. The daemon's CPU (/proc/PID/schedstat, as gw_bench.py), idle (no Modbus
   load), without and with the ten pages, in alternating windows; the rise
   is the difference of the medians, in % of one core. Goal: < 1 %.
3. The Modbus request latency, p99, from bench/gw_load (one client, FC03
   and FC04 reads of 125 registers, as gw_bench.py), without and with the
   ten pages, rounds alternating; ratio of the medians. Goal: <= 1.2x.
4. Without [http]: the daemon's own memory (RssAnon) against the same
   daemon built from the tree before the console (--baseline), and whether
   libmicrohttpd is mapped (/proc/PID/maps): goal: not mapped, RssAnon
   within 2 %. VmRSS is shown too: it adds file pages of the binary,
   shared with the page cache, which a larger binary shows more of. With
   [http] for comparison, which maps it.

usage: console_bench.py --build DIR [--baseline DRGATEWAYD] [--rounds N]
                        [--window S] [--write-doc] [--quick]
"""
import argparse
import datetime
import os
import platform
import selectors
import socket
import statistics
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gw_bench  # noqa: E402  (the gateway bench's processes, ports and measures)
from gw_bench import GW_ADDR, SIM_ADDR, cpu_ns, free_port, status_kb, wait_for  # noqa: E402

TOP = gw_bench.TOP
DOC = os.path.join(TOP, "docs", "performance.md")
PAGES = 10
RPI_MS = 2
GOAL_CPU_RISE = 1.0   # % of one core
GOAL_P99_RATIO = 1.2
GOAL_RSS_RATIO = 1.02
BEGIN = "<!-- bench-console results: begin (rewritten by make bench-console CONSOLE_BENCH_ARGS=--write-doc) -->"
END = "<!-- bench-console results: end -->"


def log(msg):
    print(f"bench-console: {msg}", flush=True)


class Pages:
    """n robot pages' traffic: an SSE stream each, and the page's poll of
    its robot every 2 s. Counts the events and bytes received."""

    def __init__(self, port, robot, n):
        self.port, self.robot, self.n = port, robot, n
        self.events = self.bytes = self.polls = 0
        self.stop_flag = False
        self.sel = selectors.DefaultSelector()
        self.thread = threading.Thread(target=self.run, daemon=True)

    def request(self, path):
        s = socket.create_connection((GW_ADDR, self.port), timeout=5)
        s.sendall((f"GET {path} HTTP/1.1\r\nHost: {GW_ADDR}\r\nAccept: text/event-stream\r\n"
                   "Cache-Control: no-cache\r\n\r\n").encode())
        s.setblocking(False)
        return s

    def poll_once(self):
        s = socket.create_connection((GW_ADDR, self.port), timeout=5)
        s.sendall((f"GET /api/v1/robots/{self.robot} HTTP/1.1\r\nHost: {GW_ADDR}\r\n"
                   "Connection: close\r\n\r\n").encode())
        while s.recv(65536):
            pass
        s.close()
        self.polls += 1

    def start(self):
        for _ in range(self.n):
            s = self.request(f"/api/v1/events?robot={self.robot}")
            self.sel.register(s, selectors.EVENT_READ, bytearray())
        self.thread.start()
        return self

    def run(self):
        next_poll = [time.monotonic() + 2.0 * i / self.n for i in range(self.n)]
        while not self.stop_flag:
            now = time.monotonic()
            for i in range(self.n):
                if now >= next_poll[i]:
                    next_poll[i] = now + 2.0
                    try:
                        self.poll_once()
                    except OSError:
                        pass
            for key, _ in self.sel.select(timeout=0.05):
                try:
                    data = key.fileobj.recv(262144)
                except BlockingIOError:
                    continue
                except OSError:
                    data = b""
                if not data:
                    self.sel.unregister(key.fileobj)
                    key.fileobj.close()
                    continue
                self.bytes += len(data)
                buf = key.data
                buf += data
                # every event read to its end (the blank line), as a page does
                while True:
                    i = buf.find(b"\n\n")
                    if i < 0:
                        break
                    if b"event: values" in buf[:i]:
                        self.events += 1
                    del buf[:i + 2]

    def stop(self):
        self.stop_flag = True
        self.thread.join(5)
        for key in list(self.sel.get_map().values()):
            key.fileobj.close()
        self.sel.close()


def mapped(pid, lib):
    with open(f"/proc/{pid}/maps") as f:
        return any(lib in line for line in f)


class Bench:
    def __init__(self, args):
        self.args = args
        b = args.build if os.path.isabs(args.build) else os.path.join(TOP, args.build)
        self.gw = os.path.join(b, "drgatewayd")
        self.sim_bin = os.path.join(b, "drsim")
        self.load_bin = os.path.join(b, "bench", "gw_load")
        self.tmp = tempfile.mkdtemp(prefix="bench-console-")
        self.procs = []
        self.notes = []

    def start(self, name, argv):
        p = gw_bench.Proc(name, argv, self.tmp)
        self.procs.append(p)
        return p

    def cleanup(self):
        for p in reversed(self.procs):
            p.stop()
        self.procs = []

    def gateway(self, binary, name, http):
        mb = free_port(GW_ADDR, [socket.SOCK_STREAM])
        udp = free_port(GW_ADDR, [socket.SOCK_DGRAM])
        ini = os.path.join(self.tmp, name + ".ini")
        text = f"""[modbus]
listen = {GW_ADDR}
port = {mb}

[robot arm1]
host = {SIM_ADDR}
tcp_port = {self.sim_tcp}
udp_port = {self.sim_udp}
local_address = {GW_ADDR}
local_udp_port = {udp}
rpi_ms = {RPI_MS}
"""
        http_port = None
        if http:
            http_port = free_port(GW_ADDR, [socket.SOCK_STREAM])
            text += f"\n[http]\nlisten = {GW_ADDR}\nport = {http_port}\n"
        with open(ini, "w") as f:
            f.write(text)
        p = self.start(name, [binary, "-c", ini])
        p.port, p.http = mb, http_port
        wait_for(f"{name}: link up", lambda: "link up" in p.log() or not p.alive(), 20)
        if not p.alive():
            raise RuntimeError(f"{name} exited:\n{p.log()}")
        wait_for(f"{name}: Modbus port", lambda: gw_bench.accepts(mb))
        return p

    def cpu_window(self, pid, seconds):
        t0, c0 = time.monotonic(), cpu_ns(pid)
        time.sleep(seconds)
        return (cpu_ns(pid) - c0) / 1e9 / (time.monotonic() - t0) * 100

    def p99(self, port, seconds):
        import json
        import subprocess
        argv = [self.load_bin, "-H", GW_ADDR, "-p", str(port), "-c", "1", "-d", str(seconds),
                "-w", "0.3", "-l", "console"]
        for r in self.reqs:
            argv += ["-r", r]
        out = subprocess.run(argv, capture_output=True, text=True, timeout=seconds + 60)
        res = json.loads(out.stdout)
        if res["errors"]:
            raise RuntimeError(f"gw_load: {res['errors']} bad answers")
        return res["p99_us"], res["p50_us"], res["rps"]

    def run(self):
        a = self.args
        t_begin = time.monotonic()
        self.load_before = os.getloadavg()
        self.sim_tcp = free_port(SIM_ADDR, [socket.SOCK_STREAM, socket.SOCK_DGRAM])
        self.sim_udp = free_port(SIM_ADDR, [socket.SOCK_DGRAM])
        self.reqs = gw_bench.read_windows(self.gw)
        sim = self.start("drsim", [self.sim_bin, "--address", SIM_ADDR, "--tcp-port",
                                   str(self.sim_tcp), "--udp-port", str(self.sim_udp)])
        time.sleep(0.3)

        # 4. RSS and libraries: without [http] (this build and the one
        # before the console), then with it; each started three times in
        # turn (a file-backed page is counted where the kernel happened to
        # map it with its neighbours), the medians
        self.rss = {}
        runs = [r for r in (("no [http]", self.gw, False),
                            ("before the console", a.baseline, False),
                            ("[http], no page open", self.gw, True)) if r[1]]
        samples = {r[0]: [] for r in runs}
        for _ in range(3):
            for label, binary, http in runs:
                g = self.gateway(binary, "rss", http)
                time.sleep(a.window)
                samples[label].append((status_kb(g.pid, "VmRSS"), status_kb(g.pid, "RssAnon"),
                                       mapped(g.pid, "libmicrohttpd")))
                g.stop()
                self.procs.remove(g)
        for label, xs in samples.items():
            self.rss[label] = (statistics.median(x[0] for x in xs),
                               statistics.median(x[1] for x in xs), any(x[2] for x in xs))
            log(f"{label}: VmRSS {self.rss[label][0]:.0f} kB (RssAnon {self.rss[label][1]:.0f} kB), "
                f"libmicrohttpd {'mapped' if self.rss[label][2] else 'not mapped'}")

        # 1-3. with [http], pages off and on in turn
        g = self.gateway(self.gw, "drgatewayd", True)
        time.sleep(1.0)
        cpu = {False: [], True: []}
        lat = {False: [], True: []}
        self.events_per_s = []
        for rnd in range(a.rounds):
            for on in ((False, True) if rnd % 2 == 0 else (True, False)):
                pages = Pages(g.http, "arm1", PAGES).start() if on else None
                if on:
                    time.sleep(1.0)  # the first events (every value) are through
                    e0, t0 = pages.events, time.monotonic()
                cpu[on].append(self.cpu_window(g.pid, a.window))
                lat[on].append(self.p99(g.port, a.window))
                if on:
                    self.events_per_s.append((pages.events - e0) / (time.monotonic() - t0))
                    pages.stop()
                    time.sleep(0.5)
                log(f"round {rnd + 1}/{a.rounds}, {'10 pages' if on else 'no page'}: CPU "
                    f"{cpu[on][-1]:.2f} %, Modbus p99 {lat[on][-1][0]:.0f} us")
        self.rss_pages = status_kb(g.pid, "VmRSS")
        self.cpu = {k: statistics.median(v) for k, v in cpu.items()}
        self.cpu_all = cpu
        self.lat = {k: statistics.median(x[0] for x in v) for k, v in lat.items()}
        self.lat50 = {k: statistics.median(x[1] for x in v) for k, v in lat.items()}
        self.lat_all = lat
        self.cleanup()
        self.load_after = os.getloadavg()
        self.elapsed = time.monotonic() - t_begin

    def table(self):
        def ok(x):
            return "met" if x else "MISSED"
        rows = []
        rise = self.cpu[True] - self.cpu[False]
        ev = statistics.median(self.events_per_s) if self.events_per_s else 0.0
        rows.append((f"CPU with {PAGES} live robot pages, no Modbus load: rise",
                     f"{rise:+.2f} % of a core ({self.cpu[False]:.2f} % -> {self.cpu[True]:.2f} %; "
                     f"{ev:.1f} value events/s received by the pages)",
                     f"< {GOAL_CPU_RISE:g} %", ok(rise < GOAL_CPU_RISE)))
        r = self.lat[True] / self.lat[False]
        rows.append((f"Modbus request p99 (1 client, FC03/FC04 x125) with {PAGES} pages",
                     f"{self.lat[True]:.0f} us vs {self.lat[False]:.0f} us without: {r:.2f}x "
                     f"(p50 {self.lat50[True]:.0f} vs {self.lat50[False]:.0f} us)",
                     f"<= {GOAL_P99_RATIO:g}x", ok(r <= GOAL_P99_RATIO)))
        no = self.rss.get("no [http]")
        base = self.rss.get("before the console")
        if no:
            rows.append(("libmicrohttpd mapped without [http]", "yes" if no[2] else "no",
                         "no", ok(not no[2])))
        if no and base:
            # The goal is on the daemon's own memory (RssAnon): VmRSS adds
            # the file pages of the binary and its libraries, which the
            # kernel maps in runs around each page touched (fault-around)
            # and shares with the page cache; a larger binary shows more of
            # them without costing memory (docs/performance.md).
            ra = no[1] / base[1]
            rows.append(("Own memory (RssAnon) without [http] vs the daemon before the console",
                         f"{no[1]:.0f} kB vs {base[1]:.0f} kB ({ra:.3f}x, {no[1] - base[1]:+.0f} kB)",
                         f"<= {GOAL_RSS_RATIO:g}x", ok(ra <= GOAL_RSS_RATIO)))
            rows.append(("VmRSS without [http] vs the daemon before the console",
                         f"{no[0]:.0f} kB vs {base[0]:.0f} kB ({no[0] / base[0]:.3f}x; file pages "
                         f"{no[0] - no[1]:.0f} vs {base[0] - base[1]:.0f} kB)", "(info)", "-"))
        h = self.rss.get("[http], no page open")
        if h:
            rows.append(("VmRSS with [http] (libmicrohttpd "
                         f"{'mapped' if h[2] else 'NOT mapped'}), no page / {PAGES} pages",
                         f"{h[0]:.0f} kB / {self.rss_pages} kB", "(info)", "-"))
        return rows

    def markdown(self):
        out = ["| measure | result | goal | |", "|---|---|---|---|"]
        for r in self.table():
            out.append("| " + " | ".join(r) + " |")
        out.append("")
        out.append(f"Run: {datetime.datetime.now().strftime('%Y-%m-%d %H:%M')}, "
                   f"{os.cpu_count()} CPUs, Linux {platform.release()}, load average "
                   f"{self.load_before[0]:.2f} before / {self.load_after[0]:.2f} after; "
                   f"{self.args.rounds} rounds of {self.args.window:g} s windows (CPU, then "
                   f"p99), pages off and on in turn; {self.elapsed:.0f} s in all. "
                   f"CPU per window without / with pages: "
                   f"{', '.join('%.2f' % x for x in self.cpu_all[False])} / "
                   f"{', '.join('%.2f' % x for x in self.cpu_all[True])} %; p99: "
                   f"{', '.join('%.0f' % x[0] for x in self.lat_all[False])} / "
                   f"{', '.join('%.0f' % x[0] for x in self.lat_all[True])} us.")
        if self.notes:
            out.append("")
            out.append("Notes: " + "; ".join(self.notes))
        return "\n".join(out)

    def missed(self):
        return [r[0] for r in self.table() if r[3] == "MISSED"]


DOC_SECTION = """## Console

`make bench-console` (part of `make bench`; `make bench-console
CONSOLE_BENCH_ARGS=--write-doc` rewrites the results below) runs
`bench/console_bench.py`: drsim at RPI 2 ms and drgatewayd with `[http]`, on
loopback.

- **Ten live robot pages** are ten Server-Sent Event streams
  (`/api/v1/events?robot=NAME`, every event read to its end) plus each page's
  poll of `/api/v1/robots/NAME` every 2 s: what a robot page asks of the
  daemon. Plain readers in the benchmark's own process, not ten headless
  chromium tabs: on this 2-CPU machine the tabs would take more CPU than the
  daemon and leave it less, so the figures would measure chromium, while the
  daemon sees the same requests either way.
- **CPU**: the daemon's CPU time (`/proc/PID/schedstat`, as the gateway
  bench) with no Modbus load, in windows with and without the pages, in
  turn; the rise is the difference of the medians.
- **Modbus p99**: `bench/gw_load` with one client (FC03 and FC04 reads of 125
  registers, as the gateway bench), with and without the pages, in turn.
- **Without `[http]`**: VmRSS of the daemon with no `[http]` section against
  the daemon built from the tree just before the console
  (`$(B)/bench/noconsole/drgatewayd`), and whether libmicrohttpd is in its
  `/proc/PID/maps`.

"""


def write_doc(md):
    def add_section(text, block):
        return text.rstrip("\n") + "\n\n" + DOC_SECTION + "### Results\n\n" + block + "\n"
    gw_bench.write_between(DOC, BEGIN, END, md, missing=add_section)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--baseline", help="drgatewayd built from the tree before the console")
    ap.add_argument("--rounds", type=int, default=10,
                    help="rounds of windows, pages off and on in turn (p99s of ~150 us on a "
                    "shared 2-core machine vary by 30 %% window to window: 6 rounds were not "
                    "enough for a stable median)")
    ap.add_argument("--window", type=float, default=3.0, help="seconds per measurement")
    ap.add_argument("--write-doc", action="store_true", help=f"write the results into {DOC}")
    ap.add_argument("--quick", action="store_true", help="2 rounds of 1.5 s (a smoke test)")
    args = ap.parse_args()
    if args.quick:
        args.rounds, args.window = 2, 1.5
    b = Bench(args)
    if not gw_bench.run_or_report(b, log):
        return 1
    missed = gw_bench.show_results(b, write_doc if args.write_doc else None, log)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
