# SPDX-License-Identifier: MIT
"""GET /metrics (issue 21, docs/http.md "Metrics") against a running
gateway and drsim: the text passes promtool check metrics; its values are
the status block's (link up, packets rising per connection, a Modbus
exception counted by its code after a request that got one, a write
counted and shown as the robot's last write); a real Prometheus server
scrapes it and answers a query for the link state, 1 and then 0 once
drsim is killed; /api/v1/log has the log's lines."""
import json
import os
import re
import shutil
import subprocess
import tempfile
import time
import urllib.parse
import urllib.request

import pytest

from gwlib import (EX_ILLEGAL_ADDRESS, GW_ADDR, ModbusError, free_port, running, skip,
                   spawn, timeout, wait_for, LOGDIR)

PROMTOOL = shutil.which("promtool") or "/usr/bin/promtool"
PROMETHEUS = shutil.which("prometheus") or "/usr/bin/prometheus"
SAMPLE = re.compile(r'^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{(.*)\})? (\S+)$')


def http_section():
    port = free_port(GW_ADDR, udp=False)
    return port, "\n[http]\nlisten = %s\nport = %d\n" % (GW_ADDR, port)


def get(port, path):
    with urllib.request.urlopen("http://%s:%d%s" % (GW_ADDR, port, path),
                                timeout=timeout(10)) as r:
        return r.status, r.headers.get("Content-Type"), r.read().decode()


def samples(text):
    """{(name, frozenset of label pairs): value}"""
    out = {}
    for line in text.splitlines():
        if not line or line.startswith("#"):
            continue
        m = SAMPLE.match(line)
        assert m, "not a sample line: %r" % line
        labels = frozenset(re.findall(r'(\w+)="((?:[^"\\]|\\.)*)"', m.group(3) or ""))
        out[(m.group(1), labels)] = float(m.group(4))
    return out


def val(s, name, **labels):
    return s[(name, frozenset(labels.items()))]


@pytest.fixture(scope="module")
def gw():
    port, sect = http_section()
    with running("metrics", extra=sect) as g:
        g.http = port
        wait_for(lambda: g.listening(port), 10, "the console's port")
        yield g


def metrics(g):
    st, ctype, text = get(g.http, "/metrics")
    assert st == 200 and ctype.startswith("text/plain; version=0.0.4"), (st, ctype)
    return text


def test_promtool_check(gw):
    if not os.access(PROMTOOL, os.X_OK):
        skip("promtool", "no promtool (Debian's prometheus package)")
    text = metrics(gw)
    r = subprocess.run([PROMTOOL, "check", "metrics"], input=text, capture_output=True,
                       text=True, timeout=timeout(30))
    assert r.returncode == 0, r.stdout + r.stderr
    # lint findings are printed even with status 0: none wanted
    assert r.stdout.strip() == "" and r.stderr.strip() == "", r.stdout + r.stderr
    # each family's HELP and TYPE once
    types = re.findall(r"^# TYPE (\S+) ", text, re.M)
    assert len(types) == len(set(types)), types


def test_values_match_the_status_block(gw):
    with gw.raw() as m:
        st = m.read(4, 0, 44)
        s1 = samples(metrics(gw))
        assert st[1] == 2 and val(s1, "drgate_link_up", robot="r0") == 1
        assert val(s1, "drgate_link_state", robot="r0") == 2
        assert val(s1, "drgate_link_data_fresh", robot="r0") == 1
        assert val(s1, "drgate_link_last_error_code", robot="r0") == st[12]
        # one counter per connection, by its T->O assembly; their sum is
        # the status block's packet counter (IR 6-7), read around it
        conns = {dict(k[1])["assembly"]: v for k, v in s1.items()
                 if k[0] == "drgate_link_packets_received_total"}
        assert set(conns) == {"io_state", "bit_out", "int_out", "float_out", "joint_state",
                              "task_state"}, conns
        rx_after = m.read(4, 0, 44)
        total = sum(conns.values())
        assert (st[6] << 16 | st[7]) <= total <= (rx_after[6] << 16 | rx_after[7]), \
            (st[6:8], total, rx_after[6:8])
        wait_for(lambda: all(
            samples(metrics(gw))[("drgate_link_packets_received_total",
                                  frozenset({("robot", "r0"), ("assembly", a)}))] > conns[a]
            for a in conns), 10, "every connection's packet counter to rise")
        # a request that gets exception 0x02 is counted under its code
        s2 = samples(metrics(gw))
        key = ("drgate_modbus_exceptions_total",
               frozenset({("transport", "tcp"), ("code", "2")}))
        before = s2.get(key, 0)
        fc4 = ("drgate_modbus_requests_total",
               frozenset({("transport", "tcp"), ("function_code", "4")}))
        with pytest.raises(ModbusError) as e:
            m.read(4, 2040, 8)
        assert e.value.code == EX_ILLEGAL_ADDRESS
        s3 = samples(metrics(gw))
        assert s3[key] == before + 1, (before, s3.get(key))
        assert s3[fc4] > s2[fc4]
        assert val(s3, "drgate_modbus_clients") >= 1
        # a write: counted, logged, and the robot's last write
        me = "%s:%d" % m.sock.getsockname()
        m.write_regs(300, [0, 7])
        s4 = samples(metrics(gw))
        assert val(s4, "drgate_modbus_writes_total", transport="tcp") == \
            val(s3, "drgate_modbus_writes_total", transport="tcp") + 1
        _, _, body = get(gw.http, "/api/v1/robots/r0")
        lw = json.loads(body)["last_write"]
        assert lw["client"] == "modbus " + me and lw["fields"] == ["int_in[0]"], lw
        assert re.match(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z$", lw["time"]), lw
        _, _, body = get(gw.http, "/api/v1/status")
        sides = json.loads(body)["sides"]
        mine = [c for c in sides["modbus"]["clients"] if c["address"] == me]
        assert mine and mine[0]["exceptions"] >= 1 and mine[0]["requests"] >= 4, sides
        assert sides["modbus"]["rtu"] == [] and "gpio" not in sides and "mqtt" not in sides


def test_log_endpoint(gw):
    _, ctype, body = get(gw.http, "/api/v1/log")
    log = json.loads(body)
    assert 0 < len(log) <= 200
    assert any(e["text"].startswith("robot r0: link up") or "link up" in e["text"]
               for e in log), log[-5:]
    assert all(set(e) == {"time", "level", "text"} for e in log)
    assert all(e["level"] in ("error", "warning", "info", "debug") for e in log)
    times = [e["time"] for e in log]
    assert times == sorted(times)


def test_prometheus_scrapes_link_state():
    """A real Prometheus server (1 s scrapes) answers drgate_link_up for
    r0: 1 while linked, 0 after drsim is killed."""
    if not os.access(PROMETHEUS, os.X_OK):
        skip("prometheus", "no prometheus server (Debian's prometheus package)")
    port, sect = http_section()
    with running("metricsprom", extra=sect) as g:
        wait_for(lambda: g.listening(port), 10, "the console's port")
        work = tempfile.mkdtemp(dir=LOGDIR)
        prom_port = free_port(GW_ADDR, udp=False)
        conf = os.path.join(work, "prometheus.yml")
        with open(conf, "w") as f:
            f.write("global:\n  scrape_interval: 1s\n  scrape_timeout: 1s\n"
                    "scrape_configs:\n  - job_name: drgate\n    static_configs:\n"
                    "      - targets: ['%s:%d']\n" % (GW_ADDR, port))
        prom = spawn([PROMETHEUS, "--config.file=" + conf,
                      "--storage.tsdb.path=" + os.path.join(work, "data"),
                      "--web.listen-address=%s:%d" % (GW_ADDR, prom_port),
                      "--log.level=warn"], LOGDIR / "metricsprom.prometheus.log")
        try:
            def query():
                q = urllib.parse.quote('drgate_link_up{robot="r0"}')
                try:
                    with urllib.request.urlopen(
                            "http://%s:%d/api/v1/query?query=%s" % (GW_ADDR, prom_port, q),
                            timeout=timeout(5)) as r:
                        res = json.loads(r.read())["data"]["result"]
                except OSError:
                    return None
                return float(res[0]["value"][1]) if res else None
            wait_for(lambda: query() == 1.0, 60, "Prometheus to see drgate_link_up 1")
            g.sim.kill()
            wait_for(lambda: query() == 0.0, 60, "Prometheus to see drgate_link_up 0")
            s = samples(get(port, "/metrics")[2])
            assert val(s, "drgate_link_up", robot="r0") == 0
            assert val(s, "drgate_link_reconnects_total", robot="r0") >= 1
            assert val(s, "drgate_link_last_error_code", robot="r0") != 0
        finally:
            prom.terminate()
            try:
                prom.wait(timeout(10))
            except subprocess.TimeoutExpired:
                prom.kill()
                prom.wait()
            shutil.rmtree(work, ignore_errors=True)
