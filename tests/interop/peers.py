# SPDX-License-Identifier: MIT
"""Shared helpers for the interoperability tests (tests/interop/).

Everything here is bounded in time: starting a peer waits at most a few
seconds for it to accept connections, stopping one sends SIGTERM and then
SIGKILL, and every subprocess runs under a timeout.

The two ends share this machine without root, as on an integrator's laptop:
drsim (or cpppo) listens on 127.0.0.2 / 127.0.0.3, the originator on
127.0.0.1, and every port is a free one picked at run time, so that several
builds can run `make check` at once. The Class 1 ports are announced through
the socket address items (0x8000 / 0x8001) of the Forward Open.
"""
import contextlib
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
TOP = os.path.dirname(os.path.dirname(HERE))

SIM_ADDR = "127.0.0.2"   # drsim, the adapter
PEER_ADDR = "127.0.0.3"  # cpppo's server
LOCAL_ADDR = "127.0.0.1" # originators

# The robot's ten assemblies, from the vendor specification (see
# docs/assemblies.md): name, default instance, direction, size in bytes.
# Written out here on purpose rather than read from our codec: the point
# of these tests is to check our code against something that is not it.
ASSEMBLIES = [
    ("io_state", 101, "T->O", 36),
    ("joint_state", 102, "T->O", 144),
    ("task_state", 103, "T->O", 96),
    ("bit_out", 104, "T->O", 8),
    ("int_out", 105, "T->O", 96),
    ("float_out", 106, "T->O", 96),
    ("io_control", 107, "O->T", 12),
    ("bit_in", 108, "O->T", 8),
    ("int_in", 109, "O->T", 96),
    ("float_in", 110, "O->T", 96),
]
ASM = {name: (inst, direction, size) for name, inst, direction, size in ASSEMBLIES}


def build_dir():
    """The build directory ($(B)), from DRGATE_BUILD or ./build."""
    return os.environ.get("DRGATE_BUILD", os.path.join(TOP, "build"))


def drsim_path():
    return os.environ.get("DRSIM", os.path.join(build_dir(), "drsim"))


def free_port(addr, tcp_and_udp=True):
    """A port free on `addr` for TCP (and UDP too, if asked), chosen by
    the kernel. Another program could take it before we use it; the
    callers retry once on a bind failure."""
    for _ in range(50):
        t = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            t.bind((addr, 0))
            port = t.getsockname()[1]
            if not tcp_and_udp:
                return port
            u = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                u.bind((addr, port))
                return port
            except OSError:
                continue
            finally:
                u.close()
        finally:
            t.close()
    raise RuntimeError("no free port on %s" % addr)


def wait_tcp(addr, port, proc=None, timeout=10.0):
    """Wait until something accepts TCP on addr:port (or proc exits)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc is not None and proc.poll() is not None:
            return False
        with contextlib.closing(socket.socket(socket.AF_INET, socket.SOCK_STREAM)) as s:
            s.settimeout(0.5)
            try:
                s.connect((addr, port))
                return True
            except OSError:
                pass
        time.sleep(0.05)
    return False


def stop(proc, timeout=5.0):
    """SIGTERM, wait, then SIGKILL. Returns the exit status."""
    if proc is None or proc.poll() is not None:
        return None if proc is None else proc.returncode
    proc.send_signal(signal.SIGTERM)
    try:
        return proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.wait(timeout=timeout)


class Server:
    """A peer process (drsim, cpppo) on addr with a TCP port; its output
    goes to a log file that is shown when something fails."""

    def __init__(self, name, argv, addr, tcp_port, ready_timeout=10.0):
        self.name = name
        self.addr = addr
        self.tcp_port = tcp_port
        fd, self.log_path = tempfile.mkstemp(prefix="drgate-%s-" % name, suffix=".log")
        self.log = os.fdopen(fd, "w")
        self.proc = subprocess.Popen(argv, stdout=self.log, stderr=subprocess.STDOUT,
                                     stdin=subprocess.DEVNULL, start_new_session=True)
        if not wait_tcp(addr, tcp_port, self.proc, ready_timeout):
            self.stop()
            raise RuntimeError("%s did not start (%s):\n%s" % (name, " ".join(argv), self.log_text()))

    def log_text(self):
        self.log.flush()
        with open(self.log_path, errors="replace") as f:
            return f.read()[-4000:]

    def alive(self):
        return self.proc.poll() is None

    def stop(self):
        rc = stop(self.proc)
        self.log.close()
        return rc

    def cleanup(self):
        with contextlib.suppress(OSError):
            os.unlink(self.log_path)


class Drsim(Server):
    """drsim on 127.0.0.2 with free ports: tcp_port (encapsulation, TCP and
    UDP) and udp_port (Class 1)."""

    def __init__(self, *extra, verbose=True):
        path = drsim_path()
        if not os.access(path, os.X_OK):
            raise RuntimeError("no drsim at %s (build it first)" % path)
        last = None
        for _ in range(3):  # a port taken between choosing and binding
            tcp = free_port(SIM_ADDR)
            udp = free_port(SIM_ADDR, tcp_and_udp=True)
            if udp == tcp:
                continue
            self.udp_port = udp
            argv = [path, "--address", SIM_ADDR, "--tcp-port", str(tcp),
                    "--udp-port", str(udp)] + (["-v"] if verbose else []) + list(extra)
            try:
                Server.__init__(self, "drsim", argv, SIM_ADDR, tcp)
                return
            except RuntimeError as e:
                last = e
        raise last


def run(argv, timeout, **kw):
    """subprocess.run with a timeout and captured text output."""
    return subprocess.run(argv, timeout=timeout, capture_output=True, text=True, **kw)


def le_u16(b, off):
    return b[off] | b[off + 1] << 8
