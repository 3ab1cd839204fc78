# SPDX-License-Identifier: MIT
"""Processes for the quality tests (tests/soak/soak.py,
tests/valgrind/scenario.py): drsim on 127.0.0.2 and drgatewayd on
127.0.0.1, each on free ports, optionally run under a wrapper such as
valgrind; their logs go to files; nothing outlives the test.

Only the standard library here; the Modbus clients are pymodbus (from
.venv, tests/requirements.txt) in the tests themselves.
"""
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

SIM_ADDR = "127.0.0.2"  # drsim
GW_ADDR = "127.0.0.1"   # drgatewayd: Modbus and its Class 1 socket


def log(msg):
    print(msg, flush=True)


def wait_for(cond, seconds, what, interval=0.05):
    """Polls cond() until it returns something true; returns it. Raises
    after `seconds`."""
    deadline = time.monotonic() + seconds
    last = None
    while True:
        try:
            v = cond()
            if v:
                return v
        except OSError as e:  # a peer still starting
            last = e
        if time.monotonic() > deadline:
            raise TimeoutError("timed out after %.0f s waiting for %s%s" % (
                seconds, what, " (last error: %s)" % last if last else ""))
        time.sleep(interval)


# Free ports and children that die with the test: the gateway suite's
# helpers (tests/gateway/gwlib.py), one copy for both.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "gateway"))
from gwlib import _die_with_parent, free_port  # noqa: E402


_procs = []


class Proc:
    """One child process with its output in a log file."""

    def __init__(self, argv, log_path):
        self.argv = [str(a) for a in argv]
        self.log_path = Path(log_path)
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.log_path, "wb") as f:
            self.p = subprocess.Popen(self.argv, stdin=subprocess.DEVNULL, stdout=f,
                                      stderr=subprocess.STDOUT,
                                      preexec_fn=_die_with_parent)
        _procs.append(self)

    @property
    def pid(self):
        return self.p.pid

    def alive(self):
        return self.p.poll() is None

    def log(self):
        try:
            return self.log_path.read_text(errors="replace")
        except FileNotFoundError:
            return ""

    def stop(self, seconds, sig=signal.SIGTERM):
        """Sends sig and waits; returns the exit status, None if it had to
        be killed."""
        if self.p.poll() is not None:
            return self.p.returncode
        self.p.send_signal(sig)
        try:
            return self.p.wait(seconds)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()
            return None


def kill_all():
    for pr in _procs:
        if pr.p.poll() is None:
            pr.p.kill()
            pr.p.wait()


def start_drsim(drsim, logdir, name, extra=(), wrapper=(), seconds=10):
    """drsim -v on SIM_ADDR, free ports; returns (proc, tcp, udp)."""
    for _ in range(10):
        tcp = free_port(SIM_ADDR)
        udp = free_port(SIM_ADDR, tcp=False)
        pr = Proc(list(wrapper) + [drsim, "-a", SIM_ADDR, "-p", tcp, "-u", udp, "-v"]
                  + list(extra), Path(logdir) / ("%s.drsim.log" % name))
        wait_for(lambda: not pr.alive() or "listening on" in pr.log(), seconds,
                 "drsim to listen")
        if pr.alive():
            return pr, tcp, udp
        time.sleep(0.2)  # a port taken meanwhile: new ones
    raise RuntimeError("drsim did not start: %s" % pr.log()[-2000:])


def gateway_config(port, sim_tcp, sim_udp, local_udp, robot_extra="", modbus_extra=""):
    """One robot (drsim), no GPIO."""
    return ("; written by tests/soak/harness.py\n"
            "[daemon]\nlog_level = info\n\n"
            "[modbus]\nlisten = %s\nport = %d\n%s\n\n"
            "[robot r1]\nhost = %s\ntcp_port = %d\nudp_port = %d\n"
            "local_address = %s\nlocal_udp_port = %d\nunit_id = 1\n%s\n"
            % (GW_ADDR, port, modbus_extra, SIM_ADDR, sim_tcp, sim_udp, GW_ADDR,
               local_udp, robot_extra))


def modbus_up(port):
    try:
        socket.create_connection((GW_ADDR, port), timeout=2).close()
        return True
    except OSError:
        return False


def start_gateway(drgatewayd, logdir, name, sim_tcp, sim_udp, robot_extra="",
                  modbus_extra="", wrapper=(), seconds=10):
    """drgatewayd -c (a config written here); returns (proc, port, conf)."""
    for _ in range(10):
        port = free_port(GW_ADDR, udp=False)
        local_udp = free_port(GW_ADDR, tcp=False)
        conf = Path(logdir) / ("%s.ini" % name)
        conf.write_text(gateway_config(port, sim_tcp, sim_udp, local_udp,
                                       robot_extra, modbus_extra))
        pr = Proc(list(wrapper) + [drgatewayd, "-c", conf],
                  Path(logdir) / ("%s.gateway.log" % name))
        wait_for(lambda: not pr.alive() or modbus_up(port), seconds,
                 "drgatewayd to listen")
        if pr.alive():
            return pr, port, conf
        if "cannot" not in pr.log():
            raise RuntimeError("drgatewayd exited: %s" % pr.log()[-2000:])
        time.sleep(0.2)
    raise RuntimeError("drgatewayd did not start: %s" % pr.log()[-2000:])


def fd_count(pid):
    return len(os.listdir("/proc/%d/fd" % pid))


def rss_kb(pid):
    for line in Path("/proc/%d/status" % pid).read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


def append_result(results, passed, failed, label):
    if results:
        Path(results).parent.mkdir(parents=True, exist_ok=True)
        with open(results, "a") as f:
            f.write("%d %d %s\n" % (passed, failed, label))
