# SPDX-License-Identifier: MIT
"""SIGHUP: a good configuration is swapped in without dropping the robot
connection (when the robot's section did not change); a bad one is refused
and the running one keeps going."""
import signal
import socket
import struct
import time

import pytest

from gwlib import (EX_ILLEGAL_FUNCTION, GW_ADDR, INSTANCE, REAL_123456, EnipReader, dint_regs,
                   free_port, running, wait_for)


@pytest.fixture
def pair(request):
    name = request.node.name.replace("[", "-").replace("]", "")
    with running(name) as g:
        yield g


def rx(st):
    return st[6] << 16 | st[7]


def reload(g, modbus=None, robot=None, extra=None, text=None, port=None, listen=None):
    """Rewrites the config and sends SIGHUP; returns the log offset before."""
    mark = len(g.log())
    g.write_config(text if text is not None else
                   g.config_text(modbus=modbus, robot=robot, extra=extra, port=port,
                                 listen=listen))
    g.signal(signal.SIGHUP)
    return mark


def wait_generation(g, n):
    wait_for(lambda: g.status()[29] == n, 10, "config_generation %d" % n)


def test_reload_keeps_the_robot_connection(pair, regmap):
    g = pair
    with g.raw() as m:
        m.write_regs(regmap.addr("HR", "int_in[0]"), dint_regs(31337, "abcd"))
        wait_for(lambda: m.read(4, regmap.addr("IR", "int_out[0]"), 2) ==
                 dint_regs(31337, "abcd"), 10, "echo")
        st0 = m.read(4, 0, 40)
        assert st0[29] == 0 and st0[28] == 0
        mark = reload(g, modbus="word_order = cdab\n")
        g.log_wait("reloaded (generation 1)", start=mark)
        wait_generation(g, 1)
        st1 = m.read(4, 0, 40)
        assert st1[28] == 1                        # cdab
        assert m.read(4, 35, 2) == REAL_123456["cdab"]
        # the same connections: rx packets kept counting, link never dropped
        assert st1[1] == 2 and rx(st1) >= rx(st0)
        assert "link down" not in g.log()[mark:]
        log = g.sim.log()
        assert log.count("connection open") == 6 and "closed" not in log.replace(
            "closed (session ended)", ""), log
        # the O->T image survived, now shown in the new word order
        assert m.read(3, regmap.addr("HR", "int_in[0]"), 2) == dint_regs(31337, "cdab")
        assert m.read(4, regmap.addr("IR", "int_out[0]"), 2) == dint_regs(31337, "cdab")
        enip = EnipReader("127.0.0.2", g.sim.tcp)
        try:
            assert struct.unpack_from("<i", enip.get(INSTANCE["int_in"]))[0] == 31337
        finally:
            enip.close()
        # clients kept their connection (this one)
        assert m.read(4, 32, 1) == [0x1234]


def test_reload_bad_config_is_refused(pair, regmap):
    g = pair
    good = g.config_text()
    bad = good.replace("[modbus]\n", "[modbus]\nword_order = abdc\n")
    line = bad.splitlines().index("word_order = abdc") + 1
    mark = reload(g, text=bad)
    g.log_wait("reload refused", start=mark)
    msg = [l for l in g.log()[mark:].splitlines() if "reload refused" in l][0]
    assert "%s:%d: word_order 'abdc' invalid" % (g.conf, line) in msg
    assert g.alive()
    st = g.status()
    assert st[29] == 0 and st[28] == 0 and st[1] == 2
    with g.raw() as m:
        assert m.read(4, 35, 2) == REAL_123456["abcd"]
    # a file that is not there is refused as well
    g.conf.unlink()
    g.signal(signal.SIGHUP)
    wait_for(lambda: g.log()[mark:].count("reload refused") == 2, 10, "second refusal")
    # and a good one afterwards is taken
    mark = reload(g, modbus="word_order = dcba\n")
    wait_generation(g, 1)
    assert g.status()[28] == 3
    assert g.sim.log().count("connection open") == 6


def test_reload_changed_robot_reconnects(pair):
    g = pair
    mark = reload(g, robot="rpi_ms = 20\n")
    wait_generation(g, 1)
    g.log_wait("changed or removed", start=mark)
    g.wait_link(True)
    wait_for(lambda: g.status()[5] == 20, 10, "RPI 20 in the status block")
    wait_for(lambda: g.sim.log().count("connection open") == 12, 10, "six new connections")
    assert g.sim.log().count("closed (forward close)") == 6


def test_reload_changed_robot_keeps_heartbeat_and_counters(pair):
    """A reload that changes a robot (here its RPI) reconnects it, but what
    a PLC watches for liveness and progress never goes backwards: the
    heartbeat (IR 4) and the packet counters (IR 6-9) go on from where
    they were, sampled all through the reload (before the fix: heartbeat
    4 -> 1, rx_packets back to 0)."""
    g = pair
    wait_for(lambda: g.status()[4] >= 3, 10, "heartbeat 3")
    with g.raw() as m:
        before = m.read(4, 0, 30)
        mark = reload(g, robot="rpi_ms = 20\n")
        seen = [before]
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline:
            st = m.read(4, 0, 30)
            seen.append(st)
            if st[29] == 1 and st[1] == 2 and st[5] == 20:
                break
            time.sleep(0.05)
        assert seen[-1][29] == 1 and seen[-1][1] == 2, seen[-1]
    g.log_wait("changed or removed", start=mark)  # it did reconnect
    for a, b in zip(seen, seen[1:]):
        assert b[4] >= a[4], ("heartbeat went back", a[4], b[4])
        assert rx(b) >= rx(a), ("rx_packets went back", rx(a), rx(b))
        lost_a, lost_b = a[8] << 16 | a[9], b[8] << 16 | b[9]
        assert lost_b >= lost_a, ("lost_packets went back", lost_a, lost_b)
    assert rx(seen[-1]) > rx(before)


def test_reload_unit_id_keeps_connection(pair):
    g = pair
    g.unit_ids = [5]
    reload(g)
    wait_generation_unit = lambda: g.status(5)[29] == 1  # noqa: E731
    wait_for(wait_generation_unit, 10, "unit 5 serving generation 1")
    with g.raw() as m:
        assert m.exception(bytes([4, 0, 0, 0, 1]), unit=1) == 0x0A
    assert g.sim.log().count("connection open") == 6


def test_reload_allowlist_applies_to_connected_clients(pair, regmap):
    g = pair
    with g.raw() as m:
        m.write_reg(0, 1)
        reload(g, modbus="allow = 127.0.0.0/8 ro\n")
        wait_generation(g, 1)
        assert m.exception(struct.pack(">BHH", 6, 0, 2)) == EX_ILLEGAL_FUNCTION
        assert m.read(4, 32, 1) == [0x1234]


def test_reload_new_port(pair):
    g = pair
    old = g.port
    new = free_port(GW_ADDR, udp=False)
    reload(g, port=new)
    wait_for(lambda: g.listening(new), 10, "the new port")
    wait_for(lambda: not g.listening(old), 10, "the old port to close")
    g.port = new
    assert g.status()[29] == 1 and g.status()[1] == 2


def test_reload_port_in_use_keeps_running(pair):
    """A reload whose new Modbus port cannot be opened (in use) leaves the
    gateway serving on the old one, logged; the rest of the file is taken.
    (It used to close the old listener first and then stop the daemon.)"""
    g = pair
    busy = socket.socket()
    busy.bind((GW_ADDR, 0))
    busy.listen(1)
    try:
        mark = reload(g, port=busy.getsockname()[1], modbus="word_order = cdab\n")
        g.log_wait("still listening on %s:%d" % (GW_ADDR, g.port), start=mark)
        wait_generation(g, 1)
        assert g.alive(), g.log()[mark:]
        st = g.status()
        assert st[1] == 2 and st[28] == 1
        assert g.sim.log().count("connection open") == 6
    finally:
        busy.close()
    # the next reload moves it once the port is free
    new = free_port(GW_ADDR, udp=False)
    reload(g, port=new, modbus="word_order = cdab\n")
    wait_for(lambda: g.listening(new), 10, "the new port")
    g.port = new
    wait_generation(g, 2)


def test_reload_same_port_other_address(pair):
    """From one address to the wildcard on the same port: the old listener
    is in the way, so it is closed first."""
    g = pair
    reload(g, listen="0.0.0.0")
    wait_generation(g, 1)
    assert g.alive()
    wait_for(lambda: g.listening(), 10, "the port on 127.0.0.1")
    s = socket.create_connection(("127.0.0.7", g.port), timeout=10)
    s.close()


def test_reload_new_robot_that_cannot_start(pair):
    """A new robot whose local UDP port is taken cannot be started: the
    reload must not take the running gateway down."""
    g = pair
    busy = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    busy.bind((GW_ADDR, 0))
    try:
        extra = ("[robot extra]\nhost = 127.0.0.2\ntcp_port = %d\nudp_port = %d\n"
                 "local_address = %s\nlocal_udp_port = %d\nunit_id = 9\n"
                 % (free_port("127.0.0.2"), g.sims[0].udp, GW_ADDR, busy.getsockname()[1]))
        mark = reload(g, extra=extra)
        wait_for(lambda: not g.alive() or "UDP" in g.log()[mark:] or
                 "refused" in g.log()[mark:], 10, "the reload to end")
        time.sleep(0.5)
        assert g.alive(), "exit status %s: %s" % (g.proc.poll(), g.log()[mark:])
        st = g.status()
        assert st[1] == 2
    finally:
        busy.close()


def test_reload_reindexing_keeps_explicit_polls():
    """Issue 11 item 1. Two explicit-mode robots, the second (b) slow (40
    ms replies, so a poll of it is nearly always out); a reload removes the
    first and adds a new one (c): b moves from position 1 to 0 while its
    requests are in flight. Its replies must still reach b (they used to
    reach c's poll state: b's in-flight count never returned to 0 and b
    stayed 'link down: timed out' for good)."""
    from gwlib import Drsim, Gateway
    sims = [Drsim("reidx-a").start(), Drsim("reidx-b", "--delay", "40").start(),
            Drsim("reidx-c").start()]
    robot = "mode = explicit\nrpi_ms = 50\ntimeout_ms = 500\n"
    g = Gateway("reidx", sims[:2], robot=robot, unit_ids=[1, 2])
    try:
        g.start()
        text = g.config_text()
        head, sec_a, sec_b = text.split("\n[robot ")
        sec_c = ("r2]\nhost = 127.0.0.2\ntcp_port = %d\nudp_port = %d\nlocal_address = %s\n"
                 "local_udp_port = %d\nunit_id = 3\ntimeout_multiplier = 4\n%s\n"
                 % (sims[2].tcp, sims[2].udp, GW_ADDR, free_port(GW_ADDR, tcp=False), robot))
        mark = len(g.log())
        g.write_config("\n[robot ".join([head, sec_b, sec_c]))
        g.signal(signal.SIGHUP)
        wait_for(lambda: g.status(2)[29] == 1, 10, "unit 2 serving generation 1")
        g.wait_link(True, unit=3)

        def polls(unit):
            st = g.status(unit)
            return st[6] << 16 | st[7]
        # b keeps polling: its received count goes on rising for a second
        # and more (1 s is twenty RPIs and many times its timeout)
        n0 = polls(2)
        wait_for(lambda: polls(2) >= n0 + 20, 10, "robot b's polls to go on")
        time.sleep(1.0)
        n1 = polls(2)
        time.sleep(0.5)
        assert polls(2) > n1
        assert g.status(2)[1] == 2, g.log()[mark:]
        assert "robot r1 (127.0.0.2): link down" not in g.log()[mark:], g.log()[mark:]
    finally:
        g.kill()
        for s in sims:
            s.kill()


def test_reload_moves_modbus_state_with_the_robot():
    """Issue 13: the Modbus unit (its rules and state: here the watchdog
    register, HR 0, which reads back the last value written) is the Modbus
    side's, kept by robot position and carried over a reload by the
    robot's serial. A reload removes the first robot (a) and adds a new
    one (c): b moves from position 1 to 0 and keeps its unit's state; c,
    new at position 1, starts afresh (not with what b had at that
    position, nor with a's)."""
    from gwlib import Drsim, Gateway
    sims = [Drsim("mvunit-a").start(), Drsim("mvunit-b").start(), Drsim("mvunit-c").start()]
    g = Gateway("mvunit", sims[:2], unit_ids=[1, 2])
    try:
        g.start()
        with g.raw() as m:
            m.write_reg(0, 0x1111, unit=1)
            m.write_reg(0, 0x2222, unit=2)
            assert m.read(3, 0, 1, unit=1) == [0x1111]
            assert m.read(3, 0, 1, unit=2) == [0x2222]
        text = g.config_text()
        head, sec_a, sec_b = text.split("\n[robot ")
        sec_c = ("r2]\nhost = 127.0.0.2\ntcp_port = %d\nudp_port = %d\nlocal_address = %s\n"
                 "local_udp_port = %d\nunit_id = 3\ntimeout_multiplier = 4\n"
                 % (sims[2].tcp, sims[2].udp, GW_ADDR, free_port(GW_ADDR, tcp=False)))
        g.write_config("\n[robot ".join([head, sec_b, sec_c]))
        g.signal(signal.SIGHUP)
        wait_for(lambda: g.status(2)[29] == 1, 10, "unit 2 serving generation 1")
        g.wait_link(True, unit=3)
        with g.raw() as m:
            assert m.read(3, 0, 1, unit=2) == [0x2222]
            assert m.read(3, 0, 1, unit=3) == [0]
            assert m.exception(bytes([3, 0, 0, 0, 1]), unit=1) == 0x0A
        assert g.status(2)[1] == 2
    finally:
        g.kill()
        for s in sims:
            s.kill()
