# SPDX-License-Identifier: MIT
"""The MQTT northbound side ([mqtt], docs/mqtt.md) against a real broker:
Debian's mosquitto, started here on a free port (and once with TLS, with
a CA and a server certificate made here with openssl), and paho-mqtt as
the plant's independent client. drsim's data must arrive under the
canonical names with the robot's values, changes respect the deadband
and the rate, the Will fires when the gateway dies, plant writes go
through the same checks as Modbus writes (refusals on the error topic),
and a broker that goes away and comes back is survived."""
import contextlib
import json
import math
import signal
import subprocess
import time

import pytest

from gwlib import GW_ADDR, SIM_ADDR, EnipReader, decode_t2o, running, timeout, wait_for

pytest.importorskip("paho.mqtt.client")

from mqttlib import (PREFIX, Plant, broker_running, mqtt_section,  # noqa: E402 (paho)
                     plant_gateway)

@pytest.fixture
def broker(request):
    with broker_running(request.node.name) as b:
        yield b


def wait_up(plant, g=None):
    wait_for(lambda: plant.last(PREFIX + "/status") == "online", 20, "status online")
    wait_for(lambda: plant.last(PREFIX + "/r0/state") == "up", 20, "state up")
    return wait_for(lambda: plant.data(), 20, "a first data message")[0]


def test_snapshot_names_and_values(broker):
    with plant_gateway("mqtt_snapshot", broker) as (g, plant):
        snap = wait_up(plant)
        robot = decode_t2o({i: EnipReader(SIM_ADDR, g.sim.tcp).get(i)
                            for i in (101, 102, 103, 104, 105, 106)})
        # every leaf of the robot's T->O data, by its canonical name
        # (masks such as io_state.cb_di are not leaves)
        for name in robot:
            if name in ("io_state.cb_di", "io_state.cb_do", "io_state.tool_di",
                        "io_state.tool_do", "bit_out"):
                assert name not in snap
            else:
                assert name in snap, name
        for name in ("io_state.version.major", "io_state.version.minor",
                     "io_state.version.patch", "io_state.robot_state",
                     "int_out[3]", "bit_out[5]", "io_state.cb_di[1]"):
            assert snap[name] == robot[name], name
        assert "float_in[0]" in snap and "io_control.ao[0]" in snap  # O->T too
        # units: the retained meta topic
        meta = json.loads(wait_for(lambda: plant.last(PREFIX + "/r0/meta"), 10, "meta"))
        assert meta["joint_state.position[1]"] == {"type": "REAL", "unit": "degree",
                                                   "dir": "T->O"}
        assert meta["float_in[0]"]["dir"] == "O->T"
        assert set(meta) == set(snap)


def test_plant_write_echoes_through_drsim(broker):
    with plant_gateway("mqtt_write", broker, "writes = yes") as (g, plant):
        wait_up(plant)
        plant.set("float_in[3]", "2.5")
        plant.set("int_in[5]", "-7")
        plant.set("bit_in[9]", "1")
        wait_for(lambda: plant.merged().get("float_out[3]") == 2.5 and
                 plant.merged().get("int_out[5]") == -7 and
                 plant.merged().get("bit_out[9]") == 1, 10, "the echo of the writes")
        assert plant.merged()["float_in[3]"] == 2.5
        # the robot itself has it (read beside the gateway)
        robot = decode_t2o({i: EnipReader(SIM_ADDR, g.sim.tcp).get(i)
                            for i in (101, 102, 103, 104, 105, 106)})
        assert robot["int_out[5]"] == -7
        assert plant.all(PREFIX + "/r0/error") == []


def errors(plant):
    return [json.loads(p) for _, p, _ in plant.all(PREFIX + "/r0/error")]


def test_refused_writes_are_reported(broker):
    with plant_gateway("mqtt_refused", broker, "writes = yes") as (g, plant):
        wait_up(plant)
        bad = [("float_in[0]", "nan", "non-finite"),
               ("int_in[0]", "1.5", "invalid value"),
               ("bit_in[0]", "2", "invalid value"),
               ("joint_state.position[1]", "1", "read-only"),
               ("float_inn[0]", "1", "did you mean float_in[0]"),
               ("int_in[1]", "", "payload")]
        # a burst: every refusal gets its reply, even when they arrive
        # together (libmosquitto queues what is published from within
        # its read)
        for path, value, _ in bad * 3:
            plant.set(path, value, wait=False)
        wait_for(lambda: len(errors(plant)) == 3 * len(bad), 10, "one error per refused write")
        for (path, value, why), e in zip(bad * 3, errors(plant)):
            assert e["topic"] == "%s/r0/set/%s" % (PREFIX, path)
            assert e["payload"] == value
            assert why in e["error"].lower() or why in e["error"], (why, e)
        # nothing of it reached the robot's image
        plant.set("int_in[2]", "5")
        wait_for(lambda: plant.merged().get("int_out[2]") == 5, 10, "a good write after")
        m = plant.merged()
        assert m["int_in[0]"] == 0 and m["bit_in[0]"] == 0
        assert not (isinstance(m["float_in[0]"], float) and math.isnan(m["float_in[0]"]))


def test_single_writer_mode_refuses_plant_writes(broker):
    with plant_gateway("mqtt_single", broker,
                       "writes = yes", modbus="single_writer = yes") as (g, plant):
        wait_up(plant)
        plant.set("int_in[0]", "3")
        e = wait_for(lambda: errors(plant), 10, "the refusal")[0]
        assert "single-writer" in e["error"]


def test_writes_off_by_default(broker):
    with plant_gateway("mqtt_nowrite", broker) as (g, plant):
        wait_up(plant)
        plant.set("int_in[4]", "9")
        time.sleep(timeout(1.0))  # nothing is to happen: give it the chance
        assert plant.merged().get("int_out[4]") == 0
        assert errors(plant) == []


def test_deadband_and_rate(broker):
    with plant_gateway("mqtt_deadband", broker, "writes = yes\ndeadband = 1.0") as (g, plant):
        wait_up(plant)
        plant.set("float_in[0]", "10")
        wait_for(lambda: plant.merged().get("float_out[0]") == 10, 10, "float_out[0] = 10")
        plant.set("float_in[0]", "10.5")  # within the deadband
        plant.set("int_in[0]", "1")       # integers: every change
        wait_for(lambda: plant.merged().get("int_out[0]") == 1, 10, "int_out[0] = 1")
        # the images went 10 -> 10.5 before int_out[0] changed: not published
        assert all(d.get("float_out[0]") in (None, 0, 10) for d in plant.data())
        assert all(d.get("float_in[0]") in (None, 0, 10) for d in plant.data())
        plant.set("float_in[0]", "11.5")  # 1.5 from what was published
        wait_for(lambda: plant.merged().get("float_out[0]") == 11.5, 10, "11.5")


def test_rate(broker):
    """drsim's noise changes data every RPI (10 ms); with deadband 0 the
    gateway publishes it, but at most once per publish_interval_ms."""
    with plant_gateway("mqtt_rate", broker, "publish_interval_ms = 200") as (g, plant):
        wait_up(plant)
        n0, t0 = len(plant.data()), time.monotonic()
        time.sleep(2.0)
        n, dt = len(plant.data()) - n0, time.monotonic() - t0
        assert 2 <= n <= dt / 0.2 + 2, (n, dt)


def test_will_when_killed_offline_when_stopped(broker):
    with plant_gateway("mqtt_lwt", broker) as (g, plant):
        wait_up(plant)
        g.proc.kill()
        g.proc.wait()
        wait_for(lambda: plant.last(PREFIX + "/status") == "offline", 20,
                 "the Will (status offline)")
        # retained: a plant that connects later sees it too
        late = Plant(broker)
        try:
            wait_for(lambda: late.all(PREFIX + "/status"), 10, "the retained status")
            assert late.all(PREFIX + "/status")[-1][1:] == ("offline", True)
        finally:
            late.close()
        g.start()
        wait_for(lambda: plant.last(PREFIX + "/status") == "online", 20, "online again")
        n = len(plant.all(PREFIX + "/status"))
        rc, _ = g.stop()
        assert rc == 0
        wait_for(lambda: len(plant.all(PREFIX + "/status")) > n, 10, "status at stop")
        assert plant.last(PREFIX + "/status") == "offline"


def test_broker_restart_is_survived(broker):
    with plant_gateway("mqtt_restart", broker) as (g, plant):
        wait_up(plant)
        plant.close()
        mark = len(g.log())
        broker.stop()
        # Modbus and the robot link do not care
        for _ in range(5):
            assert g.status()[1] == 2
            time.sleep(timeout(0.2))
        g.log_wait("mqtt: connection to", start=mark)
        broker.start(same_port=True)
        with contextlib.closing(Plant(broker)) as plant:
            # published afresh (the broker forgot its retained messages);
            # the gateway may have reconnected before this plant subscribed,
            # so the retained topics are what is sure to be seen, then data
            wait_up(plant)
            assert wait_for(lambda: plant.last(PREFIX + "/r0/meta"), 10, "meta again")
            assert g.alive() and g.status()[1] == 2


def openssl(*args, cwd):
    subprocess.run(["openssl"] + list(args), cwd=cwd, check=True, capture_output=True,
                   timeout=timeout(60))


@pytest.fixture
def tls_files(tmp_path):
    """A CA and a server certificate for 127.0.0.1 (EC P-256: fast)."""
    d = tmp_path
    openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
            "-nodes", "-keyout", "ca.key", "-out", "ca.crt", "-days", "2", "-subj",
            "/CN=drgate test CA", cwd=d)
    openssl("req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
            "-keyout", "server.key", "-out", "server.csr", "-subj", "/CN=127.0.0.1", cwd=d)
    (d / "ext.cnf").write_text("subjectAltName=IP:127.0.0.1\n")
    openssl("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key",
            "-CAcreateserial", "-out", "server.crt", "-days", "2", "-extfile", "ext.cnf",
            cwd=d)
    return {"ca": d / "ca.crt", "cert": d / "server.crt", "key": d / "server.key"}


def test_tls(request, tls_files):
    with broker_running(request.node.name, tls=tls_files) as b, \
            plant_gateway("mqtt_tls", b, "ca_file = %s" % tls_files["ca"],
                          tls_ca=tls_files["ca"]) as (g, plant):
        snap = wait_up(plant)
        assert "io_state.robot_state" in snap
        assert "connected to" in g.log()


def test_tls_failure_says_why(request, tls_files, tmp_path):
    """A CA that did not sign the broker's certificate: the connection
    fails, and the log says it is TLS (docs/mqtt.md, Broker loss)."""
    openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
            "-nodes", "-keyout", "other.key", "-out", "other.crt", "-days", "2", "-subj",
            "/CN=another CA", cwd=tmp_path)
    with broker_running(request.node.name, tls=tls_files) as b:
        extra = mqtt_section(b, "ca_file = %s" % (tmp_path / "other.crt"))
        with running("mqtt_tls_bad", extra=extra) as g:
            g.log_wait("mqtt: cannot connect to %s:%d: TLS failure" % (GW_ADDR, b.port), 20)
            assert "connected to" not in g.log()


def test_tls_by_host_name(request, tls_files, tmp_path):
    """A server given by a host name is connected by the address looked up
    (resolve.c), its certificate checked against the name (OpenSSL, as
    libmosquitto did when it resolved the name itself): `localhost` with a
    certificate for DNS:localhost connects; with one for IP:127.0.0.1
    only, it is a TLS failure, never connected."""
    d = tmp_path
    openssl("req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
            "-keyout", "named.key", "-out", "named.csr", "-subj", "/CN=localhost", cwd=d)
    (d / "named.cnf").write_text("subjectAltName=DNS:localhost\n")
    openssl("x509", "-req", "-in", "named.csr", "-CA", tls_files["ca"], "-CAkey",
            tls_files["ca"].parent / "ca.key", "-CAcreateserial", "-out", "named.crt", "-days",
            "2", "-extfile", "named.cnf", cwd=d)
    named = {"ca": tls_files["ca"], "cert": d / "named.crt", "key": d / "named.key"}
    # The broker on both loopbacks: Debian's /etc/hosts names ::1
    # localhost too, and a TLS connection by name is made by libmosquitto
    # to the first address it finds (docs/mqtt.md "TLS")
    for files, ok in ((named, True), (tls_files, False)):
        with broker_running(request.node.name, tls=files, ipv6=True) as b:
            extra = mqtt_section(b, "ca_file = %s" % files["ca"]).replace(
                "host = %s" % GW_ADDR, "host = localhost")
            with running("mqtt_tls_name", extra=extra) as g:
                if ok:
                    g.log_wait("mqtt: connected to localhost:%d" % b.port, 20)
                else:
                    g.log_wait("mqtt: cannot connect to localhost:%d: TLS failure" % b.port, 20)
                    assert "connected to" not in g.log()


def test_reload(broker):
    """SIGHUP: an unchanged [mqtt] keeps its connection and publishes afresh;
    a changed one reconnects (offline, then online); one whose
    password_file cannot be read is refused and the running one kept."""
    with plant_gateway("mqtt_reload", broker) as (g, plant):
        wait_up(plant)
        connects = lambda: g.log().count("mqtt: connected to")
        assert connects() == 1
        states = len(plant.all(PREFIX + "/r0/state"))
        g.signal(signal.SIGHUP)
        wait_for(lambda: "reloaded (generation 1)" in g.log(), 10, "reload 1")
        wait_for(lambda: len(plant.all(PREFIX + "/r0/state")) > states, 10, "state again")
        assert connects() == 1
        g.extra = mqtt_section(broker, "publish_interval_ms = 50")
        g.write_config()
        n = len(plant.all(PREFIX + "/status"))
        g.signal(signal.SIGHUP)
        wait_for(lambda: connects() == 2, 10, "a new connection")
        wait_for(lambda: [p for _, p, _ in plant.all(PREFIX + "/status")][n:] ==
                 ["offline", "online"], 10, "offline, then online")
        g.extra = mqtt_section(broker, "username = u\npassword_file = /nonexistent/pw")
        g.write_config()
        mark = len(g.log())
        g.signal(signal.SIGHUP)
        g.log_wait("reload refused", start=mark)
        assert "/nonexistent/pw" in g.log()[mark:]
        assert g.alive() and connects() == 2
        assert plant.last(PREFIX + "/status") == "online"
