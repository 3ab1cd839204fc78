# SPDX-License-Identifier: MIT
"""make bench-enip: EtherNet/IP speed, as ratios to baselines measured in
the same run (this machine is a small, noisy VM; absolute figures mean
little, ratios do). docs/performance.md explains the method and results.

Explicit messaging: Get_Attribute_Single round trips per second against
drsim (io_state, instance 101), by
  - our client (bench/enip_gets.c),
  - a bare C TCP ping-pong of the same frame sizes on loopback
    (bench/pingpong.c): the physical limit,
  - pycomm3 (generic_message, unconnected, no route path), in this process.
The three stay connected and take turns in short slices (ROUNDS rounds of
one SECONDS slice each, the order rotating), so that a busy neighbour hits
all three alike; each round gives two ratios, and the medians of the ratios
are compared with the goals (>= 0.7x the ping-pong, >= 1.5x pycomm3).

Class 1: bench/enip_io.c, six connections at RPI 1 ms, with a bare
timerfd loop alongside, in IO_ROUNDS runs of IO_SECONDS each; goals, on
the medians of the per-run ratios (the two share the run's noise and the
host's cost of a wake-up): p99 deviation from the RPI <= 1.5x the timer's,
client CPU <= 4x the timer loop's (its bound: two wake-ups per RPI where
the timer loop has one, each moving six datagrams in one batched call
where the timer loop sends one; docs/performance.md, "How the CPU goals
are set"). The wake-ups per RPI of both are printed beside them. One long
run judged the timing on whichever
stream the VM happened to disturb: on a quiet host both p99 deviations are
10 to 60 us and each moves by 3x from run to run. Then, for information, the same
with o2t_follow_us (O->T sent with the T->O arrivals, drgatewayd's
default), and with the loop keeping the client's time (no timerfd, ppoll
to dr_client_next_deadline(), as drgatewayd's loop does).

usage: bench_enip.py BUILD_DIR        exit status 1 if a goal is missed
"""
import os
import select
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "interop"))
import peers  # noqa: E402

ROUNDS = int(os.environ.get("BENCH_ROUNDS", "15"))
SECONDS = float(os.environ.get("BENCH_SECONDS", "0.4"))
IO_SECONDS = float(os.environ.get("BENCH_IO_SECONDS", "3"))
IO_ROUNDS = int(os.environ.get("BENCH_IO_ROUNDS", "5"))
GOALS = {
    "gets_vs_pingpong": (">=", 0.7),
    "gets_vs_pycomm3": (">=", 1.5),
    "io_p99dev_vs_timerfd": ("<=", 1.5),
    "io_cpu_vs_timerfd": ("<=", 4.0),
}


def run(argv, timeout):
    r = subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
    if r.returncode != 0:
        raise RuntimeError("%s failed (%d): %s" % (" ".join(argv), r.returncode, r.stderr))
    return r.stdout


class Slicer:
    """A measuring program kept running (pingpong / enip_gets with SECONDS
    0): each slice() writes a duration and reads back one result line."""

    def __init__(self, argv):
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     text=True, bufsize=1)

    def line(self, timeout):
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        text = self.proc.stdout.readline() if ready else ""
        if not text:
            raise RuntimeError("%s: no answer" % " ".join(self.proc.args))
        return text.split()

    def slice(self, seconds):
        self.proc.stdin.write("%g\n" % seconds)
        self.proc.stdin.flush()
        return float(self.line(seconds + 20)[3])

    def close(self):
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()
        return self.proc.returncode


class Pycomm3:
    def __init__(self, path):
        from pycomm3 import CIPDriver, Services
        self.svc = Services.get_attribute_single
        self.drv = CIPDriver(path)
        self.drv.socket_timeout = 2.0
        self.drv.open()

    def slice(self, seconds):
        n = 0
        t0 = time.monotonic()
        t = t0
        while t - t0 < seconds:
            r = self.drv.generic_message(service=self.svc, class_code=4, instance=101,
                                         attribute=3, connected=False, route_path=False)
            if r.error is not None:
                raise RuntimeError("pycomm3: %s" % r.error)
            n += 1
            t = time.monotonic()
        return n / (t - t0)

    def close(self):
        self.drv.close()
        return 0


def explicit(build):
    """ROUNDS rounds; in each, one SECONDS slice of each of the three, in
    an order that rotates from round to round. The programs stay up (one
    session, one connection each) between slices."""
    sim = peers.Drsim(verbose=False)
    meters = []
    try:
        host, port = peers.SIM_ADDR, str(sim.tcp_port)
        ours = Slicer([os.path.join(build, "bench", "enip_gets"), host, port, "io_state", "0"])
        meters.append(ours)
        sizes = ours.line(20)
        req, rep = sizes[1], sizes[2]
        ping = Slicer([os.path.join(build, "bench", "pingpong"), peers.SIM_ADDR, req, rep, "0"])
        meters.append(ping)
        py = Pycomm3("%s:%s" % (host, port))
        meters.append(py)
        order = [("ping", ping), ("ours", ours), ("py", py)]
        for m in (ping, ours, py):  # warm up: connections, caches, CPU clock
            m.slice(0.2)
        rows = []
        for i in range(ROUNDS):
            r = {}
            for k in range(3):
                name, m = order[(i + k) % 3]
                r[name] = m.slice(SECONDS)
            rows.append(r)
            print("  round %2d: ping-pong %7.0f/s  ours %7.0f/s  pycomm3 %7.0f/s  "
                  "ours/ping-pong %.2f  ours/pycomm3 %.2f"
                  % (i + 1, r["ping"], r["ours"], r["py"], r["ours"] / r["ping"],
                     r["ours"] / r["py"]), flush=True)
    finally:
        bad = [m for m in meters if m.close() != 0]
        rc = sim.stop()
        sim.cleanup()
    if rc != 0 or bad:
        raise RuntimeError("drsim exited with %r, %d meter(s) failed" % (rc, len(bad)))
    med = lambda k: statistics.median(r[k] for r in rows)
    return {
        "frame_sizes": (int(req), int(rep)),
        "pingpong_per_s": med("ping"), "gets_per_s": med("ours"), "pycomm3_per_s": med("py"),
        "gets_vs_pingpong": statistics.median(r["ours"] / r["ping"] for r in rows),
        "gets_vs_pycomm3": statistics.median(r["ours"] / r["py"] for r in rows),
    }


def implicit(build, follow_us=0, loop=False):
    out = run([os.path.join(build, "bench", "enip_io"), str(IO_SECONDS), "6", "1000",
               str(follow_us)] + (["loop"] if loop else []), IO_SECONDS + 60)
    res = {"lines": []}
    for line in out.splitlines():
        res["lines"].append(line)
        w = line.split()
        if w[:3] == ["io", "cpu", "client"]:
            res["io_client_cpu_pct"] = float(w[3])
        elif w[:3] == ["io", "cpu", "timerfd"]:
            res["io_timerfd_cpu_pct"] = float(w[3])
        elif w[:3] == ["io", "cpu", "receiver"]:
            res["io_receiver_cpu_pct"] = float(w[3])
        elif w[:2] == ["io", "wakeups"]:
            res["wakeups_" + w[2]] = float(w[3])
        elif w[:2] == ["io", "timerfd"] or w[:2] == ["io", "client"] and w[3] == "n":
            kv = dict(zip(w[2 if w[1] == "timerfd" else 3::2], w[3 if w[1] == "timerfd" else 4::2]))
            res["timerfd" if w[1] == "timerfd" else "client"] = {k: float(v) for k, v in kv.items()}
        elif w[:3] == ["io", "client", "tx"]:
            res["client_counts"] = line
            res["timeouts"] = int(w[5])
    res["io_p99dev_vs_timerfd"] = res["client"]["dev_p99"] / max(res["timerfd"]["dev_p99"], 1e-3)
    res["io_cpu_vs_timerfd"] = res["io_client_cpu_pct"] / max(res["io_timerfd_cpu_pct"], 1e-3)
    return res


def verdict(name, value):
    op, goal = GOALS[name]
    ok = {">=": value >= goal, "<=": value <= goal, "<": value < goal}[op]
    return ok, "%-22s %8.2f   goal %s %-5g %s" % (name, value, op, goal, "ok" if ok else "MISSED")


def main():
    build = sys.argv[1] if len(sys.argv) > 1 else os.path.join(peers.TOP, "build")
    print("bench-enip: %s, %d CPUs, load %s" % (os.uname().machine, os.cpu_count(),
                                                " ".join(open("/proc/loadavg").read().split()[:3])))
    print("explicit: Get_Attribute_Single io_state against drsim, %d rounds of %g s each" % (ROUNDS, SECONDS))
    ex = explicit(build)
    print("  frames %d / %d bytes; medians: ping-pong %.0f/s, ours %.0f/s, pycomm3 %.0f/s"
          % (ex["frame_sizes"] + (ex["pingpong_per_s"], ex["gets_per_s"], ex["pycomm3_per_s"])))
    print("class 1: 6 connections at RPI 1 ms, %d runs of %g s, a bare timerfd loop alongside"
          % (IO_ROUNDS, IO_SECONDS))
    runs = []
    for k in range(IO_ROUNDS):
        io = implicit(build)
        runs.append(io)
        if k == 0:
            for line in io["lines"]:
                print("  " + line)
    print("  run  interval (us)     p50      p99      max   dev p99  x timer    CPU %  x timer"
          "  wake-ups/RPI")
    for k, io in enumerate(runs):
        c, t = io["client"], io["timerfd"]
        print("  %d    client pooled %8.1f %8.1f %8.1f %8.1f %7.2f %8.2f %8.2f %8.2f"
              % (k + 1, c["p50"], c["p99"], c["max"], c["dev_p99"], io["io_p99dev_vs_timerfd"],
                 io["io_client_cpu_pct"], io["io_cpu_vs_timerfd"], io.get("wakeups_client", 0)))
        print("       bare timerfd  %8.1f %8.1f %8.1f %8.1f %16.2f %17.2f"
              % (t["p50"], t["p99"], t["max"], t["dev_p99"], io["io_timerfd_cpu_pct"],
                 io.get("wakeups_timerfd", 0)))
        if io.get("timeouts"):
            print("  NOTE: %d connection timeout(s) in run %d: the machine stalled for more "
                  "than 128 ms; the figures are of a disturbed run" % (io["timeouts"], k + 1))
    io = {"io_p99dev_vs_timerfd": statistics.median(r["io_p99dev_vs_timerfd"] for r in runs),
          "io_cpu_vs_timerfd": statistics.median(r["io_cpu_vs_timerfd"] for r in runs),
          "io_client_cpu_pct": statistics.median(r["io_client_cpu_pct"] for r in runs),
          "io_timerfd_cpu_pct": statistics.median(r["io_timerfd_cpu_pct"] for r in runs)}
    # The same with o2t_follow_us (drgatewayd's default): for information,
    # the trade it makes (fewer wake-ups, O->T timing that follows the
    # T->O arrivals); the goals are judged on the client's default above.
    fo = implicit(build, 250)
    print("  with o2t_follow_us = 250 (info): client CPU %.2f %% = %.2f x the bare timerfd "
          "loop's, %.2f wake-ups per RPI, dev p99 %.1f us = %.2f x the bare timerfd loop's"
          % (fo["io_client_cpu_pct"], fo["io_cpu_vs_timerfd"], fo.get("wakeups_client", 0),
             fo["client"]["dev_p99"], fo["io_p99dev_vs_timerfd"]))
    # Without the client's timerfd: one timerfd_settime per RPI fewer (4
    # system calls per period instead of 5), the same wake-ups.
    lo = implicit(build, 0, True)
    print("  with the loop's timer (info): client CPU %.2f %% = %.2f x the bare timerfd loop's, "
          "%.2f wake-ups per RPI, dev p99 %.1f us = %.2f x the bare timerfd loop's"
          % (lo["io_client_cpu_pct"], lo["io_cpu_vs_timerfd"], lo.get("wakeups_client", 0),
             lo["client"]["dev_p99"], lo["io_p99dev_vs_timerfd"]))
    print("results:")
    vals = {"gets_vs_pingpong": ex["gets_vs_pingpong"], "gets_vs_pycomm3": ex["gets_vs_pycomm3"],
            "io_p99dev_vs_timerfd": io["io_p99dev_vs_timerfd"],
            "io_cpu_vs_timerfd": io["io_cpu_vs_timerfd"]}
    missed = 0
    for name, v in vals.items():
        ok, text = verdict(name, v)
        missed += not ok
        print("  " + text)
    # the figures behind the CPU ratio, for the record (not goals: a
    # percentage of this host's core says more about the host than the code)
    print("  (client CPU %.2f %% of a core, the bare timerfd loop's %.2f %%: medians)"
          % (io["io_client_cpu_pct"], io["io_timerfd_cpu_pct"]))
    print("bench-enip: %s" % ("all goals met" if missed == 0 else "%d goal(s) missed" % missed))
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
