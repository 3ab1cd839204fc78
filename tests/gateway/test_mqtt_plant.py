# SPDX-License-Identifier: MIT
"""MQTT for a plant dashboard (docs/mqtt.md): a subscriber that arrives
late gets the robot's full state at once (the retained snapshot); every
data message carries the time of the robot packet, the quality and the
names of enum values; meta's type names are the ones docs/mqtt.md lists;
a robot removed by a reload, and the topics of a prefix a reload moves,
do not stay `up`; deliberate disconnects log at info, failed connects say
why; refused writes are rate-limited in the log; 1.5 for a DINT is "not
an integer". Debian's mosquitto and paho-mqtt as in test_mqtt.py."""
import datetime
import json
import re
import signal
import time
from pathlib import Path

import pytest

from gwlib import GW_ADDR, SIM_ADDR, EnipReader, decode_t2o, free_port, running, timeout, \
    wait_for

pytest.importorskip("paho.mqtt.client")

from mqttlib import (PREFIX, Plant, broker_running, mqtt_section,  # noqa: E402 (paho)
                     plant_gateway)

DOCS = Path(__file__).resolve().parents[2] / "docs" / "mqtt.md"
RETIRED = "down: removed from the configuration"
# dr_robot_state_t (lib/include/drgate/codec.h), as docs/assemblies.md names them
STATE_NAMES = ["INITIALIZING", "STANDBY", "OPERATING", "SAFE_OFF", "TEACHING", "SAFE_STOP",
               "EMERGENCY_STOP", "HOMING", "RECOVERY", "SAFE_STOP2", "SAFE_OFF2"]


def wait_up(plant, prefix=PREFIX, robot="r0"):
    wait_for(lambda: plant.last(prefix + "/status") == "online", 20, "status online")
    wait_for(lambda: plant.last("%s/%s/state" % (prefix, robot)) == "up", 20, "state up")
    return wait_for(lambda: plant.messages(robot), 20, "a first data message")[0]


def retained(broker, wait_topic, settle=0.3):
    """What a subscriber that connects now gets at once: the retained
    messages, {topic: payload} (an empty payload would be no message)."""
    late = Plant(broker)
    try:
        wait_for(lambda: late.all(wait_topic), 10, "the retained %s" % wait_topic)
        time.sleep(timeout(settle))  # the broker sends them all together
        return {t: p for t, p, r in late.all() if r}
    finally:
        late.close()


@pytest.fixture(scope="module")
def cell():
    """One broker, drsim and a gateway with writes for the module's
    tests that only look (and write int_in / float_in registers)."""
    with broker_running("mqtt_plant") as b, \
            plant_gateway("mqtt_plant", b, "writes = yes") as (g, plant):
        wait_up(plant)
        yield b, g, plant


@pytest.fixture
def broker(request):
    with broker_running(request.node.name) as b:
        yield b


def robot_now(g):
    return decode_t2o({i: EnipReader(SIM_ADDR, g.sim.tcp).get(i)
                       for i in (101, 102, 103, 104, 105, 106)})


def test_late_subscriber_gets_the_full_state(cell):
    b, g, plant = cell
    snap = json.loads(retained(b, PREFIX + "/r0/snapshot")[PREFIX + "/r0/snapshot"])
    meta = json.loads(plant.last(PREFIX + "/r0/meta"))
    # every field at once, the same keys as meta (and as the first data)
    assert set(snap["values"]) == set(meta)
    assert set(snap["values"]) == set(plant.messages()[0]["values"])
    # fields that do not move (the snapshot may be a second behind drsim,
    # whose state and DI1 change during its first 3 s)
    robot = robot_now(g)
    for name in ("io_state.version.major", "io_state.version.minor", "io_state.version.patch",
                 "int_out[3]"):
        assert snap["values"][name] == robot[name], name
    assert snap["quality"] == "fresh"
    assert snap["names"]["io_state.robot_state"] == \
        STATE_NAMES[snap["values"]["io_state.robot_state"]]
    # a change reaches the retained snapshot (at most a second later), so a
    # subscriber that comes after it starts from the new value
    plant.set("int_in[2]", "5")
    wait_for(lambda: plant.merged().get("int_out[2]") == 5, 10, "the echo of int_in[2]")
    wait_for(lambda: json.loads(plant.last(PREFIX + "/r0/snapshot"))["values"]
             .get("int_out[2]") == 5, 10, "the snapshot with int_out[2] = 5")
    snap = json.loads(retained(b, PREFIX + "/r0/snapshot")[PREFIX + "/r0/snapshot"])
    assert snap["values"]["int_in[2]"] == 5 and snap["values"]["int_out[2]"] == 5
    # at most one snapshot a second while drsim's noise changes data
    n0, t0 = len(plant.all(PREFIX + "/r0/snapshot")), time.monotonic()
    time.sleep(2.0)
    n, dt = len(plant.all(PREFIX + "/r0/snapshot")) - n0, time.monotonic() - t0
    assert 1 <= n <= dt + 1, (n, dt)


def iso_time(text):
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", text), text
    return datetime.datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ").replace(
        tzinfo=datetime.timezone.utc).timestamp()


def test_data_carries_time_quality_and_names(cell):
    b, g, plant = cell
    n0 = len(plant.messages())
    wait_for(lambda: len(plant.messages()) >= n0 + 5, 10, "five more data messages")
    with plant.lock:
        msgs = [(json.loads(p), w) for (t, p, _), w in zip(plant.msgs, plant.walls)
                if t == PREFIX + "/r0/data"]
    last = 0.0
    for m, arrived in msgs[n0:]:
        assert set(m) <= {"time", "quality", "age_ms", "values", "names"}, m.keys()
        t = iso_time(m["time"])
        # the robot packet came before the message reached the plant (same
        # clock, ms resolution), and not long before: fresh data
        assert arrived - timeout(2.0) <= t <= arrived + 0.002, (m["time"], arrived)
        assert t >= last  # packets in order
        last = t
        assert m["quality"] == "fresh" and isinstance(m["age_ms"], int), m
        assert 0 <= m["age_ms"] < 1000 * timeout(1), m
        for path, name in m.get("names", {}).items():
            assert STATE_NAMES[m["values"][path]] == name
    # the first (full) message names the robot's state as drsim has it
    first = plant.messages()[0]
    state = robot_now(g)["io_state.robot_state"]
    assert first["names"] == {"io_state.robot_state": STATE_NAMES[first["values"][
        "io_state.robot_state"]]}
    assert first["names"]["io_state.robot_state"] in STATE_NAMES
    assert state in range(len(STATE_NAMES))


def test_meta_type_names_are_the_documented_ones(cell):
    _, _, plant = cell
    meta = json.loads(plant.last(PREFIX + "/r0/meta"))
    text = DOCS.read_text()
    section = text[text.index("### meta"):]
    section = section[:section.index("\n## ")]
    documented = re.findall(r"^\| `([A-Z]+)` \|", section, re.M)
    assert documented, "no type table under docs/mqtt.md's ### meta"
    assert {m["type"] for m in meta.values()} == set(documented)
    assert meta["io_state.servo_on"]["type"] == "BIT"
    assert meta["io_state.cb_di[1]"]["type"] == "BITS"
    assert meta["io_state.robot_state"]["type"] == "ENUM"


def test_dint_written_as_a_fraction_is_not_an_integer(cell):
    _, _, plant = cell
    n = len(plant.all(PREFIX + "/r0/error"))
    plant.set("int_in[0]", "1.5")
    wait_for(lambda: len(plant.all(PREFIX + "/r0/error")) > n, 10, "the refusal")
    err = json.loads(plant.all(PREFIX + "/r0/error")[n][1])["error"]
    assert "not an integer" in err and "DINT" in err and "int_in[0]" in err, err
    assert "malformed" not in err


def test_snapshot_goes_stale_when_the_link_drops(broker):
    with plant_gateway("mqtt_stale", broker) as (g, plant):
        wait_up(plant)
        wait_for(lambda: plant.last(PREFIX + "/r0/snapshot"), 10, "a snapshot")
        g.sim.kill()
        wait_for(lambda: plant.last(PREFIX + "/r0/state").startswith("down"), 20,
                 "state down")
        snap = wait_for(lambda: [s for s in plant.messages(leaf="snapshot")
                                 if s["quality"] == "stale"], 10, "a stale snapshot")[0]
        assert isinstance(snap["age_ms"], int) and snap["time"] is not None
        assert len(snap["values"]) == len(plant.messages()[0]["values"])
        # what a subscriber that comes now gets: stale, not current
        late = json.loads(retained(broker, PREFIX + "/r0/snapshot")[PREFIX + "/r0/snapshot"])
        assert late["quality"] == "stale"


def test_removed_robot_and_moved_prefix_are_retired(broker):
    with plant_gateway("mqtt_retire", broker) as (g, plant):
        wait_up(plant)
        wait_for(lambda: plant.last(PREFIX + "/r0/snapshot"), 10, "a snapshot")
        # the robot is renamed: r0 is gone, arm is new
        text = g.config_text().replace("[robot r0]", "[robot arm]")
        g.write_config(text)
        g.signal(signal.SIGHUP)
        wait_for(lambda: "reloaded (generation 1)" in g.log(), 10, "reload 1")
        wait_for(lambda: plant.last(PREFIX + "/r0/state") == RETIRED, 10,
                 "r0's state retired")
        wait_up(plant, robot="arm")
        kept = retained(broker, PREFIX + "/arm/state")
        assert kept[PREFIX + "/r0/state"] == RETIRED
        assert PREFIX + "/r0/meta" not in kept and PREFIX + "/r0/snapshot" not in kept
        assert kept[PREFIX + "/arm/state"] == "up" and PREFIX + "/arm/meta" in kept
        # the prefix moves: nothing under the old one may stay up
        wait_for(lambda: plant.last(PREFIX + "/arm/snapshot"), 10, "arm's snapshot")
        g.write_config(text.replace("topic_prefix = %s" % PREFIX,
                                    "topic_prefix = drgate/moved"))
        g.signal(signal.SIGHUP)
        wait_for(lambda: "reloaded (generation 2)" in g.log(), 10, "reload 2")
        wait_for(lambda: plant.last(PREFIX + "/status") == "offline", 10, "offline")
        kept = retained(broker, PREFIX + "/status")
        assert kept[PREFIX + "/status"] == "offline"
        assert kept[PREFIX + "/arm/state"] == RETIRED
        assert not [t for t in kept if t.endswith(("/meta", "/snapshot"))], kept
        assert "up" not in kept.values()


def test_deliberate_disconnects_log_at_info(broker):
    with plant_gateway("mqtt_goodbye", broker) as (g, plant):
        wait_up(plant)
        g.extra = mqtt_section(broker, "publish_interval_ms = 50")
        g.write_config()
        g.signal(signal.SIGHUP)
        wait_for(lambda: g.log().count("mqtt: connected to") == 2, 10, "reconnected")
        rc, _ = g.stop()
        assert rc == 0
        log = g.log()
        assert "lost" not in log and "warning: mqtt" not in log, log
        assert re.search(r"info: mqtt: disconnected from [\d.:]+ \(reload", log), log
        assert re.search(r"info: mqtt: disconnected from [\d.:]+ \(the daemon stops\)",
                         log), log


def test_failed_connect_says_why():
    port = free_port(GW_ADDR, udp=False)  # nothing listens there
    extra = ("\n[mqtt]\nhost = %s\nport = %d\ntopic_prefix = %s\n" % (GW_ADDR, port, PREFIX))
    with running("mqtt_refused", extra=extra) as g:
        g.log_wait("mqtt: cannot connect to %s:%d: Connection refused" % (GW_ADDR, port))
        g.extra = extra.replace("host = %s" % GW_ADDR, "host = no-such-host.invalid")
        g.write_config()
        mark = len(g.log())
        g.signal(signal.SIGHUP)
        g.log_wait("mqtt: cannot connect to no-such-host.invalid:%d: cannot resolve the host "
                   "name (" % port, start=mark)
        assert g.alive()


def test_refused_writes_are_rate_limited(broker):
    with plant_gateway("mqtt_flood", broker, "writes = yes") as (g, plant):
        wait_up(plant)
        for _ in range(2000):
            plant.set("int_in[1]", "x", wait=False)
        plant.set("int_in[3]", "4")  # after them on the same connection
        wait_for(lambda: plant.merged().get("int_out[3]") == 4, 20, "the good write")
        shown = g.log().count("refused:")
        assert 1 <= shown <= 2, shown
        rc, _ = g.stop()
        assert rc == 0
        log = g.log()
        assert log.count("refused:") <= 3
        held = [int(n) for n in re.findall(
            r"refused: .*\[(\d+) similar messages? suppressed", log)]
        assert held and sum(held) >= 1000, log[-2000:]
