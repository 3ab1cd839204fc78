# SPDX-License-Identifier: MIT
"""Sparkplug B ([mqtt] payload = sparkplug, docs/mqtt.md "Sparkplug B")
against Debian's mosquitto, with pysparkplug (PyPI, pinned in
tests/requirements.txt) as the independent host application: it decodes
every payload with its own protobuf code and resolves DDATA aliases and
datatypes from the births, as a SCADA host does. The units (a PropertySet
pysparkplug does not expose) are read with pysparkplug's generated
protobuf module, not with the gateway's decoder.

Births list every field of `drcli list --json` with its type and unit;
values agree with `drcli get`; seq has no gap; NCMD Rebirth, DCMD writes
(echoed by drsim, refusals echoed back), the Will (NDEATH) with the
birth's bdSeq, a new bdSeq after a broker restart, DDEATH/DBIRTH with the
robot's link, and births held until the primary host is online."""
import contextlib
import json
import os
import subprocess
import threading
import time

import pytest

from gwlib import DRCLI, GW_ADDR, SIM_ADDR, noise_of, timeout, wait_for

pysparkplug = pytest.importorskip("pysparkplug")

from mqttlib import broker_running, started_after  # noqa: E402 (needs paho)
from pysparkplug import (DataType, DCmd, Message, Metric, NCmd, QoS,  # noqa: E402
                         Topic, get_current_timestamp)
from pysparkplug._protobuf import Payload as PbPayload  # noqa: E402

GROUP, EDGE = "cell1", "gw1"
TYPES = {"BOOL": DataType.BOOLEAN, "USINT": DataType.UINT8, "USINT enum": DataType.UINT8,
         "DINT": DataType.INT32, "REAL": DataType.FLOAT}


def spb_section(broker, extra=""):
    # canonical metric names (the default, folders, is test_sparkplug_tck.py's)
    return ("\n[mqtt]\nhost = %s\nport = %d\nkeepalive_s = 5\npayload = sparkplug\n"
            "group_id = %s\nedge_node_id = %s\nmetric_names = canonical\n%s\n"
            % (GW_ADDR, broker.port, GROUP, EDGE, extra))


class Host:
    """A pysparkplug client subscribed to spBv1.0/<group>/#: every message
    kept as (message type, device, pysparkplug payload, raw bytes); a
    payload pysparkplug cannot decode is kept as the exception."""

    def __init__(self, broker):
        self.msgs = []
        self.lock = threading.Lock()
        self.c = pysparkplug.Client(client_id="spb-test-host")
        self.subscribed = threading.Event()
        self.c._client.on_subscribe = lambda c, u, mid, qos: self.subscribed.set()
        self.c.subscribe(Topic(group_id=GROUP, message_type="#"), QoS.AT_LEAST_ONCE, self._on)
        self.c.connect(GW_ADDR, port=broker.port, keepalive=30)
        assert self.subscribed.wait(timeout(10)), "no SUBACK from the broker"

    def _on(self, client, msg):
        with self.lock:
            self.msgs.append((str(msg.topic.message_type), msg.topic.device_id, msg.payload))

    def all(self, kind=None, device=None):
        with self.lock:
            return [m[2] for m in self.msgs
                    if (kind is None or m[0] == kind) and (device is None or m[1] == device)]

    def kinds(self):
        with self.lock:
            return [m[0] for m in self.msgs]

    def values(self, device="r0"):
        """The device's metrics by name, from its last DBIRTH and the DDATA after it."""
        out = {}
        with self.lock:
            for kind, dev, p in self.msgs:
                if dev != device:
                    continue
                if kind == "DBIRTH":
                    out = {}
                if kind in ("DBIRTH", "DDATA"):
                    out.update({m.name: m.value for m in p.metrics})
        return out

    def send(self, kind, metrics, device=None):
        cls = NCmd if kind == "NCMD" else DCmd
        topic = Topic(group_id=GROUP, message_type=kind, edge_node_id=EDGE, device_id=device)
        payload = cls(timestamp=get_current_timestamp(), metrics=tuple(metrics))
        self.c.publish(Message(topic=topic, payload=payload, qos=QoS.AT_LEAST_ONCE,
                               retain=False), include_dtypes=True)

    def close(self):
        self.c.disconnect()


class RawSub:
    """The raw payloads of one topic (paho), for what pysparkplug does not
    expose: a metric's PropertySet, parsed with pysparkplug's protobuf."""

    def __init__(self, broker, topic):
        import paho.mqtt.client as mqtt
        self.msgs = []
        self.c = mqtt.Client()
        self.ok = threading.Event()
        self.c.on_message = lambda c, u, m: self.msgs.append(bytes(m.payload))
        self.c.on_connect = lambda c, u, f, rc: c.subscribe(topic, qos=1)
        self.c.on_subscribe = lambda c, u, mid, q: self.ok.set()
        self.c.connect(GW_ADDR, broker.port, 30)
        self.c.loop_start()
        assert self.ok.wait(timeout(10))

    def close(self):
        self.c.loop_stop()
        self.c.disconnect()


def spb_gateway(name, broker, section="", raw_topic=None):
    """The gateway with [mqtt] payload = sparkplug (and section), started
    once a Host (and a RawSub of raw_topic) listens:
    `with spb_gateway(...) as (g, host[, raw]):`."""
    peers = [lambda: Host(broker)]
    if raw_topic:
        peers.append(lambda: RawSub(broker, raw_topic))
    return started_after(name, peers, extra=spb_section(broker, section))


@pytest.fixture
def broker(request):
    with broker_running(request.node.name) as b:
        yield b


def metric(payload, name):
    return next(m for m in payload.metrics if m.name == name)


def wait_born(host, n=1):
    wait_for(lambda: len(host.all("NBIRTH")) >= n, 20, "NBIRTH")
    wait_for(lambda: len(host.all("DBIRTH", "r0")) >= n, 20, "DBIRTH of r0")
    return host.all("NBIRTH")[-1], host.all("DBIRTH", "r0")[-1]


def drcli(*args):
    out = subprocess.run([str(DRCLI)] + list(args), check=True, capture_output=True, text=True,
                         timeout=timeout(20))
    return json.loads(out.stdout)


def test_births_list_every_field_with_type_and_unit(broker):
    raw_topic = "spBv1.0/%s/DBIRTH/%s/r0" % (GROUP, EDGE)
    with spb_gateway("spb_birth", broker, raw_topic=raw_topic) as (g, host, raw):
        nb, db = wait_born(host)
        assert nb.seq == 0
        assert metric(nb, "bdSeq").datatype == DataType.INT64
        rb = metric(nb, "Node Control/Rebirth")
        assert rb.datatype == DataType.BOOLEAN and rb.value is False
        fields = drcli("list", "--json")["fields"]
        names = {m.name: m for m in db.metrics}
        assert set(names) == {f["path"] for f in fields}
        for f in fields:
            assert names[f["path"]].datatype == TYPES[f["type"]], f
        assert rb.alias is None  # Sparkplug 3.0: Rebirth is never aliased
        aliases = [m.alias for m in db.metrics]
        assert None not in aliases and len(set(aliases)) == len(aliases)
        assert db.timestamp > 1.6e12 and all(m.timestamp for m in db.metrics)
        # engUnit properties, read with the peer's own protobuf module
        wait_for(lambda: raw.msgs, 10, "the raw DBIRTH")
        p = PbPayload.FromString(raw.msgs[-1])
        units = {}
        for m in p.metrics:
            props = dict(zip(m.properties.keys, m.properties.values))
            if "engUnit" in props:
                assert props["engUnit"].type == DataType.STRING
                units[m.name] = props["engUnit"].string_value
        assert units == {f["path"]: f["unit"] for f in fields if f["unit"]}
        assert units["joint_state.position[1]"] == "degree"


STILL = ("io_state.version.major", "io_state.version.minor", "io_state.version.patch",
         "io_state.robot_state", "int_out[3]", "bit_out[5]", "io_state.cb_di[1]",
         "float_in[0]")


def test_values_match_drcli_and_seq_has_no_gap(broker):
    with spb_gateway("spb_values", broker, "publish_interval_ms = 20") as (g, host):
        wait_born(host)
        # drsim moves: DDATA flows
        wait_for(lambda: len(host.all("DDATA", "r0")) >= 20, 20, "20 DDATA")
        robot = drcli("-H", SIM_ADDR, "--port", str(g.sim.tcp), "get", "--json", *STILL)
        vals = host.values()
        for name in STILL:
            assert vals[name] == robot[name], name
        # DDATA carry only aliases (pysparkplug named them from the
        # birth); a noisy field the host has is within the noise of
        # what the robot has
        moved = {m.name for p in host.all("DDATA", "r0") for m in p.metrics}
        assert "io_state.ai[0]" in moved
        ai = drcli("-H", SIM_ADDR, "--port", str(g.sim.tcp), "get", "--json",
                   "io_state.ai[0]")["io_state.ai[0]"]
        assert abs(host.values()["io_state.ai[0]"] - ai) <= 2 * noise_of("io_state.ai[0]")
        # seq: 0 at NBIRTH, +1 (mod 256) on each message after it
        seqs = [p.seq for p in host.all() if hasattr(p, "seq")]
        assert seqs[0] == 0 and len(seqs) > 20
        for a, b in zip(seqs, seqs[1:]):
            assert b == (a + 1) % 256, seqs


def test_rebirth_command(broker):
    with spb_gateway("spb_rebirth", broker) as (g, host):
        nb, _ = wait_born(host)
        bd = metric(nb, "bdSeq").value
        host.send("NCMD", [Metric(timestamp=get_current_timestamp(),
                                  name="Node Control/Rebirth",
                                  datatype=DataType.BOOLEAN, value=True)])
        nb2, db2 = wait_born(host, 2)
        assert nb2.seq == 0 and metric(nb2, "bdSeq").value == bd
        kinds = host.kinds()
        last_nbirth = len(kinds) - 1 - kinds[::-1].index("NBIRTH")
        assert "DBIRTH" in kinds[last_nbirth:]
        assert len(db2.metrics) == len(host.all("DBIRTH", "r0")[0].metrics)


def test_will_has_the_births_bdseq(broker):
    with spb_gateway("spb_will", broker) as (g, host):
        nb, _ = wait_born(host)
        g.proc.kill()  # SIGKILL: no goodbye, the broker sends the Will
        g.proc.wait()
        death = wait_for(lambda: host.all("NDEATH"), 20, "NDEATH (the Will)")[0]
        assert death.bd_seq_metric.name == "bdSeq"
        assert death.bd_seq_metric.value == metric(nb, "bdSeq").value


def test_stop_publishes_ndeath(broker):
    with spb_gateway("spb_stop", broker) as (g, host):
        nb, _ = wait_born(host)
        rc, _ = g.stop()
        assert rc == 0
        death = wait_for(lambda: host.all("NDEATH"), 10, "NDEATH at stop")[0]
        assert death.bd_seq_metric.value == metric(nb, "bdSeq").value


def test_dcmd_write_echoes_through_drsim(broker):
    with spb_gateway("spb_write", broker, "writes = yes") as (g, host):
        _, db = wait_born(host)
        alias = {m.name: m.alias for m in db.metrics}
        ts = get_current_timestamp()
        host.send("DCMD", [Metric(timestamp=ts, name="int_in[0]", datatype=DataType.INT32,
                                  value=42),
                           Metric(timestamp=ts, name="float_in[2]",
                                  datatype=DataType.FLOAT, value=2.5)], device="r0")
        # by alias alone, a negative Int32 (two's complement in int_value)
        host.send("DCMD", [Metric(timestamp=ts, name=None, alias=alias["int_in[1]"],
                                  datatype=DataType.INT32, value=-7)], device="r0")
        wait_for(lambda: host.values().get("int_out[0]") == 42 and
                 host.values().get("int_out[1]") == -7 and
                 host.values().get("float_out[2]") == 2.5, 10, "the echo through drsim")
        robot = drcli("-H", SIM_ADDR, "--port", str(g.sim.tcp), "get", "--json",
                      "int_out[0]", "int_out[1]")
        assert robot == {"int_out[0]": 42, "int_out[1]": -7}
        # refused: a T->O field; the host gets the current value back
        n = len(host.all("DDATA", "r0"))
        before = host.values()["io_state.version.major"]
        host.send("DCMD", [Metric(timestamp=ts, name="io_state.version.major",
                                  datatype=DataType.UINT8, value=99)], device="r0")
        wait_for(lambda: any(m.name == "io_state.version.major"
                             for p in host.all("DDATA", "r0")[n:] for m in p.metrics),
                 10, "the refusal's echo")
        assert host.values()["io_state.version.major"] == before
        g.log_wait("read-only: a T->O field")


def test_dcmd_refused_when_writes_are_off(broker):
    with spb_gateway("spb_nowrite", broker) as (g, host):
        wait_born(host)
        host.send("DCMD", [Metric(timestamp=get_current_timestamp(), name="int_in[4]",
                                  datatype=DataType.INT32, value=9)], device="r0")
        g.log_wait("writes are off")
        time.sleep(timeout(0.5))
        assert host.values()["int_out[4]"] == 0 and host.values()["int_in[4]"] == 0


def test_broker_restart_gives_new_bdseq(broker):
    with spb_gateway("spb_restart", broker) as (g, host):
        nb, _ = wait_born(host)
        host.close()
        mark = len(g.log())
        broker.stop()
        g.log_wait("mqtt: connection to", start=mark)
        # at least one refused attempt meanwhile: it uses no bdSeq up
        g.log_wait("mqtt: cannot connect to", 20, start=mark)
        broker.start(same_port=True)
        with contextlib.closing(Host(broker)) as host:
            nb2, db2 = wait_born(host)
            assert nb2.seq == 0
            assert metric(nb2, "bdSeq").value == (metric(nb, "bdSeq").value + 1) % 256
            assert len(db2.metrics) > 300


def test_robot_link_gives_ddeath_and_dbirth(broker):
    with spb_gateway("spb_link", broker) as (g, host):
        wait_born(host)
        g.sim.kill()
        wait_for(lambda: host.all("DDEATH", "r0"), 30, "DDEATH when the link goes down")
        assert len(host.all("NDEATH")) == 0
        g.sim.start(same_ports=True)
        wait_for(lambda: len(host.all("DBIRTH", "r0")) >= 2, 30, "DBIRTH when it is back")
        kinds = host.kinds()
        assert kinds.index("DDEATH") < len(kinds) - 1 - kinds[::-1].index("DBIRTH")


def test_reload_that_removes_a_robot_kills_its_device(broker):
    """SIGHUP with r0 renamed arm: r0's device gets a DDEATH (else a host
    would keep it alive for ever), then new births name arm."""
    import signal
    with spb_gateway("spb_reload", broker) as (g, host):
        wait_born(host)
        g.write_config(g.config_text().replace("[robot r0]", "[robot arm]"))
        g.signal(signal.SIGHUP)
        wait_for(lambda: "reloaded (generation 1)" in g.log(), 10, "the reload")
        wait_for(lambda: host.all("DDEATH", "r0"), 10, "r0's DDEATH")
        wait_for(lambda: host.all("DBIRTH", "arm"), 20, "arm's DBIRTH")
        kinds = [(k, d) for k, d in zip(host.kinds(), [m[1] for m in host.msgs])]
        assert kinds.index(("DDEATH", "r0")) < kinds.index(("DBIRTH", "arm"))
        seqs = [p.seq for p in host.all() if hasattr(p, "seq")]
        nb = [i for i, k in enumerate(host.kinds()) if k == "NBIRTH"]
        assert len(nb) == 2 and seqs[nb[1]] == 0
        assert not host.all("NDEATH")  # the same connection


def test_primary_host_state_holds_births(broker):
    import paho.mqtt.client as mqtt
    with spb_gateway("spb_primary", broker, "primary_host_id = scada1") as (g, host):
        g.log_wait("mqtt: connected to")
        time.sleep(timeout(1.5))
        assert host.all("NBIRTH") == []
        c = mqtt.Client()
        c.connect(GW_ADDR, broker.port, 30)
        c.loop_start()
        state = json.dumps({"online": True, "timestamp": get_current_timestamp()})
        c.publish("spBv1.0/STATE/scada1", state, qos=1, retain=True).wait_for_publish(
            timeout(5))
        nb, _ = wait_born(host)
        # the host goes offline: NDEATH, a new connection, and no
        # birth until it is back; then births with the next bdSeq
        off = json.dumps({"online": False, "timestamp": get_current_timestamp()})
        c.publish("spBv1.0/STATE/scada1", off, qos=1, retain=True).wait_for_publish(
            timeout(5))
        death = wait_for(lambda: host.all("NDEATH"), 10, "NDEATH")[0]
        assert death.bd_seq_metric.value == metric(nb, "bdSeq").value
        wait_for(lambda: g.log().count("mqtt: connected to") >= 2, 20, "a new connection")
        time.sleep(timeout(1.0))
        assert len(host.all("NBIRTH")) == 1
        # the first online STATE again: older than the offline one, stale
        # (Sparkplug 3.0: a STATE is judged by its timestamp), so no birth
        c.publish("spBv1.0/STATE/scada1", state, qos=1, retain=True).wait_for_publish(
            timeout(5))
        time.sleep(timeout(1.0))
        assert len(host.all("NBIRTH")) == 1
        back = json.dumps({"online": True, "timestamp": get_current_timestamp()})
        c.publish("spBv1.0/STATE/scada1", back, qos=1, retain=True).wait_for_publish(
            timeout(5))
        nb2, _ = wait_born(host, 2)
        assert metric(nb2, "bdSeq").value == (metric(nb, "bdSeq").value + 1) % 256
        # a stale offline (the first offline's timestamp) does not take the
        # node down
        connects = g.log().count("mqtt: connected to")
        c.publish("spBv1.0/STATE/scada1", off, qos=1, retain=True).wait_for_publish(
            timeout(5))
        time.sleep(timeout(1.5))
        assert len(host.all("NDEATH")) == 1
        assert g.log().count("mqtt: connected to") == connects
        c.loop_stop()
        c.disconnect()


MQTT_HEAD = "[robot a]\nhost = 127.0.0.2\n[mqtt]\nhost = 127.0.0.1\n"
BAD = {  # (the [mqtt] keys after host, line, words of the message)
    "no_group": ("payload = sparkplug\n", 5, ["payload = sparkplug needs group_id"]),
    "edge_slash": ("payload = sparkplug\ngroup_id = g1\nedge_node_id = a/b\n", 7,
                   ["edge_node_id 'a/b' invalid", "'+', '#', '/'"]),
    "group_plus": ("payload = sparkplug\ngroup_id = g+1\n", 6, ["group_id 'g+1' invalid"]),
    "host_hash": ("payload = sparkplug\ngroup_id = g\nprimary_host_id = #\n", 7,
                  ["primary_host_id '#' invalid"]),
    "payload": ("payload = protobuf\n", 5, ["payload 'protobuf' invalid", "json, sparkplug"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_config_errors_name_file_and_line(case):
    from gwlib import DRGATEWAYD, EXIT_CONFIG, LOGDIR
    text, line, words = BAD[case]
    LOGDIR.mkdir(parents=True, exist_ok=True)
    p = LOGDIR / ("spb-cfg-%s.ini" % case)
    p.write_text(MQTT_HEAD + text)
    r = subprocess.run([str(DRGATEWAYD), "--check-config", str(p)], capture_output=True,
                       text=True, timeout=timeout(30))
    assert r.returncode == EXIT_CONFIG, r
    assert "%s:%d: " % (p, line) in r.stderr, r.stderr
    for w in words:
        assert w in r.stderr, (w, r.stderr)
