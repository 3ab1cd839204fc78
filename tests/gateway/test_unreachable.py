# SPDX-License-Identifier: MIT
"""A robot the gateway cannot reach says why (issue 19, item 2). Every
failed connection attempt, from the first one, is logged with its cause in
words and shown in the status block: last_error (IR 12) has one code per
cause, with last_cip_general (IR 30) 0, and MQTT's state says the same
words. The causes: nothing listens on the port (refused), a host that
accepts TCP and never answers RegisterSession, one that closes every
session at once, no route / network unreachable / no answer to the TCP
connection / nothing answering ARP (in a network namespace of the test's
own, where routes and a veth pair are set up without touching the host),
refused reconnects after the link was up, and the Class 1 port taken by
another program."""
import os
import shutil
import socket
import subprocess
import threading
import types

import pytest

from gwlib import (DRGATEWAYD, EXIT_RUNTIME, GW_ADDR, LOGDIR, SIM_ADDR, Gateway, RawModbus,
                   free_port, in_netns, read_text, running, skip, spawn, timeout, wait_for)

LINK_STATE, LAST_ERROR, CIP_GENERAL = 1, 12, 30

# drgate/status.h's codes, as docs/register-map.md lists them
REFUSED, CLOSED, TIMED_OUT = 15, 16, 14
HOST_UNREACH, NET_UNREACH, NO_ANSWER, NO_REGISTER = 24, 25, 26, 27


class Peer:
    """A TCP listener on 127.0.0.2 that is not an EtherNet/IP adapter: it
    accepts every connection, then says nothing (mode "silent") or closes
    it at once ("close"). tcp/udp as a Drsim has them, for Gateway."""

    def __init__(self, mode):
        self.mode = mode
        self.tcp = free_port(SIM_ADDR, udp=False)
        self.udp = free_port(SIM_ADDR, tcp=False)
        self.sock = socket.socket()
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind((SIM_ADDR, self.tcp))
        self.sock.listen(16)
        self.sock.settimeout(0.2)
        self.held = []
        self.accepted = 0
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self.stop.is_set():
            try:
                c, _ = self.sock.accept()
            except OSError:
                continue
            self.accepted += 1
            if self.mode == "close":
                c.close()
            else:
                self.held.append(c)  # open, and never a byte back

    def close(self):
        self.stop.set()
        self.thread.join()
        for c in self.held:
            c.close()
        self.sock.close()


def nobody():
    """Ports on 127.0.0.2 where nothing listens: every connect is refused."""
    return types.SimpleNamespace(tcp=free_port(SIM_ADDR), udp=free_port(SIM_ADDR, tcp=False),
                                 close=lambda: None)


def wait_error(g, code, unit=1, seconds=20):
    """The status block once last_error is `code`."""
    return wait_for(lambda: (lambda st: st if st[LAST_ERROR] == code else None)(g.status(unit)),
                    seconds, "last_error %d (unit %d)" % (code, unit))


CAUSES = {
    # peer, last_error, the log's words (after "robot r0: 127.0.0.2:PORT: ")
    "refused": (nobody, REFUSED, "connect: connection refused"),
    "silent": (lambda: Peer("silent"), NO_REGISTER,
               "register session: connection accepted, but no reply to RegisterSession"),
    "close": (lambda: Peer("close"), CLOSED, "register session: connection closed by peer"),
}


@pytest.mark.parametrize("mode", ["implicit", "explicit"])
@pytest.mark.parametrize("cause", sorted(CAUSES))
def test_unreachable_robot_says_why(cause, mode):
    """From the first attempt on: the cause in the log, and its code in
    last_error with the link down (IR 1 = 0) and IR 30 = 0."""
    make, code, words = CAUSES[cause]
    peer = make()
    g = Gateway("unreach-%s-%s" % (cause, mode), peer,
                robot="mode = %s\ntimeout_ms = 300\n" % mode)
    try:
        g.start(wait_link=False)
        st = wait_error(g, code)
        assert st[LINK_STATE] == 0 and st[CIP_GENERAL] == 0, st[:31]
        line = "robot r0: %s:%d: %s" % (SIM_ADDR, peer.tcp, words)
        g.log_wait(line)
        # the first attempt is the first thing the robot logs after its
        # "connecting to" line: not minutes of silence
        log = g.log()
        first = log.index("robot r0: connecting to")
        assert log.index(line) > first
        assert "warning: " + line in log
        if cause != "refused":
            assert peer.accepted >= 1
    finally:
        g.kill()
        peer.close()


def test_mqtt_state_names_the_cause():
    """MQTT's retained <robot>/state says why the robot is down, in the
    log's words."""
    pytest.importorskip("paho.mqtt.client")
    from mqttlib import PREFIX, Broker, Plant, mqtt_section
    broker = Broker("unreach-mqtt").start()
    peer = nobody()
    g = Gateway("unreach-mqtt", peer, extra=mqtt_section(broker))
    plant = Plant(broker)
    try:
        g.start(wait_link=False)
        wait_for(lambda: plant.last(PREFIX + "/r0/state") == "down: connection refused", 20,
                 "state 'down: connection refused'")
        # retained: a plant that comes later reads the cause at once
        late = Plant(broker)
        try:
            wait_for(lambda: late.all(PREFIX + "/r0/state"), 10, "the retained state")
            assert late.all(PREFIX + "/r0/state")[-1][1:] == ("down: connection refused", True)
        finally:
            late.close()
    finally:
        plant.close()
        g.kill()
        broker.stop()


def test_refused_reconnect_after_the_link_was_up(regmap):
    """drsim killed while linked: its Class 1 connections time out (14),
    and every reconnect that follows is refused, logged as refused and
    recorded as 15; not 'reconnecting: timed out' alone."""
    with running("unreach-reconnect") as g:
        assert g.status()[LAST_ERROR] == 0
        mark = len(g.log())
        g.sim.kill()
        g.wait_link(False)
        st = wait_error(g, REFUSED, seconds=30)
        assert st[CIP_GENERAL] == 0 and st[LINK_STATE] == 0
        g.log_wait("robot r0: %s:%d: connect: connection refused" % (SIM_ADDR, g.sim.tcp),
                   start=mark)
        # the robot back on its ports: the link too, and the code stays as
        # the record of the last failure
        g.sim.start(same_ports=True)
        g.wait_link(True, seconds=60)
        assert g.status()[LAST_ERROR] == REFUSED


def test_class1_port_in_use():
    """Another program has the Class 1 port: the start fails and says the
    address is in use and which settings fix it."""
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    port = free_port(GW_ADDR, tcp=False)
    taken.bind((GW_ADDR, port))
    try:
        g = Gateway("unreach-udp-in-use", nobody())
        g.port = free_port(GW_ADDR, udp=False)
        g.local_udp = [port]
        g.write_config()
        p = subprocess.run([str(DRGATEWAYD), "-c", str(g.conf)], capture_output=True, text=True,
                           timeout=timeout(30))
        assert p.returncode == EXIT_RUNTIME, (p.returncode, p.stderr)
        assert ("robot r0: cannot open UDP %s:%d for Class 1 I/O: address already in use"
                % (GW_ADDR, port)) in p.stderr, p.stderr
        assert "local_address" in p.stderr and "local_udp_port" in p.stderr, p.stderr
        assert "network I/O error" not in p.stderr
    finally:
        taken.close()


# ---- in a network namespace of our own -----------------------------------------

def can_unshare():
    if os.geteuid() != 0 or not shutil.which("unshare") or not shutil.which("ip"):
        return False
    return subprocess.run(["unshare", "-n", "true"], capture_output=True,
                          timeout=timeout(30)).returncode == 0


# (host, timeout_ms, last_error, the log's words after "connect: ")
NETNS_ROBOTS = [
    ("10.2.0.5", 300, HOST_UNREACH, "no route to host"),        # an unreachable route
    ("10.5.0.5", 300, NET_UNREACH, "network unreachable"),      # no route at all
    ("10.1.0.5", 300, NET_UNREACH, "network unreachable"),      # a blackhole route
    ("10.8.0.9", 300, NO_ANSWER, "no answer: TCP connection timed out"),  # SYNs vanish
    ("10.8.0.7", 8000, HOST_UNREACH, "no route to host"),       # nobody answers ARP
]

# The namespace: loopback for Modbus, routes for three of the robots, and
# a veth pair whose far end has no address: 10.8.0.9 has a static
# neighbour entry, so its SYNs go out and nothing ever answers; 10.8.0.7
# has none, and ARP fails after about 3 s (the kernel's EHOSTUNREACH, seen
# by the non-blocking connect's SO_ERROR).
NETNS_SETUP = """set -e
ip link set lo up
ip route add unreachable 10.2.0.0/24
ip route add blackhole 10.1.0.0/24
ip link add v0 type veth peer name v1
ip addr add 10.8.0.1/24 dev v0
ip link set v0 up
ip link set v1 up
ip neigh add 10.8.0.9 lladdr 02:00:00:00:00:09 dev v0 nud permanent
"""


def test_no_route_and_no_answer():
    """In a network namespace of its own: each robot's cause in its log
    line and its own code in its last_error."""
    if not can_unshare():
        skip("test_unreachable.py", "needs root, unshare(1) and ip(8)")
    LOGDIR.mkdir(parents=True, exist_ok=True)
    conf = LOGDIR / "unreach-netns.ini"
    log_path = LOGDIR / "unreach-netns.gateway.log"
    if log_path.exists():
        log_path.unlink()
    port = 1502  # nothing else lives in this namespace
    text = "[modbus]\nlisten = 127.0.0.1\nport = %d\n" % port
    for i, (host, tmo, _, _) in enumerate(NETNS_ROBOTS):
        # no local_address: the TCP session leaves from it (issue 30), and
        # 127.0.0.1 cannot reach the robots behind the veth link
        text += ("\n[robot r%d]\nhost = %s\nlocal_udp_port = 2222\n"
                 "unit_id = %d\ntimeout_ms = %d\n" % (i, host, i + 1, tmo))
    conf.write_text(text)
    proc = spawn(["unshare", "-n", "sh", "-c", NETNS_SETUP + 'exec "$0" -c "$1"',
                  DRGATEWAYD, conf], log_path)
    try:
        wait_for(lambda: proc.poll() is not None or " running: " in read_text(log_path), 10,
                 "drgatewayd to start in its namespace")
        assert proc.poll() is None, read_text(log_path)

        def status(unit):
            with in_netns("/proc/%d/ns/net" % proc.pid):
                m = RawModbus("127.0.0.1", port)
            with m:
                return m.read(4, 0, 31, unit=unit)

        for i, (host, _, code, words) in enumerate(NETNS_ROBOTS):
            st = wait_for(lambda: (lambda s: s if s[LAST_ERROR] == code else None)(status(i + 1)),
                          30, "r%d (%s): last_error %d" % (i, host, code))
            assert st[LINK_STATE] == 0 and st[CIP_GENERAL] == 0, st
            line = "warning: robot r%d: %s:44818: connect: %s" % (i, host, words)
            wait_for(lambda: line in read_text(log_path), 10, "'%s' in the log" % line)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
