# SPDX-License-Identifier: MIT
"""What the PLC and the integrator see is true (issue 30, items 1-3).

1. A robot that accepts every Forward Open and sends no T->O packet (drsim
   --drop-t2o, as behind a firewall that drops UDP towards the gateway; and
   a real drop by a tc filter on a veth link between two network
   namespaces) is never "linked": IR 1 stays 1, DI 0 stays 0, and once the
   first packet's grace is over its own cause (last_error 32, "the robot
   accepted the connection but sends no data to ADDRESS:PORT") is in the
   status block, the log (with the time actually waited), `drgatewayd
   status`, the API and MQTT's state.
2. A `local_address` that is not the address TCP would leave from, against
   an adapter that takes the T->O address from the TCP peer (drsim
   --t2o-to-peer, OpENer's rule): the data flows, because the TCP session
   leaves from local_address too.
3. Explicit mode with a Set the robot refuses (a wrong instance for
   float_in): the link stays up, the refusal is in last_error with its CIP
   status, counted, and logged (rate-limited); the link never goes down.

Each test polls with bounded waits; none asserts a duration."""
import json
import re
import shutil
import subprocess
import time
import urllib.request

import pytest

from gwlib import (DRGATEWAYD, DRSIM, GW_ADDR, LOGDIR, SIM_ADDR, Drsim, Gateway, free_port, in_netns,
                   running, skip, spawn, timeout, wait_for)

LINK_STATE, DATA_FRESH, LAST_ERROR, CIP_GENERAL = 1, 2, 12, 30
NO_DATA = 32  # DR_ENODATA: drgate/status.h


def watch_link(g, until, seconds=20, unit=1):
    """Polls the status block until until(st) is true; returns (st, every
    IR 1 value seen). Fails after `seconds`."""
    seen = set()

    def check():
        st = g.status(unit)
        seen.add(st[LINK_STATE])
        with g.raw() as m:
            seen.add(("DI0", m.read(2, 0, 1, unit=unit)[0]))
        return st if until(st) else None
    st = wait_for(check, seconds, "the status block's condition")
    return st, seen


def api(port, path):
    with urllib.request.urlopen("http://%s:%d%s" % (GW_ADDR, port, path),
                                timeout=timeout(10)) as r:
        return json.loads(r.read())


def test_no_t2o_data_is_not_linked():
    """drsim --drop-t2o: never linked, and the cause said everywhere."""
    http = free_port(GW_ADDR, udp=False)
    mqtt = None
    try:
        from mqttlib import PREFIX, Broker, Plant, mqtt_section
        import paho.mqtt.client  # noqa: F401
        if shutil.which("mosquitto"):
            mqtt = Broker("honest-nodata-mqtt").start()
    except ImportError:
        pass
    extra = "\n[http]\nport = %d\n" % http + (mqtt_section(mqtt) if mqtt else "")
    plant = Plant(mqtt) if mqtt else None
    try:
        with running("honest-nodata", sim_args=("--drop-t2o",), start=False,
                     robot="rpi_ms = 20\ntimeout_multiplier = 1\n", extra=extra) as g:
            g.start(wait_link=False)
            # the first grace (2 s + 160 ms) and more: never up
            st, seen = watch_link(g, lambda s: s[LAST_ERROR] == NO_DATA, seconds=30)
            assert st[CIP_GENERAL] == 0 and st[DATA_FRESH] == 0, st[:31]
            end = time.monotonic() + 3
            while time.monotonic() < end:  # a few more rounds of opens
                _, more = watch_link(g, lambda s: True)
                seen |= more
            assert 2 not in seen and ("DI0", 1) not in seen, seen
            assert 1 in seen  # connecting: the session is up
            where = "%s:%d" % (GW_ADDR, g.local_udp[0])
            words = ("the robot accepted the connection but sends no data to %s: a firewall, "
                     "or the robot answers another address" % where)
            g.log_wait(words)
            assert "link up" not in g.log()
            # the time waited, not the configured timeout (160 ms)
            m = re.search(r"%s \(nothing for (\d+) ms\)" % re.escape(words), g.log())
            assert m and int(m.group(1)) >= 2000, g.log()[-2000:]
            # drgatewayd status: not linked, exit 1, the cause
            p = subprocess.run([str(DRGATEWAYD), "status", "-c", str(g.conf)],
                               capture_output=True, text=True, timeout=timeout(30))
            assert p.returncode == 1, p.stdout + p.stderr
            assert "Robots: 0 of 1 linked" in p.stdout
            assert "connecting: " + words in p.stdout, p.stdout
            # the API
            r0 = api(http, "/api/v1/status")["robots"][0]
            assert r0["link"] != "up" and r0["reason"] == words, r0
            assert r0["last_error"]["code"] == NO_DATA and r0["last_error"]["text"] == words
            assert api(http, "/api/v1/robots")[0]["reason"] == words
            # MQTT's state: down with the same words, and never "up"
            if plant is not None:
                topic = PREFIX + "/r0/state"
                wait_for(lambda: plant.last(topic) == "down: " + words, 20,
                         "state 'down: %s'" % words)
                assert "up" not in [m[1] for m in plant.all(topic)]
    finally:
        if plant is not None:
            plant.close()
        if mqtt is not None:
            mqtt.stop()


def test_no_t2o_data_then_data():
    """The same gateway comes up as soon as the robot's data flows (drsim
    restarted without --drop-t2o on the same ports), and the record of the
    last failure stays."""
    with running("honest-nodata-then", sim_args=("--drop-t2o",), start=False,
                 robot="rpi_ms = 20\ntimeout_multiplier = 1\n") as g:
        g.start(wait_link=False)
        watch_link(g, lambda s: s[LAST_ERROR] == NO_DATA, seconds=30)
        g.sim.kill()
        g.sim.extra = []
        g.sim.start(same_ports=True)
        g.wait_link(True, seconds=60)
        st = g.status()
        assert st[6] << 16 | st[7] > 0  # rx_packets


def test_local_address_tcp_leaves_from():
    """local_address 127.0.0.3 while TCP to 127.0.0.2 would leave from
    127.0.0.1, against an adapter that sends T->O to the TCP peer's
    address: the session is bound to local_address, so the data comes."""
    sim = Drsim("honest-local-address", "--t2o-to-peer").start()
    g = Gateway("honest-local-address", sim)
    plain = g.config_text
    g.config_text = lambda *a, **kw: plain(*a, **kw).replace(
        "local_address = %s\n" % GW_ADDR, "local_address = 127.0.0.3\n")
    try:
        g.start(wait_link=False)
        g.wait_link(True, seconds=30)
        st = g.status()
        assert st[6] << 16 | st[7] > 0 and st[LAST_ERROR] == 0, st[:31]
        assert "registered by 127.0.0.3:" in sim.log()
    finally:
        g.kill()
        sim.kill()


@pytest.mark.parametrize("mode", ["explicit"])
def test_refused_set_keeps_the_link(mode):
    """Explicit mode, float_in at an instance the robot does not have: the
    Set is refused at every cycle, and the link stays up."""
    with running("honest-refused-set", start=False,
                 robot="mode = %s\nrpi_ms = 50\ninstance.float_in = 150\n" % mode) as g:
        g.start(wait_link=False)
        g.wait_link(True, seconds=30)
        st, seen = watch_link(g, lambda s: s[LAST_ERROR] != 0, seconds=20)
        assert st[CIP_GENERAL] != 0, st[:31]
        end = time.monotonic() + 3
        while time.monotonic() < end:
            _, more = watch_link(g, lambda s: True)
            seen |= more
        assert seen <= {2, ("DI0", 1)}, seen
        log = g.log()
        assert "link down" not in log, log[-3000:]
        assert re.search(r"robot r0: set float_in \(instance 150\) refused: CIP 0x", log), log
        # rate-limited: one line per 10 s for the kind, not one per cycle
        assert len(re.findall(r"set float_in \(instance 150\) refused", log)) <= 2


def test_t2o_dropped_by_the_network(tmp_path):
    """A real drop: drsim and the gateway in two network namespaces joined
    by a veth pair, a tc filter on drsim's end dropping every UDP packet
    it sends (TCP passes): the gateway is never linked and says why."""
    if shutil.which("ip") is None or shutil.which("tc") is None:
        skip("test_t2o_dropped_by_the_network", "no ip or tc")
    ns = "drgt-nodata-%d" % free_port(GW_ADDR, udp=False)
    nsa, nsb = ns + "a", ns + "b"

    def sh(*cmd, check=True):
        return subprocess.run(cmd, capture_output=True, text=True, check=check)
    try:
        try:
            sh("ip", "netns", "add", nsa)
            sh("ip", "netns", "add", nsb)
        except (subprocess.CalledProcessError, OSError) as e:
            skip("test_t2o_dropped_by_the_network", "no network namespaces: %s" % e)
        veth = "vnd%d" % (free_port(GW_ADDR, udp=False) % 10000)
        sh("ip", "link", "add", veth + "a", "netns", nsa, "type", "veth", "peer", "name",
           veth + "b", "netns", nsb)
        sh("ip", "-n", nsa, "addr", "add", "10.77.0.2/24", "dev", veth + "a")
        sh("ip", "-n", nsb, "addr", "add", "10.77.0.1/24", "dev", veth + "b")
        for n, d in ((nsa, veth + "a"), (nsb, veth + "b")):
            sh("ip", "-n", n, "link", "set", "lo", "up")
            sh("ip", "-n", n, "link", "set", d, "up")
        # drsim's end drops every UDP packet it sends: a classic BPF
        # classifier in direct-action mode (no tc action module needed):
        # IPv4 protocol (Ethernet 14 + 9) 17 -> TC_ACT_SHOT, else unspec
        bpf = "4,48 0 0 23,21 0 1 17,6 0 0 2,6 0 0 4294967295"
        r = sh("tc", "-n", nsa, "qdisc", "add", "dev", veth + "a", "clsact", check=False)
        r2 = sh("tc", "-n", nsa, "filter", "add", "dev", veth + "a", "egress", "bpf", "da",
                "bytecode", bpf, check=False)
        if r.returncode != 0 or r2.returncode != 0:
            skip("test_t2o_dropped_by_the_network", "no tc clsact/bpf: %s" % (r.stderr + r2.stderr))
        log_sim = tmp_path / "drsim.log"
        sim = spawn(["ip", "netns", "exec", nsa, str(DRSIM), "-a",
                     "10.77.0.2", "-v"], log_sim)
        conf = tmp_path / "gw.ini"
        conf.write_text("[modbus]\nlisten = 10.77.0.1\nport = 1502\n[robot r0]\n"
                        "host = 10.77.0.2\nrpi_ms = 20\ntimeout_multiplier = 1\n"
                        "local_address = 10.77.0.1\n")
        gw = spawn(["ip", "netns", "exec", nsb, str(DRGATEWAYD), "-c", str(conf)],
                   tmp_path / "gw.log")
        try:
            with in_netns("/run/netns/" + nsb):
                from gwlib import RawModbus

                def status():
                    with RawModbus("10.77.0.1", 1502) as m:
                        return m.read(4, 0, 44)
                seen = set()

                def check():
                    try:
                        st = status()
                    except OSError:
                        return None
                    seen.add(st[LINK_STATE])
                    return st if st[LAST_ERROR] == NO_DATA else None
                wait_for(check, 30, "last_error %d" % NO_DATA)
                end = time.monotonic() + 3
                while time.monotonic() < end:
                    check()
                assert 2 not in seen, seen
            words = "sends no data to 10.77.0.1:2222: a firewall"
            wait_for(lambda: words in (tmp_path / "gw.log").read_text(), 10, words)
        finally:
            for p in (gw, sim):
                p.kill()
                p.wait()
    finally:
        sh("ip", "netns", "del", nsa, check=False)
        sh("ip", "netns", "del", nsb, check=False)


@pytest.mark.parametrize("content", ["uninitialized\n", "", "0" * 32 + "\n"])
def test_uninitialized_machine_id_is_said(tmp_path, content):
    """Issue 30, item 6: /etc/machine-id not a machine's own (bind-mounted
    over in a mount namespace of the daemon's own): the daemon says so at
    start, with how to regenerate it; a real one says nothing."""
    if shutil.which("unshare") is None:
        skip("test_uninitialized_machine_id_is_said", "no unshare")
    mid = tmp_path / "machine-id"
    mid.write_text(content)
    g = Gateway("honest-machine-id", Drsim("honest-machine-id").start())
    try:
        g.port = free_port(GW_ADDR, udp=False)
        g.local_udp = [free_port(GW_ADDR, tcp=False)]
        g.write_config()
        log = tmp_path / "gw.log"
        p = spawn(["unshare", "-m", "sh", "-c",
                   "mount --bind %s /etc/machine-id && exec %s -c %s"
                   % (mid, DRGATEWAYD, g.conf)], log)
        try:
            words = "regenerate it (rm /etc/machine-id && systemd-machine-id-setup)"
            wait_for(lambda: "running:" in log.read_text() or p.poll() is not None, 10,
                     "the daemon to start")
            text = log.read_text()
            if "mount" in text and "running:" not in text:
                skip("test_uninitialized_machine_id_is_said", "cannot bind-mount: %s" % text)
            state = {"": "missing or empty", "uninitialized\n": "uninitialized"}.get(
                content, "all zeros")
            assert "/etc/machine-id is %s" % state in text and words in text, text
        finally:
            p.kill()
            p.wait()
    finally:
        g.sims[0].kill()
