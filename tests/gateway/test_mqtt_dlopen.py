# SPDX-License-Identifier: MIT
"""libmosquitto is loaded at run time, only for [mqtt] (gateway/mqtt/mqtt_lib.c,
docs/mqtt.md): a gateway without [mqtt] maps neither libmosquitto nor the
libssl/libcrypto it pulls in (what keeps its idle RSS under the goal of
docs/performance.md), one with [mqtt] does, and a library that cannot be
loaded (DRGATE_MOSQUITTO_LIB, drgatewayd(8)) stops the start, or refuses
the reload that adds [mqtt], with an error that names it."""
import os
import signal
import subprocess

import pytest

from gwlib import (DRGATEWAYD, EXIT_RUNTIME, GW_ADDR, LOGDIR, free_port, running, timeout,
                   wait_for)

pytest.importorskip("paho.mqtt.client")

from mqttlib import Broker, mqtt_section  # noqa: E402 (needs paho)

MQTT_LIBS = ("libmosquitto", "libssl", "libcrypto")


def mapped(pid):
    """The names of the files the process maps that MQTT would bring."""
    with open("/proc/%d/maps" % pid) as f:
        paths = {line.split()[-1] for line in f if "/" in line}
    return sorted(p for p in paths if any(lib in os.path.basename(p) for lib in MQTT_LIBS))


def test_without_mqtt_no_libmosquitto_mapped():
    with running("mqtt_dl_none") as g:
        assert mapped(g.proc.pid) == []
        assert "mqtt" not in g.log()


def test_with_mqtt_libmosquitto_mapped(request):
    """The counterpart: the same check sees the library when it is used."""
    b = Broker(request.node.name).start()
    try:
        with running("mqtt_dl_used", extra=mqtt_section(b)) as g:
            wait_for(lambda: "mqtt: connected to" in g.log(), 20, "mqtt connected")
            assert any("libmosquitto" in p for p in mapped(g.proc.pid))
    finally:
        b.stop()


def bad_lib_env(lib):
    env = dict(os.environ)
    env["DRGATE_MOSQUITTO_LIB"] = lib
    return env


def start_config(name, mqtt=True):
    LOGDIR.mkdir(parents=True, exist_ok=True)
    conf = LOGDIR / ("%s.ini" % name)
    text = ("[modbus]\nlisten = %s\nport = %d\n\n[robot r0]\nhost = 127.0.0.2\n"
            % (GW_ADDR, free_port(GW_ADDR, udp=False)))
    if mqtt:
        # nothing listens there: the load fails before any connection
        text += "\n[mqtt]\nhost = %s\nport = %d\n" % (GW_ADDR, free_port(GW_ADDR, udp=False))
    conf.write_text(text)
    return conf


@pytest.mark.parametrize("lib,why", [
    ("/nonexistent/libmosquitto.so.1", "cannot open shared object file"),
    ("libc.so.6", "no mosquitto_lib_init"),
])
def test_missing_library_stops_the_start(lib, why):
    conf = start_config("mqtt_dl_missing")
    p = subprocess.run([str(DRGATEWAYD), "-c", str(conf)], env=bad_lib_env(lib),
                       stdin=subprocess.DEVNULL, capture_output=True, text=True,
                       timeout=timeout(30))
    assert p.returncode == EXIT_RUNTIME, p.stderr
    line = [ln for ln in p.stderr.splitlines() if "error: mqtt:" in ln]
    assert len(line) == 1, p.stderr
    assert ("mqtt: cannot load %s" % lib) in line[0]
    assert why in line[0]
    assert line[0].endswith("install libmosquitto1, or remove [mqtt]")
    assert "running" not in p.stderr


def test_missing_library_refuses_the_reload():
    """A reload that adds [mqtt] is refused, the running gateway kept."""
    with running("mqtt_dl_reload", start=False) as g:
        g.start(env=bad_lib_env("/nonexistent/libmosquitto.so.1"))
        g.extra = "\n[mqtt]\nhost = %s\nport = 1\n" % GW_ADDR
        g.write_config()
        mark = len(g.log())
        g.signal(signal.SIGHUP)
        g.log_wait("reload refused", start=mark)
        assert "mqtt: cannot load /nonexistent/libmosquitto.so.1" in g.log()[mark:]
        assert g.alive() and g.listening()
        assert mapped(g.proc.pid) == []
        g.wait_link(True)
