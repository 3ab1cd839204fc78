# SPDX-License-Identifier: MIT
"""MQTT peers for tests/gateway/test_mqtt.py and bench/mqtt_bench.py: Debian's
mosquitto broker started from a generated configuration on a free
loopback port, a paho-mqtt client playing the plant, and a gateway started
only once its MQTT peers listen (test_sparkplug.py's too)."""
import contextlib
import json
import shutil
import socket
import threading
import time

import paho.mqtt.client as mqtt

from gwlib import GW_ADDR, LOGDIR, free_port, read_text, running, spawn, timeout, wait_for

MOSQUITTO = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
PREFIX = "drgate/test"


class Broker:
    """mosquitto -c <generated conf> on 127.0.0.1:<free port>, no
    persistence (a restart forgets retained messages); or on addr:port in
    network namespace netns (test_mqtt_failover.py)."""

    def __init__(self, name, tls=None, addr=GW_ADDR, port=None, netns=None, ipv6=False):
        self.name = name
        self.ipv6 = ipv6  # also on [::1]:port (where it can be bound)
        self.tls = tls  # dict of cafile/certfile/keyfile, or None
        self.addr, self.port, self.netns = addr, port, netns
        self.proc = None
        self.conf = LOGDIR / ("%s.mosquitto.conf" % name)
        self.log_path = LOGDIR / ("%s.mosquitto.log" % name)

    def start(self, same_port=False):
        if self.netns is None and (not same_port or self.port is None):
            self.port = free_port(GW_ADDR, udp=False)
        text = ("per_listener_settings false\nallow_anonymous true\n"
                "persistence false\nuser root\nlistener %d %s\n" % (self.port, self.addr))
        tls = "cafile %s\ncertfile %s\nkeyfile %s\n" % (
            self.tls["ca"], self.tls["cert"], self.tls["key"]) if self.tls else ""
        text += tls
        if self.ipv6 and loopback6_bindable():
            text += "listener %d ::1\n%s" % (self.port, tls)
        LOGDIR.mkdir(parents=True, exist_ok=True)
        self.conf.write_text(text)
        mark = len(read_text(self.log_path))
        ns = ["ip", "netns", "exec", self.netns] if self.netns else []
        self.proc = spawn(ns + [MOSQUITTO, "-c", str(self.conf), "-v"], self.log_path)
        wait_for(lambda: self.proc.poll() is not None or
                 " running" in read_text(self.log_path)[mark:], 10, "mosquitto to start")
        assert self.proc.poll() is None, read_text(self.log_path)[-2000:]
        return self

    def stop(self):
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(timeout(10))


def loopback6_bindable():
    try:
        with socket.socket(socket.AF_INET6, socket.SOCK_STREAM) as s:
            s.bind(("::1", 0))
        return True
    except OSError:
        return False


@contextlib.contextmanager
def broker_running(name, tls=None, ipv6=False):
    """A started Broker, stopped on the way out."""
    b = Broker(name, tls=tls, ipv6=ipv6).start()
    try:
        yield b
    finally:
        b.stop()


class Plant:
    """A paho client subscribed to <PREFIX>/#: every message kept as
    (topic, payload text, retained)."""

    def __init__(self, broker, tls_ca=None, addr=GW_ADDR):
        self.msgs = []
        self.times = []  # time.monotonic() of each message's arrival
        self.walls = []  # time.time() of the same
        self.lock = threading.Lock()
        self.c = mqtt.Client()
        if tls_ca:
            self.c.tls_set(ca_certs=str(tls_ca))
        self.subscribed = threading.Event()
        self.c.on_message = self._on_message
        self.c.on_connect = lambda c, u, f, rc: c.subscribe(PREFIX + "/#", qos=1)
        self.c.on_subscribe = lambda c, u, mid, qos: self.subscribed.set()
        self.c.connect(addr, broker.port, 30)
        self.c.loop_start()
        # what the gateway publishes from now on (its snapshot) is seen
        assert self.subscribed.wait(timeout(10)), "no SUBACK from the broker"

    def _on_message(self, c, u, m):
        with self.lock:
            self.msgs.append((m.topic, m.payload.decode("utf-8", "replace"), m.retain))
            self.times.append(time.monotonic())
            self.walls.append(time.time())

    def all(self, topic=None):
        with self.lock:
            return [m for m in self.msgs if topic is None or m[0] == topic]

    def last(self, topic):
        ms = self.all(topic)
        return ms[-1][1] if ms else None

    def messages(self, robot="r0", leaf="data"):
        """The robot's data (or snapshot) messages as sent: time, quality,
        age_ms, values, names."""
        return [json.loads(p) for _, p, _ in self.all("%s/%s/%s" % (PREFIX, robot, leaf))
                if p]

    def data(self, robot="r0"):
        """The values of each data message (canonical path: value)."""
        return [m["values"] for m in self.messages(robot)]

    def merged(self, robot="r0"):
        """The robot's fields as the plant knows them from all data so far."""
        out = {}
        for d in self.data(robot):
            out.update(d)
        return out

    def set(self, path, value, robot="r0", wait=True):
        """wait=False: QoS 0, not waiting: a burst reaches the gateway in
        as few reads as the network makes it."""
        info = self.c.publish("%s/%s/set/%s" % (PREFIX, robot, path), value,
                              qos=1 if wait else 0)
        if wait:
            info.wait_for_publish(timeout(5))

    def close(self):
        self.c.loop_stop()
        self.c.disconnect()


def mqtt_section(broker, extra=""):
    return ("\n[mqtt]\nhost = %s\nport = %d\ntopic_prefix = %s\nkeepalive_s = 5\n%s\n"
            % (GW_ADDR, broker.port, PREFIX, extra))


@contextlib.contextmanager
def started_after(name, peers, **running_kw):
    """running(name, start=False, **running_kw), then each of peers (a
    function that returns a connected client with close()) called, then
    the gateway started: the clients see its first messages. Yields
    (g, client, ...); the clients are closed, the last first, before
    running() kills the gateway."""
    with running(name, start=False, **running_kw) as g, contextlib.ExitStack() as stack:
        clients = [stack.enter_context(contextlib.closing(peer())) for peer in peers]
        g.start()
        yield (g, *clients)


def plant_gateway(name, broker, section="", tls_ca=None, **running_kw):
    """started_after() with a Plant and [mqtt] = mqtt_section(broker,
    section): `with plant_gateway(...) as (g, plant):`."""
    return started_after(name, [lambda: Plant(broker, tls_ca=tls_ca)],
                         extra=mqtt_section(broker, section), **running_kw)
