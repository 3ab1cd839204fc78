# SPDX-License-Identifier: MIT
"""The console's second round (issue 33) through its API, against a running
gateway (two robots: r0 on drsim, `down` pointing at a port nobody listens
on): the Modbus request log (/api/v1/modbus/requests), every robot's
identity (address, unit ID, layout, originator serial) and truth (a robot
never linked is not shown with the gateway's zeros as its state; a robot
lost is marked stale), ...

Each test here failed on the code before the change it checks (the commit
that added it says how)."""
import csv
import io
import json
import re
import subprocess
import time

import pytest

import gwlib
from gwlib import DRGATEWAYD, GW_ADDR, Drsim, Gateway, drcli_identity, free_port, wait_for
from test_http import down_robot, get, get_json

STATE_NAMES = {0: "INITIALIZING", 1: "STANDBY", 2: "OPERATING"}  # drsim's (dr_robot_state_name)
BAD_HR = 5000
# r0's own map: HR 2000-2007 four DINTs (HR 2005, 42006: int_in[2]'s second
# register), HR 2010 a REAL, coils 2048.. bits
USER_MAP = ("map = hr 2000 int_in[0..3] dint writable\n"
            "map = hr 2010 float_in[1] real writable\n"
            "map = co 2048 bit_in[0..3] writable\n")  # a holding register nothing is mapped to: FC 16 there gets 0x02


@pytest.fixture(scope="module")
def gw():
    sim = Drsim("console_api", "--still").start()
    port = free_port(GW_ADDR, udp=False)
    g = Gateway("console_api", sim, robot=USER_MAP, modbus="max_clients = 40\n",
                extra=down_robot() + "\n[http]\nport = %d\n" % port)
    g.sim, g.http = sim, port
    try:
        g.start()
        wait_for(lambda: g.listening(port), 10, "the console to listen")
        yield g
    finally:
        g.kill()
        sim.kill()


def my_client(log, c):
    """The entry of pymodbus client c (by its local address)."""
    addr = "%s:%d" % c.socket.getsockname()[:2]
    for e in log["clients"]:
        if e["client"] == addr:
            return e
    raise AssertionError("no client %s in %s" % (addr, [e["client"] for e in log["clients"]]))


def test_request_log_shows_a_refused_fc16(gw):
    c = gw.pymodbus()
    try:
        r = c.write_registers(BAD_HR, [1, 2], slave=1)
        assert r.isError() and r.exception_code == 2
        assert not c.read_holding_registers(100, count=3, slave=1).isError()
        log = get_json(gw.http, "/api/v1/modbus/requests")
        me = my_client(log, c)
        assert me["transport"] == "tcp" and me["connected"] is True
        assert me["requests"] == 2 and me["exceptions"] == 1
        w, rd = me["log"][-2:]
        assert (w["fc"], w["function"], w["addr"], w["count"], w["unit"]) == \
            (16, "Write Multiple Registers", BAD_HR, 2, 1)
        assert (w["ex"], w["exception"]) == (2, "Illegal Data Address")
        assert (rd["fc"], rd["addr"], rd["count"], rd["ex"], rd["exception"]) == \
            (3, 100, 3, 0, None)
        assert w["age_ms"] >= rd["age_ms"] >= 0
        ex = log["exceptions"]
        assert {"code": 2, "name": "Illegal Data Address"}.items() <= \
            next(b for b in ex["by_code"] if b["code"] == 2).items()
        place = [p for p in ex["by_address"] if p["addr"] == BAD_HR and p["fc"] == 16]
        assert len(place) == 1 and place[0]["code"] == 2 and place[0]["count"] >= 1
        assert place[0]["transport"] == "tcp" and place[0]["unit"] == 1
    finally:
        c.close()


def test_request_log_unit_and_rights_refusals_name_their_address(gw):
    """A request refused before its data is looked at (no robot with the
    unit ID) still shows the address and count it asked for."""
    c = gw.pymodbus()
    try:
        r = c.read_input_registers(201, count=2, slave=77)
        assert r.isError() and r.exception_code == 0x0A
        e = my_client(get_json(gw.http, "/api/v1/modbus/requests"), c)["log"][-1]
        assert (e["unit"], e["fc"], e["addr"], e["count"], e["ex"]) == (77, 4, 201, 2, 0x0A)
        assert e["exception"] == "Gateway Path Unavailable"
    finally:
        c.close()


def test_request_log_is_bounded_and_kept_across_a_reconnect(gw):
    c = gw.pymodbus()
    addr = c.socket.getsockname()[0]
    try:
        for i in range(40):
            assert not c.read_holding_registers(100 + i % 3, count=1, slave=1).isError()
        log = get_json(gw.http, "/api/v1/modbus/requests")
        me = my_client(log, c)
        n = log["log_size"]
        assert n == 32 and len(me["log"]) == n  # the newest 32 of 40
        assert [e["addr"] for e in me["log"]] == [100 + i % 3 for i in range(40 - n, 40)]
        me_addr = me["client"]
    finally:
        c.close()
    wait_for(lambda: not [e for e in get_json(gw.http, "/api/v1/modbus/requests")["clients"]
                          if e["client"] == me_addr and e["connected"]], 10,
             "the gateway to see the client gone")
    # the same address connects again: its past is still there
    c = gw.pymodbus()
    try:
        assert c.socket.getsockname()[0] == addr
        assert not c.read_coils(100, count=1, slave=1).isError()
        me = my_client(get_json(gw.http, "/api/v1/modbus/requests"), c)
        assert me["requests"] == 1 and len(me["log"]) == 32
        assert me["log"][-1]["fc"] == 1 and me["log"][-2]["fc"] == 3
    finally:
        c.close()


def test_not_found_lists_every_route(gw):
    for path in ("/api/v1/nothing", "/api/v1/modbus/nothing", "/api/v1/nobody/requests"):
        st, hdr, body = get(gw.http, path)
        assert st == 404, path
        err = json.loads(body)["error"]
        for route in ("/api/v1/robots/NAME/map", "/api/v1/modbus/requests"):
            assert route in err, (path, err)


def test_robot_identity(gw):
    """Who each robot is: the address the gateway reaches it at, the unit
    ID a PLC names it by, the layout, and the originator serial its
    Forward Opens carry (the one the log says)."""
    r0 = get_json(gw.http, "/api/v1/robots/r0")
    assert (r0["host"], r0["tcp_port"], r0["udp_port"]) == (gwlib.SIM_ADDR, gw.sim.tcp, gw.sim.udp)
    assert r0["sides"]["modbus"] == {"unit_id": 1, "unit_id_aliases": []}
    assert (r0["mode"], r0["layout"]) == ("implicit", "per_assembly")
    m = re.search(r"robot r0: connecting to .*originator serial (0x[0-9A-F]{8})", gw.log())
    assert m and r0["originator_serial"] == m.group(1), (r0["originator_serial"], m)
    down = get_json(gw.http, "/api/v1/robots/down")
    assert down["sides"]["modbus"]["unit_id"] == 9
    assert down["host"] == gwlib.SIM_ADDR and down["tcp_port"] > 0
    assert [r["name"] for r in get_json(gw.http, "/api/v1/robots")] == ["r0", "down"]
    assert get_json(gw.http, "/api/v1/robots")[0]["host"] == r0["host"]


def test_robots_identity_object(gw):
    """The robot's Identity object, as the link read it after its session
    was registered: the members drcli identity --json prints for the same
    robot, with the vendor's name; "waiting" for a robot never reached.
    drgatewayd status says it on a line of its own below the robot's."""
    want = drcli_identity(gw.sim)
    want.pop("status")  # the robot's state now (its connections), not who it is
    ident = wait_for(lambda: (lambda i: i if i["state"] == "known" else None)(
        get_json(gw.http, "/api/v1/robots/r0")["identity"]), 20, "r0's identity")
    assert ident == dict(want, state="known", vendor_name="vendor %d" % want["vendor"])
    assert get_json(gw.http, "/api/v1/robots/down")["identity"] == {"state": "waiting"}
    p = subprocess.run([str(DRGATEWAYD), "status", "-c", str(gw.conf)], capture_output=True,
                       text=True, timeout=gwlib.timeout(30))
    line = "identity: vendor %d, '%s' (product code %d, revision %s, serial 0x%08x)" % (
        want["vendor"], want["product_name"], want["product_code"], want["revision"],
        want["serial"])
    assert re.search(r"^\s+r0\s+linked \(.*\n\s+%s\n" % re.escape(line), p.stdout, re.M), \
        p.stdout
    assert p.stdout.count("identity: ") == 1, p.stdout


def test_identity_refused_leaves_the_link_alone():
    """A robot that refuses Get_Attributes_All on its Identity: the link
    comes up all the same, the refusal is logged once, and the identity
    stays unknown ("refused", with the robot's answer)."""
    sim = Drsim("console_api_noident", "--still", "--refuse-identity", "-v").start()  # -vv
    port = free_port(GW_ADDR, udp=False)
    g = Gateway("console_api_noident", sim, extra="\n[http]\nport = %d\n" % port)
    words = ("robot r0: Identity object (Get_Attributes_All, class 1, instance 1): CIP 0x08 "
             "service not supported; the robot's identity stays unknown (the link is not "
             "affected)")
    try:
        g.start()
        wait_for(lambda: g.listening(port), 10, "the console to listen")
        g.log_wait(words, 20)
        r0 = get_json(port, "/api/v1/robots/r0")
        assert r0["link"] == "up"
        assert r0["identity"] == {"state": "refused", "reason": "CIP 0x08 service not supported"}
        # a new session (drsim restarted) asks again: refused again, not logged again
        sim.kill()
        wait_for(lambda: get_json(port, "/api/v1/robots/r0")["link"] != "up", 20, "link down")
        mark = len(g.log())
        sim.start(same_ports=True)
        g.log_wait("robot r0 (%s): link up" % gwlib.SIM_ADDR, 30, mark)
        asked = "request 0x01 class 0x01 instance 1 attribute -1"  # drsim -vv
        wait_for(lambda: sim.log().count(asked) == 2, 20, "the second session's Identity read")
        assert g.log().count(words) == 1, g.log()
        assert "identity: " not in g.log()
    finally:
        g.kill()
        sim.kill()


def test_never_linked_robot_is_not_shown_as_the_robots_data(gw):
    down = get_json(gw.http, "/api/v1/robots/down")
    assert down["link"] in ("down", "connecting")
    assert down["state"] == "never linked" and down["ever_linked"] is False
    assert down["age_ms"] is None  # not the daemon's uptime
    assert down["robot_state"] is None and down["servo_on"] is None
    assert down["values_stale"] is True
    r0 = get_json(gw.http, "/api/v1/robots/r0")
    assert r0["state"] == "up" and r0["ever_linked"] is True and r0["values_stale"] is False
    assert isinstance(r0["age_ms"], int) and r0["age_ms"] < 5000
    values = get_json(gw.http, "/api/v1/robots/r0/values")
    assert r0["robot_state"]["value"] == values["io_state.robot_state"]
    assert r0["robot_state"]["name"] == STATE_NAMES[values["io_state.robot_state"]]
    assert r0["servo_on"] is values["io_state.servo_on"]


def test_a_lost_robot_is_marked_stale_not_never_linked(tmp_path):
    sim = Drsim("console_api_lost", "--still").start()
    port = free_port(GW_ADDR, udp=False)
    g = Gateway("console_api_lost", sim, extra="\n[http]\nport = %d\n" % port)
    try:
        g.start()
        wait_for(lambda: g.listening(port), 10, "the console to listen")
        assert get_json(port, "/api/v1/robots/r0")["values_stale"] is False
        sim.kill()
        wait_for(lambda: get_json(port, "/api/v1/robots/r0")["link"] != "up", 20, "the link down")
        r0 = get_json(port, "/api/v1/robots/r0")
        assert r0["state"] != "never linked" and r0["ever_linked"] is True
        assert r0["values_stale"] is True and r0["fresh"] is False
        assert r0["robot_state"]["name"] in STATE_NAMES.values()  # the last sent, marked stale
    finally:
        g.kill()
        sim.kill()


PREFIX = {"CO": 0, "DI": 1, "IR": 3, "HR": 4}


def test_map_csv_equals_print_map_json(gw):
    """The map as a table a PLC tag import takes: its rows, parsed with
    Python's csv module, are `drgatewayd --print-map --json`'s for the
    robot (the default map, then its own)."""
    st, hdr, body = get(gw.http, "/api/v1/robots/r0/map.csv")
    assert st == 200, body[:200]
    assert hdr["Content-Type"] == "text/csv; charset=utf-8"
    assert hdr["Content-Disposition"] == 'attachment; filename="r0-map.csv"'
    reader = csv.DictReader(io.StringIO(body.decode("utf-8"), newline=""))
    assert reader.fieldnames == ["area", "address", "count", "reference", "name", "type", "unit",
                                 "robot", "writable"]
    got = []
    for row in reader:
        assert row["reference"] == "%d%04d" % (PREFIX[row["area"]], int(row["address"]) + 1), row
        r = {"area": row["area"], "address": int(row["address"]), "count": int(row["count"]),
             "name": row["name"], "type": row["type"], "unit": row["unit"]}
        if row["robot"]:
            r["robot"] = row["robot"]
            r["writable"] = {"true": True, "false": False}[row["writable"]]
        got.append(r)
    out = subprocess.run([str(DRGATEWAYD), "-c", str(gw.conf), "--print-map", "--json"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    want = [r for r in json.loads(out.stdout) if r.get("robot", "r0") == "r0"]
    assert any("robot" in r for r in want)  # its own map is in it
    assert any("," in r["name"] for r in want)  # and names that need quoting
    assert got == want
    # a robot without a map of its own: the default map alone
    st, hdr, body = get(gw.http, "/api/v1/robots/down/map.csv")
    rows = list(csv.DictReader(io.StringIO(body.decode("utf-8"), newline="")))
    assert st == 200 and len(rows) == len([r for r in want if "robot" not in r])
    assert get(gw.http, "/api/v1/robots/nobody/map.csv")[0] == 404


def test_raw_registers_are_what_a_plc_reads(gw):
    c = gw.pymodbus()
    try:
        assert not c.write_registers(2000, [0, 1234], slave=1).isError()
        raw = get_json(gw.http, "/api/v1/modbus/registers/r0")
        assert raw["robot"] == "r0"
        hr = {r["address"]: r for r in raw["tables"]["HR"]}
        assert hr[2000]["words"] == [0, 1234] and hr[2000]["user"] is True
        assert hr[2000]["name"] == "int_in[0]" and hr[2000]["ref"] == "42001"
        ir = raw["tables"]["IR"]
        assert [r["address"] for r in ir] == sorted(r["address"] for r in ir)
        st = {r["address"]: r for r in ir}
        assert st[1]["name"].startswith("status.link_state") and st[1]["words"] == [2]
        plc = c.read_input_registers(200, count=2, slave=1).registers
        assert st[200]["words"] == plc, (st[200], plc)  # drsim --still: the same words
        assert list(raw["tables"]) == ["CO", "DI", "HR", "IR"]
    finally:
        c.close()
    assert get(gw.http, "/api/v1/modbus/registers/nobody")[0] == 404


def test_writes_do_not_push_the_events_out(gw):
    """PLCs that write every second keep the write log busy (one line per
    client and second): 240 write lines, more than a ring holds, leave the
    start-up and link events in /api/v1/log; the writes have their own
    ring, /api/v1/writes."""
    clients = [gw.pymodbus() for _ in range(30)]
    try:
        for rnd in range(8):
            t0 = time.monotonic()
            for i, c in enumerate(clients):
                assert not c.write_registers(2000, [rnd, i], slave=1).isError()
            # the write log's window per client is a second: each round is a line of each
            time.sleep(max(0.0, 1.1 - (time.monotonic() - t0)))
    finally:
        for c in clients:
            c.close()
    writes = get_json(gw.http, "/api/v1/writes")
    assert len(writes) == 200
    assert all("write by modbus" in w["text"] for w in writes), writes[:3]
    assert "int_in[0]" in writes[-1]["text"]
    events = [e["text"] for e in get_json(gw.http, "/api/v1/log")]
    assert not [e for e in events if "write by" in e]
    assert any("http: console on" in e for e in events), events[:5]
    assert any("robot r0 (%s): link up" % gwlib.SIM_ADDR in e for e in events), events[:5]


def test_effective_configuration_with_secrets_hidden(tmp_path):
    secret = tmp_path / "mqtt.pass"
    secret.write_text("s3cret-Pa55\n")
    port = free_port(GW_ADDR, udp=False)
    broker = free_port(GW_ADDR, udp=False)  # nobody listens: MQTT retries, the console serves
    g = Gateway("console_api_config", [], extra=down_robot() + (
        "\n[http]\nport = %d\n\n[mqtt]\nhost = %s\nport = %d\nusername = plant\n"
        "password_file = %s\n" % (port, GW_ADDR, broker, secret)))
    try:
        g.start(wait_link=False)
        wait_for(lambda: g.listening(port), 10, "the console to listen")
        st, hdr, body = get(port, "/api/v1/config")
        assert st == 200 and hdr["Content-Type"] == "text/plain; charset=utf-8"
        text = body.decode()
        assert "s3cret" not in text and str(secret) not in text
        assert "password_file = (set, hidden)" in text
        assert "username = plant" in text and "port = %d" % broker in text
        assert "[http] ; line" in text and "max_request_bytes = 16384" in text  # a default
        assert "[modbus]" in text and "\n[robot down] ; line" in text and "unit_id = 9" in text
        assert "; [gpio" not in text or "not in the file" in text
        st, hdr, body = get(port, "/config")
        assert st == 200 and b"/api/v1/config" in body
    finally:
        g.kill()


def read_events(port, path, want, seconds=10):
    """The (event, data) pairs of a stream until want(pairs) or seconds."""
    import http.client
    c = http.client.HTTPConnection(GW_ADDR, port, timeout=seconds)
    pairs, ev, t0 = [], None, time.monotonic()
    try:
        c.request("GET", path)
        r = c.getresponse()
        assert r.status == 200, r.read()
        while time.monotonic() - t0 < seconds and not want(pairs):
            line = r.readline()
            if not line:
                break
            if line.startswith(b"event: "):
                ev = line[7:].strip().decode()
            elif line.startswith(b"data: ") and ev is not None:
                pairs.append((ev, json.loads(line[6:])))
                ev = None
    finally:
        c.close()
    return pairs


def test_one_stream_carries_robots_and_the_overview(gw):
    def enough(p):
        kinds = {(e, d.get("name") or d.get("robot")) for e, d in p if e in ("status", "values")}
        return {("status", "r0"), ("status", "down"), ("values", "r0")} <= kinds and \
            any(e == "overview" for e, d in p)
    pairs = read_events(gw.http, "/api/v1/events?robots=r0,down,r0&overview=1", enough)
    assert enough(pairs), [(e, list(d)[:3]) for e, d in pairs]
    first = [d for e, d in pairs if e == "values" and d["robot"] == "r0"][0]
    assert len(first["values"]) > 300  # every value first
    assert [d for e, d in pairs if e == "overview"][0]["robots"][0]["name"] == "r0"
    # robot=NAME keeps its form
    one = read_events(gw.http, "/api/v1/events?robot=r0",
                      lambda p: any(e == "values" for e, d in p))
    assert "io_state.robot_state" in [d for e, d in one if e == "values"][0]
    for path, code in (("/api/v1/events?robots=r0,nobody", 404), ("/api/v1/events?robots=", 400),
                       ("/api/v1/events", 400)):
        assert get(gw.http, path)[0] == code, path


def test_static_files_cached_and_connection_kept(gw):
    import http.client
    c = http.client.HTTPConnection(GW_ADDR, gw.http, timeout=10)
    try:
        c.request("GET", "/static/console.js")
        r = c.getresponse()
        body = r.read()
        assert r.status == 200 and len(body) > 1000
        etag = r.getheader("ETag")
        assert etag and r.getheader("Cache-Control") == "no-cache"
        sock = c.sock
        c.request("GET", "/static/console.js", headers={"If-None-Match": etag})
        r = c.getresponse()
        assert r.status == 304 and r.read() == b"" and r.getheader("ETag") == etag
        c.request("GET", "/api/v1/status")
        r = c.getresponse()
        r.read()
        assert r.status == 200 and r.getheader("Cache-Control") == "no-store"
        assert c.sock is sock  # one connection for the three
    finally:
        c.close()


def raw_status_line(port, data):
    """The status line an HTTP request gets ("" if the connection closed
    without one)."""
    import socket as so
    s = so.create_connection((GW_ADDR, port), timeout=10)
    out = b""
    try:
        s.sendall(data)
        while b"\r\n" not in out:
            b = s.recv(65536)
            if not b:
                break
            out += b
    except (ConnectionResetError, so.timeout):
        pass
    finally:
        s.close()
    return out.split(b"\r\n")[0].decode()


def test_requests_near_the_limit_get_a_status_line(gw):
    """max_request_bytes (16384): a request around it gets an answer, never a
    connection closed without a status line; over it, 414 when the URL is
    most of it, 431 when the headers are (docs/http.md)."""
    host = b"Host: %s:%d\r\n" % (GW_ADDR.encode(), gw.http)
    for n in range(15600, 17200, 100):
        line = raw_status_line(gw.http, b"GET /api/v1/" + b"a" * n + b" HTTP/1.1\r\n" + host +
                               b"Accept: */*\r\n\r\n")
        assert line.startswith("HTTP/1.1 "), (n, line)
        assert line.split()[1] in (("404",) if n + 60 <= 16384 else ("404", "414")), (n, line)
        assert not (n >= 16400 and line.split()[1] != "414"), (n, line)
        line = raw_status_line(gw.http, b"GET /api/v1/status HTTP/1.1\r\n" + host + b"X-Big: " +
                               b"b" * n + b"\r\n\r\n")
        assert line.startswith("HTTP/1.1 "), (n, line)
        assert not (n >= 16400 and line.split()[1] != "431"), (n, line)
    # the 16,200-byte URL: within the limit with its few headers
    assert raw_status_line(gw.http, b"GET /api/v1/" + b"a" * 16200 + b" HTTP/1.1\r\n" + host +
                           b"\r\n").split()[1] == "404"


def test_closed_stream_not_logged_at_info(gw):
    mark = len(gw.log())
    pairs = read_events(gw.http, "/api/v1/events?robot=down", lambda p: len(p) >= 1)
    assert pairs and pairs[0][0] == "status"
    # the stream waits (nothing changes for a robot never linked): its
    # close is seen by the next look at its socket, and not logged at info
    wait_for(lambda: get_json(gw.http, "/api/v1/status") and
             b"drgate_http_streams 0" in get(gw.http, "/metrics")[2], 10, "the stream gone")
    assert "Failed to send" not in gw.log()[mark:], gw.log()[mark:]


def test_status_json_and_absolute_config_path(gw):
    p = subprocess.run([str(DRGATEWAYD), "status", "--json", "-c", str(gw.conf)],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 1, p.stderr  # the robot `down`
    st = json.loads(p.stdout)
    assert [r["name"] for r in st["robots"]] == ["r0", "down"]
    assert st["config"]["file"] == str(gw.conf.resolve())
    p = subprocess.run([str(DRGATEWAYD), "status", "--markdown", "-c", str(gw.conf)],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and "--json only" in p.stderr


def test_relative_config_path_shown_absolute(monkeypatch):
    import pathlib
    port = free_port(GW_ADDR, udp=False)
    g = Gateway("console_api_rel", [], extra=down_robot() + "\n[http]\nport = %d\n" % port)
    full = g.conf.resolve()
    full.parent.mkdir(parents=True, exist_ok=True)
    monkeypatch.chdir(full.parent)
    g.conf = pathlib.Path(full.name)  # drgatewayd -c console_api_rel.ini
    try:
        g.start(wait_link=False)
        wait_for(lambda: g.listening(port), 10, "the console to listen")
        assert get_json(port, "/api/v1/status")["config"]["file"] == str(full)
        text = get(port, "/api/v1/status?format=text")[2].decode()
        assert "Config: %s (generation" % full in text, text
    finally:
        g.kill()


def test_mqtt_card_says_why_it_is_not_connected():
    """The MQTT side's report (the overview's MQTT card) gives the reason it
    is not connected, in the log's words; "connected": false alone said
    nothing (before: no reason in the report)."""
    port = free_port(GW_ADDR, udp=False)
    broker = free_port(GW_ADDR, udp=False)  # nobody listens there
    g = Gateway("console_api_mqtt_down", [], extra=down_robot() + (
        "\n[http]\nport = %d\n\n[mqtt]\nhost = %s\nport = %d\n" % (port, GW_ADDR, broker)))
    try:
        g.start(wait_link=False)
        wait_for(lambda: g.listening(port), 10, "the console to listen")
        words = "cannot connect to %s:%d: " % (GW_ADDR, broker)
        mq = wait_for(lambda: (lambda m: m if (m.get("reason") or "").startswith(words) else None)(
            get_json(port, "/api/v1/status")["sides"]["mqtt"]), 20, "the MQTT card's reason")
        assert mq["connected"] is False
        assert "mqtt: " + mq["reason"] in g.log()
    finally:
        g.kill()
