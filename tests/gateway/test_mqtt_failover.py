# SPDX-License-Identifier: MIT
"""[mqtt] servers: the gateway moves to the next broker (issue 32).

Two real mosquitto brokers, each in its own network namespace joined to
this one by a veth pair (10.221.N.2 behind 10.221.N.1; a blackhole route
for each subnet, so nothing of it can leave the machine if a veth goes
down). The gateway, drsim and the hosts run here. Sparkplug 3.0 asks of an
edge node with several servers:

- the connection to the server is lost: the node connects to the next one
  with a new CONNECT (its Will: NDEATH with the next bdSeq), then NBIRTH
  and DBIRTH there (tck-id-operational-behavior-edge-node-termination-
  host-offline-reconnect's "next MQTT Server in its connection list");
- the primary host says offline on the server: the node leaves it for the
  next (tck-id-operational-behavior-primary-application-state-with-
  multiple-servers-walk); a server where its STATE never says online is
  left after primary_host_wait_s;
- every recorded session of every host passes spb_tck.check (the wire
  rules: QoS, timestamps, aliases, seq, bdSeq).

The JSON payload moves the same way. And a broker's host name whose DNS
server does not answer does not stop the daemon's loop: the robot link
stays up while the lookup hangs (the lookup runs in glibc's getaddrinfo_a
thread), the gateway goes on to the next server.

Needs root (network namespaces, a mount namespace for the resolver test);
skipped with the banner of tests/skip.sh otherwise (a failure under CI).
"""
import contextlib
import json
import os
import shutil
import stat
import subprocess
import time

import pytest

import gwlib
from gwlib import LOGDIR, read_text, running, skip, spawn, wait_for
from mqttlib import Broker, Plant
from test_sparkplug_tck import EDGE, GROUP, NS, Tahu, metric
import spb_tck

PORT = 1883
_made = 0  # namespace sets made by this process


def ip(*args, check=True):
    return subprocess.run(["ip"] + list(args), capture_output=True, text=True,
                          timeout=20, check=check)


@pytest.fixture
def brokers(request):
    """Two brokers, b[0] and b[1], each in its own namespace."""
    if os.geteuid() != 0:
        skip("test_mqtt_failover.py", "network namespaces need root")
    if shutil.which("ip") is None:
        skip("test_mqtt_failover.py", "no ip(8) (iproute2)")
    LOGDIR.mkdir(parents=True, exist_ok=True)
    # one subnet pair per pytest worker: the workers run side by side
    w = gwlib._worker_index() or 0
    # a name per test: `ip netns del` frees a namespace's veth pair
    # later, in the kernel's own time (the next test's names are new)
    global _made
    _made += 1
    tag = "drgf%d%c" % (os.getpid() % 100000, "abcdefghij"[_made % 10])
    made, routes, out = [], [], []
    try:
        for k in range(2):
            ns, net = "%s%d" % (tag, k), "10.221.%d" % (w * 4 + k)
            routes.append(net + ".0/24")
            ip("route", "replace", "blackhole", net + ".0/24", "metric", "4000")
            ip("netns", "add", ns)
            made.append(ns)
            ip("link", "add", "%sv%d" % (tag, k), "type", "veth", "peer", "name", "veth0",
               "netns", ns)
            ip("addr", "add", net + ".1/24", "dev", "%sv%d" % (tag, k))
            ip("link", "set", "%sv%d" % (tag, k), "up")
            ip("-n", ns, "addr", "add", net + ".2/24", "dev", "veth0")
            ip("-n", ns, "link", "set", "veth0", "up")
            ip("-n", ns, "link", "set", "lo", "up")
            out.append(Broker("%s-b%d" % (request.node.name, k + 1), addr=net + ".2", port=PORT,
                              netns=ns))
    except subprocess.CalledProcessError as e:
        for k, ns in enumerate(made):
            ip("link", "del", "%sv%d" % (tag, k), check=False)
            ip("netns", "del", ns, check=False)
        for r in routes:
            ip("route", "del", "blackhole", r, "metric", "4000", check=False)
        skip("test_mqtt_failover.py", "cannot make network namespaces here: %s: %s"
             % (" ".join(e.cmd), e.stderr.strip()))
    try:
        for b in out:
            b.start()
        yield out
    finally:
        for b in out:
            b.stop()
        for k, ns in enumerate(made):
            ip("link", "del", "%sv%d" % (tag, k), check=False)  # the pair, now
            ip("netns", "del", ns, check=False)
        for r in routes:
            ip("route", "del", "blackhole", r, "metric", "4000", check=False)


def servers(*bs):
    return " ".join("%s:%d" % (b.addr, b.port) for b in bs)


def spb_section(servers_text, extra=""):
    return ("\n[mqtt]\nservers = %s\nkeepalive_s = 5\npayload = sparkplug\ngroup_id = %s\n"
            "edge_node_id = %s\n%s\n" % (servers_text, GROUP, EDGE, extra))


def births(host, n=1):
    wait_for(lambda: len(host.all("NBIRTH")) >= n and len(host.all("DBIRTH", "r0")) >= n, 30,
             "NBIRTH and DBIRTH")
    return metric(host.all("NBIRTH")[-1]["payload"], "bdSeq")["value"]


def conformant(*hosts):
    for h in hosts:
        bad = h.check()
        assert not bad, "\n".join(bad[:20])


def link_stayed_up(g):
    assert "link down" not in g.log(), g.log()[-3000:]


def state(host, online, ts):
    host.send("spBv1.0/STATE/scada", text=json.dumps({"online": online, "timestamp": ts}),
              qos=1, retain=True)


@contextlib.contextmanager
def two_hosts(name, brokers):
    """Tahu's host.js on each broker; at the end every session they
    recorded passes spb_tck.check."""
    hs = [Tahu(b, "%s_%d" % (name, k + 1), b.addr) for k, b in enumerate(brokers)]
    try:
        yield hs
        conformant(*hs)
    finally:
        for h in hs:
            h.close()


def walked(h1, h2, bd):
    """Births on the second server with the next bdSeq after bd; the
    first server's NDEATH with bd (the node was born there)."""
    bd2 = births(h2)
    assert bd2 == (bd + 1) % 256, (bd, bd2)
    wait_for(lambda: [m for m in h1.all("NDEATH")
                      if metric(m["payload"], "bdSeq")["value"] == bd], 10, "NDEATH")


def test_broker_killed_node_on_the_next(brokers):
    """The first broker dies: the node is seen on the second with its
    births, bdSeq one more than on the first (the next CONNECT)."""
    b1, b2 = brokers
    with two_hosts("failover_kill", brokers) as (h1, h2), \
            running("failover_kill", extra=spb_section(servers(*brokers))) as g:
        bd = births(h1)
        assert not h2.all("NBIRTH")
        b1.stop()
        bd2 = births(h2)
        assert bd2 == (bd + 1) % 256, (bd, bd2)
        g.log_wait("next server %s:%d" % (b2.addr, b2.port))
        wait_for(lambda: len(h2.all("DDATA", "r0")) >= 3, 20, "DDATA on the second")
        link_stayed_up(g)


def test_primary_host_offline_node_walks(brokers):
    """The primary host's STATE says offline (newer than its online) on the
    server the node is born on: NDEATH there, births on the next one with
    the next bdSeq."""
    b2 = brokers[1]
    with two_hosts("failover_state", brokers) as (h1, h2):
        now = int(time.time() * 1000)
        state(h1, True, now)
        state(h2, True, now)
        with running("failover_state",
                     extra=spb_section(servers(*brokers), "primary_host_id = scada")) as g:
            bd = births(h1)
            state(h1, False, now + 1)
            walked(h1, h2, bd)
            g.log_wait("primary host offline: next server %s:%d" % (b2.addr, b2.port))
            link_stayed_up(g)


def test_primary_host_never_online_node_walks(brokers):
    """No STATE online on the first server within primary_host_wait_s: the
    node leaves it unborn and is born on the second."""
    b1 = brokers[0]
    with two_hosts("failover_wait", brokers) as (h1, h2):
        state(h2, True, int(time.time() * 1000))
        with running("failover_wait", extra=spb_section(
                servers(*brokers), "primary_host_id = scada\nprimary_host_wait_s = 2")) as g:
            births(h2)
            g.log_wait("primary host scada not online on %s:%d within 2 s" % (b1.addr, b1.port))
            assert not h1.all("NBIRTH") and not h1.all("DBIRTH")


def test_next_server_command(brokers):
    """NBIRTH offers Node Control/Next Server (Boolean false, no alias, as
    MQTT Engine shows it as a tag); NCMD Next Server = true: NDEATH on the
    first server, births on the second with the next bdSeq."""
    b2 = brokers[1]
    with two_hosts("failover_ncmd", brokers) as (h1, h2), \
            running("failover_ncmd", extra=spb_section(servers(*brokers))) as g:
        bd = births(h1)
        ns = metric(h1.all("NBIRTH")[-1]["payload"], "Node Control/Next Server")
        assert ns["type"] == "Boolean" and ns["value"] is False and ns.get("alias") is None
        h1.send(NS + "NCMD/" + EDGE, {"timestamp": int(time.time() * 1000), "metrics": [
            {"name": "Node Control/Next Server", "type": "Boolean", "value": True}]})
        walked(h1, h2, bd)
        g.log_wait("next server asked: next server %s:%d" % (b2.addr, b2.port))
        link_stayed_up(g)


def test_json_payload_fails_over(brokers):
    """JSON: the first broker dies, the plant on the second gets status
    online, the robot's meta and its data."""
    b1, b2 = brokers
    p1, p2 = Plant(b1, addr=b1.addr), Plant(b2, addr=b2.addr)
    try:
        section = ("\n[mqtt]\nservers = %s\ntopic_prefix = drgate/test\nkeepalive_s = 5\n"
                   % servers(b1, b2))
        with running("failover_json", extra=section) as g:
            wait_for(lambda: p1.messages(), 20, "data on the first broker")
            assert not p2.all()
            b1.stop()
            wait_for(lambda: p2.last("drgate/test/status") == "online", 30,
                     "status online on the second")
            wait_for(lambda: p2.last("drgate/test/r0/meta") and p2.messages(), 20,
                     "meta and data on the second")
            link_stayed_up(g)
    finally:
        p1.close()
        p2.close()


@pytest.fixture
def dns_sink(brokers):
    """A DNS server that never answers (a UDP socket on port 53 in the
    first broker's namespace), and a gateway wrapper that sees only it in
    /etc/resolv.conf (a mount namespace of its own)."""
    if shutil.which("unshare") is None:
        skip("test_mqtt_failover.py", "no unshare(1)")
    b1 = brokers[0]
    sink_log = LOGDIR / "failover_dns.sink.log"
    if sink_log.exists():
        sink_log.unlink()
    sink = spawn(["ip", "netns", "exec", b1.netns, "python3", "-c",
                  "import socket, time\ns = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)\n"
                  "s.bind(('%s', 53))\nprint('bound', flush=True)\ntime.sleep(3600)\n"
                  % b1.addr], sink_log)
    wait_for(lambda: "bound" in read_text(sink_log), 10, "DNS sink")
    resolv = LOGDIR / "failover_dns.resolv.conf"
    resolv.write_text("nameserver %s\noptions timeout:5 attempts:3\n" % b1.addr)
    wrapper = LOGDIR / "failover_dns.drgatewayd.sh"
    wrapper.write_text("#!/bin/sh\nexec unshare --mount sh -c 'mount --bind %s /etc/resolv.conf "
                       "&& exec \"$0\" \"$@\"' %s \"$@\"\n" % (resolv, gwlib.DRGATEWAYD))
    wrapper.chmod(wrapper.stat().st_mode | stat.S_IXUSR)
    real = gwlib.DRGATEWAYD
    gwlib.DRGATEWAYD = wrapper
    try:
        yield
    finally:
        gwlib.DRGATEWAYD = real
        sink.kill()
        sink.wait()


def test_dns_lookup_does_not_stop_the_loop(brokers, dns_sink):
    """The first server is a host name whose DNS server never answers (15 s
    before the resolver gives up): the robot link stays up meanwhile, and
    the gateway goes on to the second server. Before, libmosquitto's
    getaddrinfo ran in the loop: every robot link timed out."""
    b2 = brokers[1]
    with running("failover_dns", extra=spb_section(
            "broker.drgate-test.invalid:1883 " + servers(b2))) as g:
        h2 = Tahu(b2, "failover_dns_2", b2.addr)
        try:
            # Modbus answers while the lookup hangs (the loop turns) ...
            t0 = time.monotonic()
            while time.monotonic() - t0 < 4:
                g.status()
                time.sleep(0.2)
            # ... and the gateway reaches the next server
            births(h2)
            g.log_wait("broker.drgate-test.invalid:1883", 30)
            link_stayed_up(g)
            conformant(h2)
        finally:
            h2.close()
