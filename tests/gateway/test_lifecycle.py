# SPDX-License-Identifier: MIT
"""Start-up and shutdown: SIGTERM/SIGINT close the robot connections with
Forward Close and exit 0 within a second; systemd's notify protocol
(READY, WATCHDOG while healthy, STOPPING) without systemd."""
import os
import signal
import socket
import time

import pytest

from gwlib import LOGDIR, Drsim, Gateway, running, timeout


@pytest.fixture
def pair(request):
    name = request.node.name.replace("[", "-").replace("]", "")
    with running(name, start=False) as g:
        yield g


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["TERM", "INT"])
def test_signal_stops_cleanly(pair, sig):
    g = pair
    g.start()
    with g.raw() as m:
        m.write_regs(400, [0x4000, 0])
    t0 = time.monotonic()
    g.signal(sig)
    rc = g.proc.wait(timeout(10))
    took = time.monotonic() - t0
    print("exit %d after %.3f s" % (rc, took))
    assert rc == 0
    assert took < timeout(1.0), "SIGTERM must stop the gateway within a second"
    log = g.sim.log()
    # drsim saw every connection closed by Forward Close, and the session end
    assert log.count("connection open") == 6
    assert log.count("closed (forward close)") == 6, log
    assert "unregistered" in log
    assert "stopped" in g.log()
    # a planned stop is no fault: info, with the reason (issue 11 item 4)
    assert "info: robot r0 (127.0.0.2): link down: gateway stopping" in g.log(), g.log()
    assert "warning" not in g.log(), g.log()


def test_sigterm_with_the_robot_gone(pair):
    g = pair
    g.start()
    g.sim.kill()
    g.wait_link(False)
    rc, took = g.stop()
    assert rc == 0
    assert took < timeout(1.0)


def test_sigterm_while_connecting():
    sim = Drsim("life-connecting")
    sim.tcp, sim.udp = 1, 1  # nothing listens there
    g = Gateway("life-connecting", sim)
    try:
        g.start(wait_link=False)
        assert g.status()[1] != 2
        rc, took = g.stop()
        assert rc == 0 and took < timeout(1.0)
    finally:
        g.kill()


def notify_socket(name):
    path = str(LOGDIR / ("%s.notify" % name))
    if os.path.exists(path):
        os.unlink(path)
    s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    s.bind(path)
    s.settimeout(0.1)
    return s, path


def messages(s, seconds, until=None):
    out = []
    deadline = time.monotonic() + timeout(seconds)
    while time.monotonic() < deadline:
        try:
            out.append(s.recv(4096).decode())
        except socket.timeout:
            continue
        if until and any(until in x for x in out):
            break
    return out


def test_systemd_notify(pair):
    """READY=1 once serving, WATCHDOG=1 at half the watchdog period while
    the loop runs, READY=1 again after a reload, STOPPING=1 on SIGTERM."""
    g = pair
    s, path = notify_socket("life-notify")
    env = dict(os.environ, NOTIFY_SOCKET=path, WATCHDOG_USEC="400000")
    try:
        g.start(wait_link=False, env=env)
        got = messages(s, 10, until="READY=1")
        assert "READY=1" in got, got
        got = messages(s, 3)
        assert got.count("WATCHDOG=1") >= 2, got  # 0.2 s apart: about 15 in 3 s
        g.signal(signal.SIGHUP)
        assert "READY=1" in messages(s, 10, until="READY=1")
        g.signal(signal.SIGTERM)
        got = messages(s, 10, until="STOPPING=1")
        assert "STOPPING=1" in got
        assert g.proc.wait(timeout(10)) == 0
    finally:
        s.close()
        os.unlink(path)


@pytest.mark.parametrize("journal", [False, True], ids=["stderr", "journal"])
def test_log_line_prefix(pair, journal):
    """Written to a file or a terminal (JOURNAL_STREAM unset), every line
    starts with the local time to the millisecond, then drgatewayd and the
    level; under systemd's journal, which stamps lines itself, with the
    "<N>" priority only."""
    import re
    g = pair
    env = {k: v for k, v in os.environ.items() if k != "JOURNAL_STREAM"}
    if journal:
        env["JOURNAL_STREAM"] = "8:12345"
    g.start(env=env)
    g.stop()
    lines = [l for l in g.log().splitlines() if l.strip()]
    assert len(lines) >= 3 and any("link up" in l for l in lines), lines
    if journal:
        bad = [l for l in lines if not re.match(r"<[3467]>\S", l)]
    else:
        stamp = r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} drgatewayd: (error|warning|info|debug): \S"
        bad = [l for l in lines if not re.match(stamp, l)]
    assert not bad, bad
