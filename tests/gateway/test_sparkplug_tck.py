# SPDX-License-Identifier: MIT
"""Sparkplug 3.0's MUST rules and what a host sees (issue 32), with a host
the other Sparkplug tests do not use: Eclipse Tahu's JavaScript packages
(sparkplug-payload and the MQTT.js of sparkplug-client, pinned in
tests/tahu/package-lock.json, installed by `make test-deps`), run as
tests/tahu/host.js. Every session these tests record goes through
spb_tck.check: the edge-node rules of the TCK that can be checked from the
wire (QoS and retain flags, timestamps, aliases, seq, bdSeq over reconnects,
reloads and restarts). docs/mqtt.md "Tests" has the table."""
import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import threading
import time

import pytest

from gwlib import (DRCLI, GW_ADDR, LOGDIR, SIM_ADDR, TOP, free_port, spawn, timeout,
                   wait_for)
from mqttlib import broker_running, started_after
import spb_tck

TAHU = TOP / "tests" / "tahu"
NODE = shutil.which("node")
if NODE is None or not (TAHU / "node_modules" / "sparkplug-payload").is_dir():
    # (as gwlib.skip: the banner, and under CI a failure: CI runs every check)
    _why = "Eclipse Tahu's JavaScript packages are not installed in tests/tahu (make test-deps)"
    print("\n%s\n### test_sparkplug_tck SKIPPED: %s\n%s" % ("#" * 67, _why, "#" * 67))
    if os.environ.get("CI"):
        pytest.fail("skipped in CI: " + _why, pytrace=False)
    pytest.skip(_why, allow_module_level=True)

GROUP, EDGE = "cell1", "gw1"
NS = "spBv1.0/%s/" % GROUP


def section(broker, extra=""):
    return ("\n[mqtt]\nhost = %s\nport = %d\nkeepalive_s = 5\npayload = sparkplug\n"
            "group_id = %s\nedge_node_id = %s\n%s\n" % (GW_ADDR, broker.port, GROUP, EDGE,
                                                       extra))


class Tahu:
    """tests/tahu/host.js: every message with its QoS and retain flag as
    published, decoded by Tahu's sparkplug-payload; publishes with Tahu's
    encoder."""

    def __init__(self, broker, name="tahu", addr=None):
        self.msgs, self.acks = [], []
        self.lock = threading.Lock()
        log = open(LOGDIR / ("%s.tahu.log" % name), "ab")
        self.p = subprocess.Popen([NODE, str(TAHU / "host.js"), str(broker.port), GROUP] +
                                  ([addr] if addr else []),
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log,
                                  cwd=str(TAHU))
        log.close()
        self.ready = threading.Event()
        threading.Thread(target=self._read, daemon=True).start()
        assert self.ready.wait(timeout(20)), "host.js did not subscribe"

    def _read(self):
        for line in self.p.stdout:
            r = json.loads(line)
            with self.lock:
                if r.get("ready"):
                    self.ready.set()
                elif "published" in r or ("error" in r and "topic" not in r):
                    self.acks.append(r)
                else:
                    self.msgs.append(r)

    def all(self, kind=None, device=None):
        with self.lock:
            out = []
            for m in self.msgs:
                parts = m["topic"].split("/")
                if kind is not None and (len(parts) < 3 or parts[2] != kind):
                    continue
                if device is not None and (len(parts) < 5 or parts[4] != device):
                    continue
                out.append(m)
            return out

    def send(self, topic, payload=None, text=None, qos=0, retain=False):
        r = {"topic": topic, "qos": qos, "retain": retain}
        if text is not None:
            r["text"] = text
        else:
            r["payload"] = payload
        n = len(self.acks)
        self.p.stdin.write((json.dumps(r) + "\n").encode())
        self.p.stdin.flush()
        wait_for(lambda: len(self.acks) > n, 10, "host.js to publish")

    def burst(self, records):
        """Several messages written to the broker at once (no wait between)."""
        n = len(self.acks)
        self.p.stdin.write("".join(json.dumps(r) + "\n" for r in records).encode())
        self.p.stdin.flush()
        wait_for(lambda: len(self.acks) >= n + len(records), 10, "host.js to publish")

    def dcmd(self, metrics, device="r0"):
        self.send(NS + "DCMD/%s/%s" % (EDGE, device),
                  {"timestamp": int(time.time() * 1000), "metrics": metrics})

    def close(self):
        self.p.stdin.close()
        self.p.terminate()
        self.p.wait(timeout(10))

    def check(self, **kw):
        with self.lock:
            msgs = list(self.msgs)
        return spb_tck.check(msgs, **kw)


def gateway(name, broker, extra="", state=True):
    return started_after(name, [lambda: Tahu(broker, name)], extra=section(broker, extra))


@pytest.fixture
def broker(request):
    with broker_running(request.node.name) as b:
        yield b


def born(host, n=1, device="r0"):
    wait_for(lambda: len(host.all("NBIRTH")) >= n, 20, "NBIRTH")
    wait_for(lambda: len(host.all("DBIRTH", device)) >= n, 20, "DBIRTH of " + device)
    return host.all("NBIRTH")[-1]["payload"], host.all("DBIRTH", device)[-1]["payload"]


def metric(payload, name):
    return next(m for m in payload["metrics"] if m.get("name") == name)


def path_of(m):
    """The canonical path: the `path` property (the name where there is none)."""
    return ((m.get("properties") or {}).get("path") or {}).get("value", m.get("name"))


def values(host, device="r0"):
    """The device's values by canonical path, from its last DBIRTH and the DDATA after."""
    out, alias = {}, {}
    for m in host.all(device=device):
        kind = m["topic"].split("/")[2]
        if kind == "DBIRTH":
            out = {}
            alias = {x["alias"]: path_of(x) for x in m["payload"]["metrics"]}
        if kind in ("DBIRTH", "DDATA"):
            for x in m["payload"]["metrics"]:
                out[alias[x["alias"]]] = x["value"]
    return out


def assert_conformant(host, **kw):
    bad = host.check(**kw)
    assert not bad, "\n".join(bad[:20])


# ---- the four MUST rules ----------------------------------------------------------------

def test_rebirth_metric_has_no_alias(broker):
    """tck-id-operational-behavior-data-commands-rebirth-name-aliases: a node
    that uses aliases must not alias Node Control/Rebirth; the NCMD by name
    still gives a rebirth."""
    with gateway("tck_rebirth", broker) as (g, host):
        nb, db = born(host)
        rb = metric(nb, "Node Control/Rebirth")
        assert rb.get("alias") is None and rb["type"] == "Boolean" and rb["value"] is False
        host.send(NS + "NCMD/" + EDGE, {"timestamp": int(time.time() * 1000), "metrics": [
            {"name": "Node Control/Rebirth", "type": "Boolean", "value": True}]})
        nb2, _ = born(host, 2)
        assert nb2["seq"] == 0 and metric(nb2, "bdSeq")["value"] == metric(nb, "bdSeq")["value"]
        assert_conformant(host)


def test_every_metric_has_a_timestamp(broker):
    """tck-id-payloads-name-birth-data-requirement: every metric of NBIRTH,
    DBIRTH and DDATA carries a timestamp (drsim's noise makes DDATA)."""
    with gateway("tck_ts", broker, "publish_interval_ms = 50") as (g, host):
        born(host)
        wait_for(lambda: len(host.all("DDATA", "r0")) >= 10, 20, "DDATA")
        for kind in ("NBIRTH", "DBIRTH", "DDATA"):
            for m in host.all(kind):
                assert all(x.get("timestamp") for x in m["payload"]["metrics"]), m
        assert_conformant(host)


def test_sparkplug_qos_zero_and_qos1_refused(broker):
    """Births and data at QoS 0, NDEATH at QoS 1, nothing retained (as
    published: MQTT 5 retain-as-published, the host at QoS 2); [mqtt] qos = 1
    with payload = sparkplug is refused by --check-config, FILE:LINE."""
    from gwlib import DRGATEWAYD, EXIT_CONFIG
    LOGDIR.mkdir(parents=True, exist_ok=True)
    p = LOGDIR / "tck-qos.ini"
    p.write_text("[robot r0]\nhost = 127.0.0.2\n\n[mqtt]\nhost = 127.0.0.1\n"
                 "payload = sparkplug\ngroup_id = g\nqos = 1\n")
    r = subprocess.run([str(DRGATEWAYD), "--check-config", str(p)], capture_output=True,
                       text=True, timeout=timeout(30))
    assert r.returncode == EXIT_CONFIG, r
    assert "%s:8: " % p in r.stderr and "QoS 0" in r.stderr, r.stderr
    with gateway("tck_qos", broker, "publish_interval_ms = 50") as (g, host):
        born(host)
        wait_for(lambda: len(host.all("DDATA", "r0")) >= 5, 20, "DDATA")
        g.stop()
        wait_for(lambda: host.all("NDEATH"), 10, "NDEATH at stop")
        for m in host.all():
            if m["topic"].startswith(NS):
                kind = m["topic"].split("/")[2]
                assert m["qos"] == (1 if kind == "NDEATH" else 0) and not m["retain"], m
        assert_conformant(host)


def test_bdseq_grows_over_reload_and_restart(broker):
    """bdSeq is one more with every new connection: a reload that changes
    [mqtt] (it was 0 again), and a restart of the daemon (kept in the state
    directory, $STATE_DIRECTORY here as under systemd)."""
    with gateway("tck_bdseq", broker) as (g, host):
        nb, _ = born(host)
        bd = metric(nb, "bdSeq")["value"]
        g.extra = g.extra.replace("keepalive_s = 5", "keepalive_s = 6")
        g.write_config()
        g.signal(signal.SIGHUP)
        nb2, _ = born(host, 2)
        assert metric(nb2, "bdSeq")["value"] == (bd + 1) % 256
        assert g.stop()[0] == 0
        g.start()
        nb3, _ = born(host, 3)
        assert metric(nb3, "bdSeq")["value"] == (bd + 2) % 256
        assert (g.state_dir / ("sparkplug-%s-%s.bdseq" % (GROUP, EDGE))).read_text() == \
            "%d\n" % ((bd + 3) % 256)
        wait_for(lambda: len(host.all("NDEATH")) >= 2, 10, "the NDEATHs")
        assert_conformant(host)


class RefusingProxy:
    """A TCP proxy in front of the broker that answers the first `refuse`
    CONNECTs itself with CONNACK "not authorized" (5), keeping each
    refused CONNECT's Will payload, and passes later connections through."""

    def __init__(self, broker, refuse=1):
        self.broker, self.refuse, self.wills = broker, refuse, []
        self.s = socket.socket()
        self.s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.s.bind((GW_ADDR, 0))
        self.s.listen(8)
        self.port = self.s.getsockname()[1]
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                c, _ = self.s.accept()
            except OSError:
                return
            if self.refuse > 0:
                self.refuse -= 1
                pkt = self._packet(c)
                self.wills.append(self._will(pkt))
                c.sendall(bytes([0x20, 2, 0, 5]))
                c.close()
                continue
            b = socket.create_connection((GW_ADDR, self.broker.port))
            for a, z in ((c, b), (b, c)):
                threading.Thread(target=self._pipe, args=(a, z), daemon=True).start()

    @staticmethod
    def _pipe(a, z):
        try:
            while True:
                d = a.recv(65536)
                if not d:
                    break
                z.sendall(d)
        except OSError:
            pass
        for x in (a, z):
            with contextlib.suppress(OSError):
                x.shutdown(socket.SHUT_RDWR)

    @staticmethod
    def _packet(c):
        def byte():
            d = c.recv(1)
            assert d, "closed"
            return d[0]
        byte()
        n, mul = 0, 1
        while True:
            x = byte()
            n += (x & 127) * mul
            mul *= 128
            if not x & 128:
                break
        data = b""
        while len(data) < n:
            data += c.recv(n - len(data))
        return data

    @staticmethod
    def _will(d):
        """The Will payload of an MQTT 3.1.1 CONNECT's variable part."""
        ln = int.from_bytes(d[0:2], "big")
        i = 2 + ln + 1
        flags = d[i]
        i += 1 + 2
        ln = int.from_bytes(d[i:i + 2], "big")
        i += 2 + ln                                    # client id
        assert flags & 4, "no Will"
        ln = int.from_bytes(d[i:i + 2], "big")
        i += 2 + ln                                    # will topic
        ln = int.from_bytes(d[i:i + 2], "big")
        return d[i + 2:i + 2 + ln]

    def close(self):
        self.s.close()


def _bdseq_of(payload):
    """bdSeq of an NDEATH payload, decoded by Tahu."""
    r = subprocess.run([NODE, "-e", "const s=require('sparkplug-payload').get('spBv1.0');"
                        "const p=s.decodePayload(Buffer.from(process.argv[1],'base64'));"
                        "console.log(Number(p.metrics.find(m=>m.name==='bdSeq').value))",
                        __import__("base64").b64encode(payload).decode()],
                       cwd=str(TAHU), capture_output=True, text=True, timeout=timeout(30))
    return int(r.stdout)


def test_refused_connect_uses_its_bdseq(broker):
    """A CONNECT the broker answers with a refusal used its bdSeq: the
    next connection has the next one (Sparkplug 3.0: one more than in the
    previous CONNECT packet)."""
    proxy = RefusingProxy(broker, refuse=1)
    try:
        with started_after("tck_refused", [lambda: Tahu(broker, "tck_refused")],
                           extra=section(broker).replace("port = %d" % broker.port,
                                                         "port = %d" % proxy.port)) \
                as (g, host):
            nb, _ = born(host)
            assert len(proxy.wills) == 1
            assert metric(nb, "bdSeq")["value"] == (_bdseq_of(proxy.wills[0]) + 1) % 256
            assert_conformant(host)
    finally:
        proxy.close()


# ---- what a host sees ------------------------------------------------------------------

def test_every_refused_write_is_echoed(broker):
    """19 refused DCMDs in one burst (T->O fields, each its own command):
    each field's current value comes back in DDATA, not only the first's
    (the data's own DDATA are 5 s apart: what comes sooner is the echo)."""
    with gateway("tck_echo", broker, "writes = yes\npublish_interval_ms = 5000") as (g, host):
        born(host)
        paths = ["io_state.version.major", "io_state.version.minor", "io_state.version.patch"] + \
            ["int_out[%d]" % i for i in range(16)]
        before = values(host)
        n = len(host.all("DDATA", "r0"))
        host.burst([{"topic": NS + "DCMD/%s/r0" % EDGE, "qos": 0, "payload": {
            "timestamp": int(time.time() * 1000),
            "metrics": [{"name": pth, "type": "UInt8" if "version" in pth else "Int32",
                         "value": 99}]}} for pth in paths])
        alias = {x["alias"]: path_of(x) for x in host.all("DBIRTH", "r0")[-1]["payload"]["metrics"]}

        def echoed():
            return {alias[x["alias"]] for m in host.all("DDATA", "r0")[n:]
                    for x in m["payload"]["metrics"]}
        wait_for(lambda: set(paths) <= echoed(), 4, "every refused field echoed (%s)"
                 % ", ".join(sorted(set(paths) - echoed())))
        now = values(host)
        assert all(now[p] == before[p] for p in paths)
        assert_conformant(host)


def test_dcmd_of_any_legal_shape_is_decoded(broker):
    """A DCMD whose metrics have 3 properties, and a String value of 80
    bytes, is decoded (it was dropped as malformed): the properties are
    ignored, the writes reach drsim, which echoes them (int_out, float_out)."""
    with gateway("tck_shape", broker, "writes = yes\npublish_interval_ms = 50") as (g, host):
        born(host)
        props = {"a": {"type": "String", "value": "x" * 100}, "b": {"type": "Int32", "value": 1},
                 "c": {"type": "Boolean", "value": True}}
        host.dcmd([{"name": "int_in/0", "type": "Int32", "value": 77, "properties": props},
                   {"name": "float_in[1]", "type": "String", "value": "2.5" + "0" * 77}])
        wait_for(lambda: values(host).get("int_out[0]") == 77 and
                 values(host).get("float_out[1]") == 2.5, 10, "the writes echoed by drsim")
        assert "malformed" not in g.log()
        # a name longer than any field's: an unknown metric, refused, logged
        host.dcmd([{"name": "n" * 300, "type": "Int32", "value": 1}])
        g.log_wait("unknown metric (name too long)")
        assert_conformant(host)


def test_stop_sends_a_fresh_ndeath(broker):
    """SIGTERM after a while: the NDEATH the gateway sends is stamped at the
    stop, not at the connect (it was the Will's, made at the connect)."""
    with gateway("tck_bye", broker) as (g, host):
        born(host)
        time.sleep(3)
        t0 = time.time() * 1000
        assert g.stop()[0] == 0
        d = wait_for(lambda: host.all("NDEATH"), 10, "NDEATH")[0]
        assert d["payload"]["timestamp"] >= t0 - 500, (d, t0)
        assert_conformant(host)


def test_text_state_is_logged_once(broker):
    """A Sparkplug 2.2 host's text STATE (`ONLINE`): no births, and one log
    line with what came and what is expected; a 3.0 STATE then brings them."""
    with gateway("tck_state", broker, "primary_host_id = scada1") as (g, host):
        wait_for(lambda: "connected to" in g.log(), 10, "the connection")
        for _ in range(3):
            host.send("spBv1.0/STATE/scada1", text="ONLINE", qos=1, retain=True)
        g.log_wait("STATE 'ONLINE' is not Sparkplug 3.0")
        time.sleep(1)
        assert g.log().count("is not Sparkplug 3.0") == 1
        assert not host.all("NBIRTH")
        host.send("spBv1.0/STATE/scada1", qos=1, retain=True, text=json.dumps(
            {"online": True, "timestamp": int(time.time() * 1000)}))
        born(host)
        assert_conformant(host)


def test_echo_timestamps_follow_ddata(broker):
    """Refusals' echoes are stamped as DDATA are (the robot packet's time):
    a device's timestamps never step back (they did by up to an RPI), over
    refused DCMDs sent at random moments while drsim moves slowly."""
    with gateway("tck_echo_ts", broker, "writes = yes\npublish_interval_ms = 20") as (g, host):
        born(host)
        for i in range(30):
            host.dcmd([{"name": "io_state.version.major", "type": "UInt8", "value": 99}])
            time.sleep(0.037 * (i % 5))
        time.sleep(0.5)
        back = [b for b in host.check() if "time-order" in b]
        assert not back, "\n".join(back[:10])
        assert_conformant(host)


# ---- for SCADA users ------------------------------------------------------------------

def test_metric_names_are_folders_with_the_path_kept(broker):
    """By default a metric's name is a folder path Ignition takes
    (joint_state/position/1: no '.', '[' or ']'); its `path` property is the
    canonical one (drcli's), and a DCMD may name either."""
    with gateway("tck_names", broker, "writes = yes\npublish_interval_ms = 50") as (g, host):
        _, db = born(host)
        ms = {x["name"]: x for x in db["metrics"]}
        assert "joint_state/position/1" in ms and "int_in/0" in ms
        assert path_of(ms["joint_state/position/1"]) == "joint_state.position[1]"
        assert ms["joint_state/position/1"]["properties"]["engUnit"]["value"] == "degree"
        assert not any(c in n for n in ms for c in ".[]")
        listed = json.loads(subprocess.run([str(DRCLI), "list", "--json"], check=True,
                                           capture_output=True, text=True).stdout)
        assert {path_of(x) for x in db["metrics"]} == {f["path"] for f in listed["fields"]}
        host.dcmd([{"name": "int_in/3", "type": "Int32", "value": 33}])
        wait_for(lambda: values(host).get("int_out[3]") == 33, 10, "the write by folder name")
        assert_conformant(host)
