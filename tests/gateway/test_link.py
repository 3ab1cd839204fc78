# SPDX-License-Identifier: MIT
"""The robot link: loss is seen in the status block (and, by policy, in the
robot data), and the link comes back by itself when the robot does,
without restarting the gateway. Also explicit (polling) mode and two
robots on two unit IDs."""
import os
import platform
import re
import signal
import struct
import subprocess
import time

import pytest

from gwlib import (DRGATEWAYD, EX_TARGET_FAILED, GW_ADDR, INSTANCE, SCALE, SIM_ADDR, Drsim,
                   EnipReader, Gateway, dint_regs, free_port, running, timeout, wait_for)


def pwait2_kernel():
    """Linux 5.11 or later has epoll_pwait2."""
    rel = platform.release().split(".")
    try:
        return (int(rel[0]), int(rel[1].split("-")[0])) >= (5, 11)
    except (IndexError, ValueError):
        return False


def readlink_or(path):
    try:
        return os.readlink(path)
    except OSError:
        return ""


def uptime(g):
    st = g.status()
    return st[14] << 16 | st[15]


def int_out0(m, regmap, unit=1):
    a = regmap.addr("IR", "int_out[0]")
    return struct.unpack(">i", struct.pack(">HH", *m.read(4, a, 2, unit=unit)))[0]


def put_int_in0(m, regmap, v, unit=1):
    m.write_regs(regmap.addr("HR", "int_in[0]"), dint_regs(v, "abcd"), unit=unit)


@pytest.fixture
def pair(request):
    """A fresh drsim and gateway; the test's own modbus/robot settings."""
    marker = request.node.get_closest_marker("gw")
    kw = dict(marker.kwargs) if marker else {}
    name = request.node.name.replace("[", "-").replace("]", "")
    with running(name, **kw) as g:
        yield g


def lose_link(g):
    """SIGKILL drsim (no Forward Close) and wait until the status block
    says the link is down. Returns the seconds that took."""
    t0 = time.monotonic()
    g.sim.kill()
    g.wait_link(False)
    took = time.monotonic() - t0
    print("link loss seen after %.3f s" % took)
    return took


def restore_link(g):
    pid = g.proc.pid
    up0 = uptime(g)
    g.sim.start(same_ports=True)
    g.wait_link(True, seconds=60)
    assert g.alive() and g.proc.pid == pid
    assert uptime(g) >= up0  # the same process, never restarted


@pytest.mark.gw(robot="rpi_ms = 10\ntimeout_multiplier = 2\n")
def test_loss_and_recovery_hold(pair, regmap):
    g = pair
    with g.raw() as m:
        put_int_in0(m, regmap, 1111)
        wait_for(lambda: int_out0(m, regmap) == 1111, 10, "int_out[0] echo")
        lose_link(g)
        st = g.status()
        assert st[1] != 2 and st[2] == 0
        assert m.read(2, 0, 2) == [0, 0]
        assert [st[16 + i] for i in range(6)] != [2] * 6
        # hold: the last values stay readable, their age grows
        assert int_out0(m, regmap) == 1111
        assert m.read(4, regmap.addr("IR", "io_state.version.major"), 3) == [2, 12, 3]
        age = g.status()[3]
        wait_for(lambda: g.status()[3] > age, 10, "data age to grow")
        g.log_wait("link down")
        # writes while the robot is away are kept and sent when it is back
        put_int_in0(m, regmap, 2222)
        restore_link(g)
        wait_for(lambda: int_out0(m, regmap) == 2222, 20, "int_out[0] after recovery")
        assert g.status()[2] == 1 and m.read(2, 0, 2) == [1, 1]
        put_int_in0(m, regmap, 3333)
        wait_for(lambda: int_out0(m, regmap) == 3333, 10, "int_out[0] echo after recovery")
    assert g.log().count("link up") >= 2


@pytest.mark.gw(robot="rpi_ms = 10\ntimeout_multiplier = 0\n")
def test_timeout_detection_without_fin(pair, regmap):
    """A robot that stops answering (SIGSTOP: the TCP session stays open) is
    noticed by the Class 1 connection timeout, RPI x 4 here."""
    g = pair
    t0 = time.monotonic()
    g.sim.proc.send_signal(signal.SIGSTOP)
    try:
        g.wait_link(False)
        print("silent robot noticed after %.3f s" % (time.monotonic() - t0))
        # what timed out, said once ("timed out: timed out" before), and
        # how long the robot was silent: at least the timeout (more when the
        # machine is busy: the time waited is measured, not the timeout)
        said = wait_for(lambda: re.findall(r"\): timed out: no packet from the robot "
                                           r"for (\d+) ms", g.log()),
                        10, "the timeout named in the gateway's log")
        assert all(int(ms) >= 40 for ms in said), said
        assert "timed out: timed out" not in g.log()
    finally:
        g.sim.proc.send_signal(signal.SIGCONT)
    g.wait_link(True, seconds=60)
    with g.raw() as m:
        put_int_in0(m, regmap, -5)
        wait_for(lambda: int_out0(m, regmap) == -5, 10, "echo after the robot resumed")


@pytest.mark.gw(modbus="on_link_loss = zero\n")
def test_loss_zero(pair, regmap):
    g = pair
    ver = regmap.addr("IR", "io_state.version.major")
    with g.raw() as m:
        put_int_in0(m, regmap, 77)
        wait_for(lambda: int_out0(m, regmap) == 77, 10, "int_out[0] echo")
        lose_link(g)
        assert m.read(4, ver, 3) == [0, 0, 0]
        assert int_out0(m, regmap) == 0
        assert m.read(2, regmap.addr("DI", "io_state.servo_on"), 1) == [0]
        assert m.read(4, 32, 1) == [0x1234]  # test registers are not robot data
        assert m.read(4, 0, 1) == [1]
        # the O->T image is the gateway's own: not zeroed
        assert m.read(3, regmap.addr("HR", "int_in[0]"), 2) == dint_regs(77, "abcd")
        restore_link(g)
        wait_for(lambda: m.read(4, ver, 3) == [2, 12, 3], 20, "io_state after recovery")
        wait_for(lambda: int_out0(m, regmap) == 77, 20, "int_out[0] after recovery")


@pytest.mark.gw(modbus="on_link_loss = exception\n")
def test_loss_exception(pair, regmap):
    g = pair
    with g.raw() as m:
        lose_link(g)
        for fc, name in ((4, "io_state.cb_di"), (4, "joint_state.position[1]"),
                         (4, "float_out[0]"), (2, "io_state.cb_di[1]"), (2, "bit_out[0]")):
            area = "IR" if fc == 4 else "DI"
            e = regmap.entry(area, name)
            assert m.exception(bytes([fc]) + struct.pack(">HH", e["address"], e["count"])) \
                == EX_TARGET_FAILED, name
        sc = regmap.addr("IR", "float_out[0]", scaled=True)
        assert m.exception(bytes([4]) + struct.pack(">HH", sc, 1)) == EX_TARGET_FAILED
        # the status block and the test registers stay readable
        st = m.read(4, 0, 40)
        assert st[0] == 1 and st[1] != 2 and st[2] == 0 and st[32] == 0x1234
        assert m.read(2, 0, 4)[:2] == [0, 0]
        # the O->T image (holding registers, coils) is the gateway's own
        assert len(m.read(3, regmap.addr("HR", "float_in[0]"), 48)) == 48
        assert len(m.read(1, regmap.addr("CO", "bit_in[0]"), 64)) == 64
        put_int_in0(m, regmap, 9)
        restore_link(g)
        wait_for(lambda: int_out0(m, regmap) == 9, 20, "int_out[0] after recovery")


@pytest.mark.gw(robot="mode = explicit\nrpi_ms = 50\ntimeout_ms = 500\n")
def test_explicit_mode(pair, regmap):
    g = pair
    with g.raw() as m:
        st = m.read(4, 0, 40)
        assert st[5] == 50 and st[16:26] == [0] * 10  # no Class 1 connections
        rx = st[6] << 16 | st[7]
        put_int_in0(m, regmap, 424242)
        wait_for(lambda: int_out0(m, regmap) == 424242, 10, "echo through Set/Get_Attribute")
        m.write_coils(regmap.addr("CO", "bit_in[0]"), [1, 0, 1, 1])
        wait_for(lambda: m.read(2, regmap.addr("DI", "bit_out[0]"), 4) == [1, 0, 1, 1], 10,
                 "bit_out echo")
        wait_for(lambda: (lambda s: (s[6] << 16 | s[7]) > rx)(m.read(4, 0, 40)), 10,
                 "polls counted")
        assert m.read(4, regmap.addr("IR", "io_state.version.major"), 3) == [2, 12, 3]
        lose_link(g)
        restore_link(g)
        wait_for(lambda: int_out0(m, regmap) == 424242, 20, "int_out[0] after recovery")
    assert "connection open" not in g.sim.log()


@pytest.fixture
def two():
    sims = [Drsim("two-a").start(), Drsim("two-b").start()]
    g = Gateway("two", sims, modbus="on_link_loss = exception\n", unit_ids=[1, 7])
    try:
        g.start()
        yield g
    finally:
        g.kill()
        for s in sims:
            s.kill()


def test_two_robots(two, regmap):
    g = two
    enips = [EnipReader("127.0.0.2", s.tcp) for s in g.sims]
    try:
        with g.raw() as m:
            put_int_in0(m, regmap, 11, unit=1)
            put_int_in0(m, regmap, 77, unit=7)
            wait_for(lambda: int_out0(m, regmap, 1) == 11 and int_out0(m, regmap, 7) == 77, 10,
                     "each robot's echo on its own unit")
            assert struct.unpack_from("<i", enips[0].get(INSTANCE["int_in"]))[0] == 11
            assert struct.unpack_from("<i", enips[1].get(INSTANCE["int_in"]))[0] == 77
            g.sims[0].kill()
            g.wait_link(False, unit=1)
            a = regmap.addr("IR", "int_out[0]")
            assert m.exception(bytes([4]) + struct.pack(">HH", a, 2), unit=1) == EX_TARGET_FAILED
            # the other robot is not affected
            assert int_out0(m, regmap, 7) == 77 and g.status(7)[1] == 2
            put_int_in0(m, regmap, 78, unit=7)
            wait_for(lambda: int_out0(m, regmap, 7) == 78, 10, "unit 7 echo")
            g.sims[0].start(same_ports=True)
            g.wait_link(True, unit=1, seconds=60)
            wait_for(lambda: int_out0(m, regmap, 1) == 11, 20, "unit 1 after recovery")
    finally:
        for e in enips:
            e.close()


def test_session_loss_alone_keeps_the_data(regmap):
    """Class 1 connections outlive the TCP session that opened them (as on
    a robot): drsim dropping the session every second does not take the
    link down, and the data keeps flowing both ways."""
    with running("link-session-drop", sim_args=("--drop-session-after", "1")) as g:
        with g.raw() as m:
            t0 = time.monotonic()
            n = 0
            while time.monotonic() - t0 < 3.5:
                n += 1
                put_int_in0(m, regmap, n)
                wait_for(lambda: int_out0(m, regmap) == n, 10, "echo %d" % n)
                time.sleep(0.1)
            assert m.read(4, 1, 1) == [2]
        assert g.sim.log().count("closed (--drop-session-after)") >= 2
        # the same six connections all along
        assert g.sim.log().count("connection open") == 6
        assert "link down" not in g.log()


def test_refusals_summed_up_before_link_up():
    """Forward Opens refused for a while, then the robot takes them: the
    count of refusals the rate limit held back is printed before "link up",
    not up to 10 s after it, where it read like a fault of the link that
    had just come up. The robot first refuses every Forward Open (six
    connections: one line and five held back), then is restarted as a
    robot that takes them."""
    sim = Drsim("log-refusals-sim", "--refuse-forward-open", "0x0113").start()
    g = Gateway("log-refusals", sim)
    try:
        g.start(wait_link=False)
        g.log_wait("Forward Open refused: CIP 0x01/0x0113")
        time.sleep(0.5)  # all six refused by now, the retries too
        sim.kill()
        sim.extra = []
        sim.start(same_ports=True)
        g.wait_link(True, seconds=30)
        lines = g.log().splitlines()
        up = [i for i, l in enumerate(lines) if "link up" in l][0]
        before = [l for l in lines[:up] if "similar message" in l]
        assert before and before[-1].endswith("suppressed until now, the last shown]"), lines[:up + 1]
        assert "0x0113" in before[-1]
        assert not any("similar message" in l for l in g.log().splitlines()[up:])
    finally:
        g.kill()
        sim.kill()


@pytest.mark.parametrize("timing", ["follow", "strict"])
def test_o2t_timing(timing, regmap):
    """Both O->T timings keep the robot's connections fed at the RPI: over
    two seconds at RPI 2 ms no connection times out, and drsim consumed
    about as many O->T packets as it produced T->O (counted per connection
    in its log at the Forward Close)."""
    import re
    # Timeout 64 x RPI (128 ms), not 16 x: a loaded two-core machine can
    # hold a process off the CPU for 32 ms (seen in CI with other jobs
    # running); the rate check below is what tells the timings apart.
    # Under the sanitizers (deadlines scaled, GW_TIMEOUT_SCALE) 256 x RPI:
    # 128 ms timed out once with the suite on four workers, load 4.
    mult = 4 if SCALE <= 1 else 6
    with running("o2t-" + timing, robot="rpi_ms = 2\ntimeout_multiplier = %d\n"
                 "o2t_timing = %s\n" % (mult, timing)) as g:
        with g.raw() as m:
            put_int_in0(m, regmap, -77)
            wait_for(lambda: int_out0(m, regmap) == -77, 10, "echo")
        time.sleep(2.0)
        assert "link down" not in g.log()
        # The loop wakes up at the O->T deadlines itself (epoll_pwait2,
        # Linux 5.11): the client has no timer descriptor of its own.
        if pwait2_kernel():
            fds = os.listdir("/proc/%d/fd" % g.proc.pid)
            timers = [f for f in fds if "timerfd" in readlink_or("/proc/%d/fd/%s" % (g.proc.pid, f))]
            assert timers == [], timers
        rc, _ = g.stop()
        assert rc == 0
        wait_for(lambda: g.sim.log().count("closed (forward close)") == 6, 10,
                 "six Forward Closes in drsim's log")
        closes = re.findall(r"closed \(([^)]*)\): (\d+) produced, (\d+) consumed", g.sim.log())
        assert len(closes) == 6, closes  # nothing else closed: no timeout
        for why, produced, consumed in closes:
            p, c = int(produced), int(consumed)
            assert why == "forward close" and p > 500, (why, p, c)
            assert 0.9 * p <= c <= 1.1 * p, (timing, p, c)


@pytest.mark.parametrize("ppm", [-11000, 11000])
def test_o2t_follow_spacing(ppm):
    """o2t_timing = follow (the default) against a robot whose clock runs
    1.1 % slow (98.9 packets a second at RPI 10 ms, as a real adapter was
    measured) or 1.1 % fast (drsim --clock-ppm): over six seconds no
    connection sends O->T faster than one packet per RPI. drsim times the
    arrivals by the kernel's receive stamp and reports them per connection
    at the Forward Close. Before the fix: 104.7 packets a second, gaps of
    0.02 ms. The shortest gap is printed, not asserted: on a loaded machine
    a packet built on time can leave late, just before the next one (29 us
    was seen under make check beside other jobs); the rule that the client
    never schedules two packets closer than three quarters of an RPI is
    asserted in virtual time by test_client_fake's
    test_class1_follow_spacing."""
    import re
    with running("o2t-spacing-%+d" % ppm, sim_args=("--clock-ppm", str(ppm))) as g:
        time.sleep(6.0)
        rc, _ = g.stop()
        assert rc == 0
        wait_for(lambda: g.sim.log().count("closed (forward close)") == 6, 10,
                 "six Forward Closes in drsim's log")
        closes = re.findall(r"closed \(([^)]*)\): .* O->T (\d+) in (\d+) us, shortest gap (\d+) us",
                            g.sim.log())
        assert len(closes) == 6, closes
        for why, n, span_us, gap_us in closes:
            n, span_us, gap_us = int(n), int(span_us), int(gap_us)
            assert why == "forward close" and n > 400, (why, n, span_us)
            # n - 1 intervals of at least one RPI, give or take one packet
            assert (n - 1) * 10000 <= span_us + 10000, (ppm, n, span_us)
            print("ppm %+d: %d packets in %d us, shortest gap %d us" % (ppm, n, span_us, gap_us))


@pytest.mark.parametrize("policy", ["zero", "hold"])
def test_partial_link(policy, regmap):
    """drsim takes only five of the six connections: the link is down, yet
    five connections deliver. With on_link_loss = zero the robot data reads
    0 all the same (the link is up only with all six); with hold the data
    that arrives is shown, flagged stale."""
    with running("partial-" + policy, sim_args=("--max-connections", "5"), start=False,
                 modbus="on_link_loss = %s\n" % policy) as g:
        g.start(wait_link=False)
        wait_for(lambda: g.status()[16:22].count(2) == 5, 20, "five connections established")
        time.sleep(0.3)  # several RPIs of data from the five
        with g.raw() as m:
            st = m.read(4, 0, 26)
            assert st[1] != 2 and st[2] == 0  # link not up, data not fresh
            robot = m.read(4, 100, 25) + m.read(4, 200, 72) + m.read(4, 300, 48)
            if policy == "zero":
                assert robot == [0] * len(robot)
            else:
                assert any(robot)
        assert "0x0113" in g.log() or "out of connections" in g.log().lower()


def test_host_name_resolved_once(regmap):
    """A host name is resolved when the configuration is loaded and the
    link uses the address; one that does not resolve stops the start with
    a message naming the robot and the host."""
    sim = Drsim("byname", "-a", GW_ADDR).start()  # on 127.0.0.1, which localhost is
    g = Gateway("byname", sim)
    g.config_text_orig = g.config_text
    g.config_text = lambda **kw: g.config_text_orig(**kw).replace(
        "host = %s\n" % SIM_ADDR, "host = localhost\n")
    try:
        g.start()
        assert "connecting to localhost (127.0.0.1)" in g.log()
        with g.raw() as m:
            assert m.read(4, regmap.addr("IR", "io_state.version.major"), 3) == [2, 12, 3]
    finally:
        g.kill()
        sim.kill()
    bad = Gateway("byname-bad", sim)
    bad.port = free_port(GW_ADDR)
    bad.local_udp = [free_port(GW_ADDR, tcp=False)]
    bad.write_config(bad.config_text().replace("host = %s\n" % SIM_ADDR,
                                               "host = no-such-robot.invalid\n"))
    p = subprocess.run([str(DRGATEWAYD), "-c", str(bad.conf)], capture_output=True, text=True,
                       timeout=timeout(30))
    assert p.returncode == 1, (p.returncode, p.stderr)
    assert "robot r0: host 'no-such-robot.invalid' does not resolve" in p.stderr
