# SPDX-License-Identifier: MIT
"""Back within a second of the cable (issue 19, item 7).

drgatewayd and drsim on two hosts: two network namespaces joined by a veth
pair, the gateway on 10.219.0.1, drsim on 10.219.0.2, both on the standard
ports. With every connection up, drsim's end of the link goes down for 3 s
(a pulled cable: nothing arrives either way, the TCP session is not told).

What used to happen: the Forward Opens the gateway sent meanwhile, and
gave up on, waited in the TCP session; when the link returned drsim got
them all, opened an owner connection for each, and refused the gateway's
fresh ones with 0x0106 until those ran out of their 10 s grace: the robot
was back 11 s after the cable. Now an unanswered Forward Open resets the
session (what TCP holds is dropped), and drsim's held owners are taken
over by the gateway's next session: every connection is up again within a
second or so of the link, and nothing is refused.

Needs root (network namespaces); skipped, with the banner of tests/skip.sh,
where they cannot be made (a failure under CI, as skip.sh does).
"""
import json
import os
import shutil
import subprocess
import time

import pytest

from gwlib import DRGATEWAYD, DRSIM, LOGDIR, RawModbus, in_netns, skip, spawn, timeout, wait_for

GW_IP, SIM_IP = "10.219.0.1", "10.219.0.2"
MODBUS_PORT = 1502
OUTAGE_S = 3.0
# The goal: 2 s (the old code took 11 s; the new one about 0.4 s
# with the neighbours fixed, so no ARP retry counts in).
RECOVERY_BOUND_S = 2.0


def ip(*args, check=True):
    return subprocess.run(["ip"] + list(args), capture_output=True, text=True,
                          timeout=20, check=check)


@pytest.fixture
def hosts():
    """Two namespaces, gateway and robot, joined by veth0 in each."""
    if os.geteuid() != 0:
        skip("test_cable.py", "network namespaces need root")
    if shutil.which("ip") is None:
        skip("test_cable.py", "no ip(8) (iproute2)")
    tag = "drgc%d" % os.getpid()
    ns = {"gw": tag + "g", "sim": tag + "s"}
    made = []
    try:
        for n in ns.values():
            ip("netns", "add", n)
            made.append(n)
        ip("link", "add", "veth0", "netns", ns["gw"], "type", "veth",
           "peer", "name", "veth0", "netns", ns["sim"])
        for who, addr in (("gw", GW_IP), ("sim", SIM_IP)):
            ip("-n", ns[who], "addr", "add", addr + "/24", "dev", "veth0")
            ip("-n", ns[who], "link", "set", "veth0", "up")
            ip("-n", ns[who], "link", "set", "lo", "up")
        # Permanent neighbours: when the link returns, the kernel's ARP
        # retry (1 s) would otherwise be most of what the test measures.
        mac = {who: json.loads(ip("-j", "-n", ns[who], "link", "show", "veth0").stdout)[0]["address"]
               for who in ns}
        for who, peer, addr in (("gw", "sim", SIM_IP), ("sim", "gw", GW_IP)):
            ip("-n", ns[who], "neigh", "replace", addr, "lladdr", mac[peer],
               "dev", "veth0", "nud", "permanent")
    except subprocess.CalledProcessError as e:
        for n in made:
            ip("netns", "del", n, check=False)
        skip("test_cable.py", "cannot make network namespaces here: %s" % e.stderr.strip())
    yield ns
    for n in made:
        ip("netns", "del", n, check=False)


def udp_in(ns):
    """UDP datagrams received in namespace ns (/proc/net/snmp is the
    reader's namespace's)."""
    lines = ip("netns", "exec", ns, "cat", "/proc/net/snmp").stdout.splitlines()
    udp = [ln.split()[1:] for ln in lines if ln.startswith("Udp:")]
    return int(dict(zip(udp[0], udp[1]))["InDatagrams"])


def gateway_config():
    # timeout x64 (640 ms), as the other gateway tests use on a loaded
    # machine; the request timeout is the default, 1 s
    return ("[modbus]\nlisten = 127.0.0.1\nport = %d\n\n"
            "[robot r0]\nhost = %s\nlocal_address = %s\ntimeout_multiplier = 4\n"
            % (MODBUS_PORT, SIM_IP, GW_IP))


def test_link_down_3s(hosts):
    name = "cable"
    LOGDIR.mkdir(parents=True, exist_ok=True)
    conf = LOGDIR / ("%s.ini" % name)
    conf.write_text(gateway_config())
    sim_log, gw_log = LOGDIR / ("%s.drsim.log" % name), LOGDIR / ("%s.gateway.log" % name)
    for p in (sim_log, gw_log):
        if p.exists():
            p.unlink()
    procs = []
    m = None
    try:
        procs.append(spawn(["ip", "netns", "exec", hosts["sim"], DRSIM, "-a", SIM_IP, "-v"],
                           sim_log))
        wait_for(lambda: "listening on" in sim_log.read_text(), 10, "drsim to listen")
        procs.append(spawn(["ip", "netns", "exec", hosts["gw"], DRGATEWAYD, "-c", conf],
                           gw_log))

        def status():
            nonlocal m
            if m is None:
                with in_netns("/run/netns/%s" % hosts["gw"]):
                    m = RawModbus("127.0.0.1", MODBUS_PORT, connect_timeout=2)
            try:
                return m.read(4, 0, 31)
            except OSError:
                m.close()
                m = None
                raise

        def all_up():
            st = status()
            return st[1] == 2 and all(st[16 + i] == 2 for i in range(6))

        wait_for(all_up, 20, "every connection up")
        # and O->T flowing too (10 packets a connection): an owner that has
        # had no O->T packet yet stays established through the outage for
        # its 10 s first-packet grace, refusing even its originator
        wait_for(lambda: udp_in(hosts["sim"]) >= 60, 10, "O->T packets at drsim")
        sim_mark, gw_mark = len(sim_log.read_text()), len(gw_log.read_text())

        # the cable: drsim's end down for 3 s; the gateway must see it
        ip("-n", hosts["sim"], "link", "set", "veth0", "down")
        t_down = time.monotonic()
        seen_down = False
        while time.monotonic() - t_down < OUTAGE_S:
            seen_down = seen_down or not all_up()
            time.sleep(0.05)
        ip("-n", hosts["sim"], "link", "set", "veth0", "up")
        t_up = time.monotonic()
        assert seen_down, "the gateway did not notice the link was down"

        wait_for(all_up, 30, "every connection up after the link returned", interval=0.01)
        recovery = time.monotonic() - t_up
        print("every connection up %.2f s after the link returned" % recovery)
        st = status()
        sim_text, gw_text = sim_log.read_text()[sim_mark:], gw_log.read_text()[gw_mark:]
        assert "0x0106" not in gw_text and "ownership" not in gw_text, gw_text
        assert "refused" not in sim_text, sim_text
        assert st[12] != 0x0106, "last_error 0x0106"
        # six opens, four of them taking a held owner over: nothing opened
        # for a request the gateway had given up on
        assert sim_text.count("connection open:") == 6, sim_text
        assert sim_text.count("closed (taken over by its originator)") == 4, sim_text
        assert recovery < timeout(RECOVERY_BOUND_S), \
            "up %.1f s after the link returned (bound %.1f s)" % (recovery, RECOVERY_BOUND_S)
    finally:
        if m is not None:
            m.close()
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
