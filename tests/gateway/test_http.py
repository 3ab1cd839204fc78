# SPDX-License-Identifier: MIT
"""The console's HTTP side ([http], gateway/http/, docs/http.md) against a
running gateway: every JSON endpoint and its errors, the values equal to
what `drcli get --json` prints for the same robot, live values as
Server-Sent Events, TLS and Basic authentication (from a non-loopback
address, in a network namespace of its own), a reload that moves the port
without the link going down, `drgatewayd status` and its exit codes, a
flood of slow and idle connections that neither delays a Modbus reply nor
the robot's packets, the configuration's checks, and no libmicrohttpd
mapped without [http].

One gateway (two robots: r0 on drsim, `down` pointing at a port nobody
listens on) serves most tests of the module."""
import http.client
import json
import os
import re
import signal
import socket
import ssl
import subprocess
import threading
import time

import pytest

from gwlib import (DRCLI, DRGATEWAYD, EXIT_CONFIG, GW_ADDR, LOGDIR, SIM_ADDR, Drsim, Gateway,
                   dint_regs, free_port, kill_all, running, skip, spawn, timeout, wait_for)

ASSEMBLIES = ("io_state", "joint_state", "task_state", "bit_out", "int_out", "float_out",
              "io_control", "bit_in", "int_in", "float_in")


def down_robot():
    """A robot section whose host refuses connections (nothing on the port)."""
    return ("\n[robot down]\nhost = %s\ntcp_port = %d\nunit_id = 9\nlocal_address = %s\n"
            "local_udp_port = %d\n" % (SIM_ADDR, free_port(SIM_ADDR), GW_ADDR,
                                        free_port(GW_ADDR, tcp=False)))


def get(port, path, method="GET", headers=None, host=GW_ADDR):
    c = http.client.HTTPConnection(host, port, timeout=timeout(10))
    try:
        c.request(method, path, headers=headers or {})
        r = c.getresponse()
        return r.status, dict(r.getheaders()), r.read()
    finally:
        c.close()


def get_json(port, path):
    st, hdr, body = get(port, path)
    assert st == 200, (path, st, body)
    assert hdr["Content-Type"] == "application/json"
    return json.loads(body)


@pytest.fixture(scope="module")
def gw():
    sim = Drsim("http", "--still").start()
    port = free_port(GW_ADDR, udp=False)
    g = Gateway("http", sim, extra=down_robot() + "\n[http]\nport = %d\ntimeout_s = 3\n"
                "max_connections = 16\n" % port)
    g.sim, g.http = sim, port
    try:
        g.start()
        wait_for(lambda: g.listening(port), 10, "the console to listen")
        wait_for(lambda: "robot down" in g.log() and "connection refused" in g.log(), 20,
                 "robot down refused")
        yield g
    finally:
        g.kill()
        sim.kill()


def test_status(gw):
    st = get_json(gw.http, "/api/v1/status")
    assert st["version"] and st["uptime_s"] >= 0
    assert st["config"] == {"file": str(gw.conf), "generation": 0}
    assert isinstance(st["sides"], dict)
    r0, down = st["robots"]
    assert r0["name"] == "r0" and r0["link"] == "up" and r0["reason"] is None
    assert r0["fresh"] is True and r0["rpi_ms"] == 10 and r0["rx_packets"] > 0
    assert r0["last_error"] is None and r0["last_write"] is None
    assert {c["assembly"]: c["state"] for c in r0["connections"]} == {
        a: "connected" for a in ("io_state", "bit_out", "int_out", "float_out", "joint_state",
                                 "task_state")}
    # the same words as the log and MQTT's state
    assert down["name"] == "down" and down["link"] != "up"
    assert down["reason"] == "connection refused"
    assert down["last_error"]["text"] == "connection refused"
    assert down["last_error"]["cip_general"] == 0 and down["last_error"]["code"] > 0
    assert "robot down: %s" % "" in gw.log() or "connection refused" in gw.log()


def test_robots_and_robot(gw):
    robots = get_json(gw.http, "/api/v1/robots")
    assert [r["name"] for r in robots] == ["r0", "down"]
    one = get_json(gw.http, "/api/v1/robots/down")
    assert one["name"] == "down" and one["reason"] == "connection refused"
    assert get_json(gw.http, "/api/v1/robots/r0")["link"] == "up"


def test_host_checked_headers_and_keep_alive(gw):
    """Served without a login (loopback), a request is only answered with
    a name of this machine in Host (DNS rebinding: a page of the
    attacker's site, its name now pointing at 127.0.0.1, gets 421); every
    answer carries the security headers; a page's polls reuse one
    connection (keep-alive)."""
    st, hdr, body = get(gw.http, "/api/v1/status", headers={"Host": "evil.example:%d" % gw.http})
    assert st == 421, (st, body)
    assert get(gw.http, "/api/v1/status", headers={"Host": "evil.example"})[0] == 421
    assert get(gw.http, "/api/v1/status", headers={"Host": "localhost:1"})[0] == 421
    for host in ("localhost:%d" % gw.http, "127.0.0.1:%d" % gw.http, "[::1]:%d" % gw.http,
                 "localhost"):
        assert get(gw.http, "/api/v1/status", headers={"Host": host})[0] == 200, host
    st, hdr, body = get(gw.http, "/")
    assert st == 200
    assert hdr["X-Content-Type-Options"] == "nosniff"
    assert "frame-ancestors 'none'" in hdr["Content-Security-Policy"]
    assert "default-src 'self'" in hdr["Content-Security-Policy"]
    assert hdr["Referrer-Policy"] == "no-referrer"
    assert hdr["X-Frame-Options"] == "DENY"
    assert "Strict-Transport-Security" not in hdr  # plain HTTP: no HSTS
    assert "nosniff" in get(gw.http, "/nope")[1]["X-Content-Type-Options"]
    c = http.client.HTTPConnection(GW_ADDR, gw.http, timeout=timeout(10))
    try:
        socks = set()
        for _ in range(5):
            c.request("GET", "/api/v1/robots")
            r = c.getresponse()
            assert r.status == 200 and r.getheader("Connection") != "close"
            r.read()
            socks.add(id(c.sock))
        assert len(socks) == 1  # one connection for all five
    finally:
        c.close()


def tokens(text):
    """{"path": the value's JSON text as printed} of a flat JSON object."""
    return dict(re.findall(r'^\s*"([^"]+)": (.+?),?$', text, re.M))


def test_values_as_drcli_prints_them(gw):
    """Every leaf, keyed and printed as drcli get --json prints it for the
    same robot (drsim --still: nothing moves between the two reads)."""
    st, hdr, body = get(gw.http, "/api/v1/robots/r0/values")
    assert st == 200
    api = body.decode()
    cli = subprocess.run([str(DRCLI), "-H", SIM_ADDR, "--port", str(gw.sim.tcp), "get",
                          "--json"] + list(ASSEMBLIES), capture_output=True, text=True,
                         timeout=timeout(30), check=True).stdout
    assert json.loads(api) == json.loads(cli)
    assert tokens(api) == tokens(cli)  # the same tokens: 90.0, true, ...
    assert len(tokens(api)) > 300
    assert api == cli  # even the layout


def test_not_found_and_method(gw):
    st, hdr, body = get(gw.http, "/api/v1/nothing")
    assert st == 404
    err = json.loads(body)
    assert err["path"] == "/api/v1/nothing" and err["method"] == "GET"
    assert "not found" in err["error"] and "/api/v1/status" in err["error"]
    for path in ("/api/v1/robots/nobody", "/api/v1/robots/nobody/values",
                 "/api/v1/robots/r0/nothing", "/api/v1/events?robot=nobody"):
        st, hdr, body = get(gw.http, path)
        assert st == 404, path
        assert json.loads(body)["path"] == path.split("?")[0], path
    st, hdr, body = get(gw.http, "/no/such/page")
    assert st == 404 and b"GET /no/such/page" in body
    st, hdr, body = get(gw.http, "/robot/nobody")
    assert st == 404 and b"/robot/nobody" in body
    st, hdr, body = get(gw.http, "/api/v1/events")
    assert st == 400 and b"robot=NAME" in body
    for method in ("POST", "PUT", "DELETE"):
        st, hdr, body = get(gw.http, "/api/v1/status", method=method)
        assert st == 405, method
        assert hdr["Allow"] == "GET, HEAD"
        assert json.loads(body)["method"] == method
    st, hdr, body = get(gw.http, "/")
    assert st == 200 and hdr["Content-Type"].startswith("text/html")


def raw_request(port, data, seconds=10):
    s = socket.create_connection((GW_ADDR, port), timeout=timeout(seconds))
    try:
        s.sendall(data)
        out = b""
        while True:
            try:
                b = s.recv(65536)
            except (ConnectionResetError, socket.timeout):
                break
            if not b:
                break
            out += b
        return out
    finally:
        s.close()


def test_oversized_url_and_headers(gw):
    long_url = b"/api/v1/" + b"a" * 40000
    out = raw_request(gw.http, b"GET " + long_url + b" HTTP/1.1\r\nHost: x\r\n\r\n")
    assert re.match(rb"HTTP/1\.1 (414|431) ", out), out[:200]
    out = raw_request(gw.http, b"GET /api/v1/status HTTP/1.1\r\nHost: x\r\nX-Big: " +
                      b"b" * 40000 + b"\r\n\r\n")
    assert re.match(rb"HTTP/1\.1 431 ", out), out[:200]
    assert get(gw.http, "/api/v1/status")[0] == 200  # and nothing else changed


class Events:
    """An /api/v1/events stream read in a thread: (event, data) pairs."""

    def __init__(self, port, robot):
        self.sock = socket.create_connection((GW_ADDR, port), timeout=timeout(10))
        self.sock.sendall(b"GET /api/v1/events?robot=%s HTTP/1.0\r\nHost: localhost\r\n\r\n"
                          % robot.encode())
        self.events, self.head, self.done = [], None, False
        self.t = threading.Thread(target=self.run, daemon=True)
        self.t.start()

    def run(self):
        buf = b""
        try:
            while True:
                b = self.sock.recv(65536)
                if not b:
                    break
                buf += b
                if self.head is None and b"\r\n\r\n" in buf:
                    self.head, buf = buf.split(b"\r\n\r\n", 1)
                while self.head is not None and b"\n\n" in buf:
                    block, buf = buf.split(b"\n\n", 1)
                    ev = dict(ln.split(": ", 1) for ln in block.decode().splitlines()
                              if not ln.startswith(":"))
                    if ev:
                        self.events.append((ev["event"], json.loads(ev["data"])))
        except OSError:
            pass
        self.done = True

    def close(self):
        self.sock.close()


def test_events(gw, regmap):
    ev = Events(gw.http, "r0")
    try:
        wait_for(lambda: len(ev.events) >= 2, 10, "the first two events")
        assert b"text/event-stream" in ev.head
        (e1, status), (e2, values) = ev.events[:2]
        assert e1 == "status" and status["name"] == "r0" and status["link"] == "up"
        # the first values event: every value, as /values has them
        assert e2 == "values"
        assert values == get_json(gw.http, "/api/v1/robots/r0/values")
        # a change: only what changed comes next
        n = len(ev.events)
        with gw.raw() as m:
            m.write_regs(regmap.addr("HR", "int_in[3]"), dint_regs(4242, "abcd"))
        e = wait_for(lambda: [x for x in ev.events[n:] if x[0] == "values"], 10,
                     "a values event")[0]
        assert e[1]["int_in[3]"] == 4242
        assert len(e[1]) < 10
    finally:
        ev.close()
    down = Events(gw.http, "down")
    try:
        wait_for(lambda: down.events, 10, "the down robot's first event")
        assert down.events[0][1]["reason"] == "connection refused"
    finally:
        down.close()


def test_status_command(gw):
    """Exit 1 while a robot is down, with the summary on stdout."""
    p = subprocess.run([str(DRGATEWAYD), "status", "-c", str(gw.conf)], capture_output=True,
                       text=True, timeout=timeout(30))
    assert p.returncode == 1, p.stderr
    assert "Robots: 1 of 2 linked" in p.stdout
    assert re.search(r"^\s+r0\s+linked \(", p.stdout, re.M)
    assert re.search(r"^\s+down\s+down: connection refused \(", p.stdout, re.M)
    assert "Modbus: 127.0.0.1:%d, 0 clients\n" % gw.port in p.stdout
    with gw.raw():
        p = subprocess.run([str(DRGATEWAYD), "status", "-c", str(gw.conf)],
                           capture_output=True, text=True, timeout=timeout(30))
        assert re.search(r"Modbus: 127\.0\.0\.1:%d, 1 client: 127\.0\.0\.1:\d+\n" % gw.port,
                         p.stdout), p.stdout


def test_systemd_status_line(tmp_path):
    """STATUS= to systemd (NOTIFY_SOCKET) when it changes: each robot's
    link in words and the Modbus clients."""
    path = str(tmp_path / "notify")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(path)
    sock.settimeout(0.2)
    got = []

    def status_lines():
        while True:
            try:
                got.append(sock.recv(4096).decode())
            except socket.timeout:
                break
        return [m for m in got if m.startswith("STATUS=")]

    env = dict(os.environ, NOTIFY_SOCKET=path)
    try:
        with running("http_notify", start=False, extra=down_robot()) as g:
            g.start(wait_link=False, env=env)
            wait_for(lambda: "STATUS=r0 linked, down down: connection refused; 0 Modbus clients"
                     in status_lines(), 20, "STATUS= with r0 linked")
            with g.raw():
                wait_for(lambda: any(m.endswith("; 1 Modbus client") for m in status_lines()),
                         10, "STATUS= with one Modbus client")
    finally:
        sock.close()


def test_status_command_unreachable_and_no_http(tmp_path):
    conf = tmp_path / "gw.ini"
    port = free_port(GW_ADDR, udp=False)
    conf.write_text("[robot r0]\nhost = %s\n[http]\nport = %d\n" % (SIM_ADDR, port))
    p = subprocess.run([str(DRGATEWAYD), "status", "-c", str(conf)], capture_output=True,
                       text=True, timeout=timeout(30))
    assert p.returncode == 3
    assert "cannot reach the daemon at http://127.0.0.1:%d/" % port in p.stderr
    assert "Connection refused" in p.stderr
    conf.write_text("[robot r0]\nhost = %s\n" % SIM_ADDR)
    p = subprocess.run([str(DRGATEWAYD), "status", "-c", str(conf)], capture_output=True,
                       text=True, timeout=timeout(30))
    assert p.returncode == 3 and "has no [http] section" in p.stderr


def test_flood_does_not_delay_modbus_or_the_robot(gw, regmap):
    """500 connections, an idle one and 50 slowloris clients (a header byte
    a second) against the console: Modbus replies keep coming, the robot's
    link stays up without a timeout, the idle and slow clients are cut at
    timeout_s, and the console serves again once the flood is over."""
    mark = len(gw.log())
    before = get_json(gw.http, "/api/v1/robots/r0")["rx_packets"]
    socks, stop = [], threading.Event()

    def slowloris(s):
        try:
            s.sendall(b"GET /api/v1/status HTTP/1.1\r\n")
            while not stop.wait(1.0):
                s.sendall(b"X")
        except OSError:
            pass

    # an idle client (connects, sends nothing) and 50 slow ones
    slow = [socket.create_connection((GW_ADDR, gw.http), timeout=timeout(10))]
    for _ in range(50):
        s = socket.create_connection((GW_ADDR, gw.http), timeout=timeout(10))
        slow.append(s)
        threading.Thread(target=slowloris, args=(s,), daemon=True).start()
    for _ in range(500):
        # non-blocking: past max_connections and the listen backlog the
        # kernel leaves the handshake waiting, which is fine for a flood
        s = socket.socket()
        s.setblocking(False)
        s.connect_ex((GW_ADDR, gw.http))
        socks.append(s)
    try:
        with gw.raw() as m:
            for i in range(50):
                v = m.read(4, regmap.addr("IR", "int_out[0]"), 2)
                assert len(v) == 2
        st = gw.status(1)
        assert st[1] == 2 and st[2] == 1  # link up, data fresh
        # idle and slow clients are closed at timeout_s (3 s), not kept
        def cut():
            n = 0
            for s in slow:
                try:
                    s.settimeout(0.01)
                    if s.recv(1) == b"":
                        n += 1
                except socket.timeout:
                    pass
                except OSError:
                    n += 1
            return n == len(slow)
        wait_for(cut, 20, "the slow clients to be closed")
    finally:
        stop.set()
        for s in socks + slow:
            s.close()
    wait_for(lambda: get(gw.http, "/api/v1/status")[0] == 200, 20, "the console again")
    after = get_json(gw.http, "/api/v1/robots/r0")
    assert after["link"] == "up" and after["rx_packets"] > before
    assert after["lost_packets"] == 0
    log = gw.log()[mark:]
    assert "timed out" not in log and "link down" not in log, log


def maps(pid):
    with open("/proc/%d/maps" % pid) as f:
        return f.read()


def test_without_http_no_libmicrohttpd_mapped():
    with running("http_none") as g:
        assert "libmicrohttpd" not in maps(g.proc.pid)
        assert "libgnutls" not in maps(g.proc.pid)


def test_reload_moves_the_port_and_keeps_the_link(tmp_path):
    """SIGHUP with a new [http] port: the new one serves, the old one is
    closed, the robot's link never goes down; status says 0 (all linked)."""
    port, port2 = free_port(GW_ADDR, udp=False), free_port(GW_ADDR, udp=False)
    with running("http_reload", extra="\n[http]\nport = %d\n" % port) as g:
        assert "libmicrohttpd" in maps(g.proc.pid)
        wait_for(lambda: g.listening(port), 10, "the console")
        p = subprocess.run([str(DRGATEWAYD), "status", "-c", str(g.conf)],
                           capture_output=True, text=True, timeout=timeout(30))
        assert p.returncode == 0, p.stdout + p.stderr
        assert "running, every robot linked" in p.stdout and "1 of 1 linked" in p.stdout
        rx = get_json(port, "/api/v1/robots/r0")["rx_packets"]
        mark = len(g.log())
        g.extra = "\n[http]\nport = %d\n" % port2
        g.write_config()
        g.signal(signal.SIGHUP)
        g.log_wait("reloaded (generation 1)", start=mark)
        wait_for(lambda: g.listening(port2), 10, "the new port")
        assert not g.listening(port)
        st = get_json(port2, "/api/v1/status")
        assert st["config"]["generation"] == 1
        assert st["robots"][0]["link"] == "up"
        wait_for(lambda: get_json(port2, "/api/v1/robots/r0")["rx_packets"] > rx, 10,
                 "packets counted after the reload")
        assert "link down" not in g.log()[mark:] and "closing its link" not in g.log()[mark:]
        p = subprocess.run([str(DRGATEWAYD), "status", "-c", str(g.conf)],
                           capture_output=True, text=True, timeout=timeout(30))
        assert p.returncode == 0 and "generation 1" in p.stdout
        # a port that is taken refuses the reload: the console stays where it is
        taken = socket.socket()
        taken.bind((GW_ADDR, 0))
        taken.listen(1)
        try:
            mark = len(g.log())
            g.extra = "\n[http]\nport = %d\n" % taken.getsockname()[1]
            g.write_config()
            g.signal(signal.SIGHUP)
            g.log_wait("reload refused, keeping the running configuration: http: cannot "
                       "listen on 127.0.0.1:%d" % taken.getsockname()[1], start=mark)
            assert get_json(port2, "/api/v1/status")["config"]["generation"] == 1
        finally:
            taken.close()


# ---- TLS and authentication -----------------------------------------------------------

def openssl(*args, cwd):
    subprocess.run(["openssl"] + list(args), cwd=cwd, check=True, capture_output=True,
                   timeout=timeout(60))


@pytest.fixture(scope="module")
def tls_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("http_tls")
    openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
            "-nodes", "-keyout", "server.key", "-out", "server.crt", "-days", "2", "-subj",
            "/CN=10.9.0.1", cwd=d)
    openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
            "-nodes", "-keyout", "other.key", "-out", "other.crt", "-days", "2", "-subj",
            "/CN=other", cwd=d)
    h = subprocess.run(["openssl", "passwd", "-6", "s3cret"], capture_output=True, text=True,
                       check=True, timeout=timeout(30)).stdout.strip()
    (d / "users").write_text("# the console's users\nadmin:%s\n" % h)
    (d / "users").chmod(0o600)  # --check-config refuses one others may read
    return d


NS_ADDR = "10.9.0.1"


def test_tls_and_login_from_another_address(tls_dir):
    """The gateway in a network namespace of its own with an address that
    is not loopback (10.9.0.1): HTTPS, Basic auth: no login and a wrong password
    get 401, the right one 200; plain HTTP to the TLS port fails cleanly
    (no answer, the connection closed) and the console goes on."""
    if subprocess.run(["unshare", "-n", "true"], capture_output=True).returncode != 0:
        skip("test_tls_and_login_from_another_address", "cannot make a network namespace")
    LOGDIR.mkdir(parents=True, exist_ok=True)
    conf = LOGDIR / "http_tls.ini"
    log = LOGDIR / "http_tls.gateway.log"
    conf.write_text("[modbus]\nlisten = 127.0.0.1\nport = 1502\n[robot r0]\nhost = 127.0.0.2\n"
                    "[http]\nlisten = 0.0.0.0\nport = 8443\ntls_cert = %s\ntls_key = %s\n"
                    "auth_file = %s\nstatus_port = 8080\n"
                    % (tls_dir / "server.crt", tls_dir / "server.key", tls_dir / "users"))
    # 10.9.0.1 on the namespace's loopback device: a client connecting to
    # it comes from 10.9.0.1, an address that is not loopback's 127/8
    script = ("ip link set lo up && ip addr add %s/32 dev lo && exec %s -c %s"
              % (NS_ADDR, DRGATEWAYD, conf))
    p = spawn(["unshare", "-n", "sh", "-c", script], log)
    from gwlib import in_netns
    ns = "/proc/%d/ns/net" % p.pid
    try:
        wait_for(lambda: "http: console on https://0.0.0.0:8443/" in log.read_text()
                 or p.poll() is not None, 20, "the console")
        assert p.poll() is None, log.read_text()
        ctx = ssl.create_default_context(cafile=str(tls_dir / "server.crt"))
        ctx.check_hostname = False

        def req(auth=None, ctx=ctx, port=8443, host=NS_ADDR):
            with in_netns(ns):
                if ctx is None:
                    c = http.client.HTTPConnection(host, port, timeout=timeout(10))
                else:
                    c = http.client.HTTPSConnection(host, port, context=ctx,
                                                    timeout=timeout(10))
                c.connect()
            try:
                hdr = {}
                if auth:
                    import base64
                    hdr["Authorization"] = "Basic " + base64.b64encode(auth.encode()).decode()
                c.request("GET", "/api/v1/status", headers=hdr)
                r = c.getresponse()
                return r.status, dict(r.getheaders()), r.read()
            finally:
                c.close()

        st, hdr, body = req()
        assert st == 401 and 'realm="drgatewayd"' in hdr["WWW-Authenticate"]
        assert req("admin:wrong")[0] == 401
        assert req("nobody:s3cret")[0] == 401
        st, hdr, body = req("admin:s3cret")
        assert st == 200 and json.loads(body)["robots"][0]["name"] == "r0"
        assert 'login refused for user "admin" from 10.9.0.1' in log.read_text()
        # plain HTTP to the TLS port: no HTTP answer, the connection closed
        with in_netns(ns):
            s = socket.create_connection((NS_ADDR, 8443), timeout=timeout(10))
        try:
            s.sendall(b"GET /api/v1/status HTTP/1.0\r\n\r\n")
            got = b""
            while True:
                try:
                    b = s.recv(4096)
                except ConnectionResetError:
                    break
                if not b:
                    break
                got += b
            assert not got.startswith(b"HTTP/"), got
        finally:
            s.close()
        assert req("admin:s3cret")[0] == 200
        # loopback needs no login; status_port is plain HTTP on loopback
        st, hdr, body = req(ctx=None, port=8080, host="127.0.0.1")
        assert st == 200
        with in_netns(ns):
            s = socket.socket()
            s.settimeout(timeout(5))
            assert s.connect_ex((NS_ADDR, 8080)) != 0  # not on other addresses
            s.close()
    finally:
        p.kill()
        p.wait()


# ---- --check-config ---------------------------------------------------------------------

def check(tmp_path, http, robot="[robot r0]\nhost = 127.0.0.2\n"):
    conf = tmp_path / "c.ini"
    conf.write_text(robot + "[http]\n" + http)
    p = subprocess.run([str(DRGATEWAYD), "--check-config", str(conf)], capture_output=True,
                       text=True, timeout=timeout(30))
    return p.returncode, (p.stdout + p.stderr).replace(str(conf), "FILE")


def test_check_config(tmp_path, tls_dir):
    crt, key, users = tls_dir / "server.crt", tls_dir / "server.key", tls_dir / "users"
    assert check(tmp_path, "port = 8080\n")[0] == 0
    rc, out = check(tmp_path, "listen = 0.0.0.0\n")
    assert rc == EXIT_CONFIG
    assert "FILE:4: [http] listen 0.0.0.0 serves the console to other hosts in clear text " \
           "and to anyone: add tls_cert, tls_key and auth_file, or insecure = yes" in out
    rc, out = check(tmp_path, "listen = 0.0.0.0\ntls_cert = %s\ntls_key = %s\n" % (crt, key))
    assert rc == EXIT_CONFIG and "FILE:4:" in out and "add auth_file" in out
    rc, out = check(tmp_path, "listen = 0.0.0.0\nauth_file = %s\n" % users)
    assert rc == EXIT_CONFIG and "add tls_cert and tls_key" in out
    assert check(tmp_path, "listen = 0.0.0.0\ninsecure = yes\n")[0] == 0
    assert check(tmp_path, "listen = 0.0.0.0\ntls_cert = %s\ntls_key = %s\nauth_file = %s\n"
                 % (crt, key, users))[0] == 0
    rc, out = check(tmp_path, "port = 8080\ntls_cert = %s\n" % crt)
    assert rc == EXIT_CONFIG and "FILE:5: [http] tls_cert and tls_key go together" in out
    rc, out = check(tmp_path, "tls_cert = /nonexistent.crt\ntls_key = %s\n" % key)
    assert rc == EXIT_CONFIG
    assert "FILE:4: [http] tls_cert /nonexistent.crt: No such file or directory" in out
    rc, out = check(tmp_path, "tls_cert = %s\ntls_key = %s\n" % (key, key))
    assert rc == EXIT_CONFIG and "FILE:4:" in out and "no certificate in it" in out
    # a certificate and another's key: they do not load together
    rc, out = check(tmp_path, "tls_cert = %s\ntls_key = %s\n" % (crt, tls_dir / "other.key"))
    assert rc == EXIT_CONFIG and "FILE:4: [http] tls_cert" in out and "do not load" in out
    bad = tmp_path / "bad_users"
    bad.write_text("# users\nadmin:$6$abcdefgh$0123456789\nroot:plaintext\n")
    bad.chmod(0o600)
    rc, out = check(tmp_path, "port = 8080\nauth_file = %s\n" % bad)
    assert rc == EXIT_CONFIG
    assert "FILE:5: [http] auth_file %s:3: not a crypt(3) hash" % bad in out
    # a password file or TLS key others may read is refused, with the line
    (tmp_path / "open_users").write_text(users.read_text())
    (tmp_path / "open_users").chmod(0o644)
    rc, out = check(tmp_path, "port = 8080\nauth_file = %s\n" % (tmp_path / "open_users"))
    assert rc == EXIT_CONFIG
    assert "FILE:5: [http] auth_file %s is readable or writable by other users (mode 0644)" \
        % (tmp_path / "open_users") in out
    (tmp_path / "open.key").write_text(key.read_text())
    (tmp_path / "open.key").chmod(0o640)
    rc, out = check(tmp_path, "tls_cert = %s\ntls_key = %s\n" % (crt, tmp_path / "open.key"))
    assert rc == EXIT_CONFIG and "FILE:5: [http] tls_key" in out and "by its group" in out
    # a weak or unbounded hash: the line, and what to use instead
    weak = tmp_path / "weak_users"
    weak.write_text("admin:$1$uvQIcxeK$G9TGyFsvmD3mp.nhbWyis.\n")
    weak.chmod(0o600)
    rc, out = check(tmp_path, "port = 8080\nauth_file = %s\n" % weak)
    assert rc == EXIT_CONFIG and "FILE:5: [http] auth_file %s:1: an MD5 hash" % weak in out
    weak.write_text("admin:$6$rounds=999999999$abcdefgh$x5ue8x8ebAkvbD9dK\n")
    rc, out = check(tmp_path, "port = 8080\nauth_file = %s\n" % weak)
    assert rc == EXIT_CONFIG and "more than 100000 rounds" in out
    # the TLS priority string is tried
    rc, out = check(tmp_path, "tls_cert = %s\ntls_key = %s\ntls_priorities = NOPE:+X\n"
                    % (crt, key))
    assert rc == EXIT_CONFIG and "tls_priorities NOPE:+X" in out, out
    assert check(tmp_path, "tls_cert = %s\ntls_key = %s\ntls_priorities = SECURE256\n"
                 % (crt, key))[0] == 0
    rc, out = check(tmp_path, "allow = 10.0.0.1/8\n")
    assert rc == EXIT_CONFIG and "FILE:4: allow '10.0.0.1/8' invalid: host bits set" in out
    rc, out = check(tmp_path, "port = 502\n")
    assert rc == EXIT_CONFIG and "is the Modbus port" in out
    rc, out = check(tmp_path, "max_request_bytes = 100\n")
    assert rc == EXIT_CONFIG and "out of range (allowed: 4096..1048576)" in out


def test_allowlist_closes_others():
    port = free_port(GW_ADDR, udp=False)
    with running("http_allow", extra="\n[http]\nport = %d\nallow = 10.0.0.0/8\n" % port) as g:
        wait_for(lambda: g.listening(port), 10, "the console")
        out = raw_request(port, b"GET /api/v1/status HTTP/1.0\r\n\r\n")
        assert out == b""  # closed without an answer: 127.0.0.1 is not allowed
        g.extra = "\n[http]\nport = %d\nallow = 127.0.0.0/8\n" % port
        g.write_config()
        mark = len(g.log())
        g.signal(signal.SIGHUP)
        g.log_wait("reloaded (generation 1)", start=mark)
        assert get(port, "/api/v1/status")[0] == 200  # same port, new rules


def test_missing_library_stops_the_start(tmp_path):
    """DRGATE_MHD_LIB (drgatewayd(8)) pointing at nothing: the start stops
    with exit 1 and a line that names the library and what to do."""
    conf = tmp_path / "gw.ini"
    conf.write_text("[modbus]\nlisten = %s\nport = %d\n[robot r0]\nhost = %s\n[http]\nport = %d\n"
                    % (GW_ADDR, free_port(GW_ADDR, udp=False), SIM_ADDR,
                       free_port(GW_ADDR, udp=False)))
    env = dict(os.environ, DRGATE_MHD_LIB="/nonexistent/libmicrohttpd.so.12")
    p = subprocess.run([str(DRGATEWAYD), "-c", str(conf)], env=env, stdin=subprocess.DEVNULL,
                       capture_output=True, text=True, timeout=timeout(30))
    assert p.returncode == 1, p.stderr
    line = [ln for ln in p.stderr.splitlines() if "error: http:" in ln]
    assert len(line) == 1, p.stderr
    assert "http: cannot load /nonexistent/libmicrohttpd.so.12 (" in line[0]
    assert line[0].endswith("install libmicrohttpd12, or remove [http]")


def test_largest_map_is_served_whole():
    """The robot's map with the largest user map the configuration takes
    (GW_MAX_MAP blocks, here 64 of int_out[0..23] as DINTs) is several
    hundred kB of JSON: served whole, not refused as too large or 404."""
    port = free_port(GW_ADDR, udp=False)
    blocks = "".join("map = ir %d int_out[0..23] dint\n" % (2048 + 48 * i) for i in range(64))
    with running("http_bigmap", robot=blocks, extra="\n[http]\nport = %d\n" % port) as g:
        wait_for(lambda: g.listening(port), 10, "the console")
        name = get_json(port, "/api/v1/robots")[0]["name"]
        status, _, body = get(port, "/api/v1/robots/%s/map" % name)
        assert status == 200, body[:200]
        assert len(body) > 262144  # more than the response buffer held before
        doc = json.loads(body)
        text = json.dumps(doc)
        for i in range(64):
            assert '"address": %d' % (2048 + 48 * i) in text, i


def test_one_client_cannot_take_every_connection():
    """max_connections_per_ip: a client address holding its share of
    connections gets the next one closed unanswered, while the console
    still has room (max_connections), and is served again once it lets
    one go."""
    port = free_port(GW_ADDR, udp=False)
    with running("http_perip", extra="\n[http]\nport = %d\nmax_connections_per_ip = 3\n"
                 "max_connections = 16\ntimeout_s = 60\n" % port) as g:
        wait_for(lambda: g.listening(port), 10, "the console")
        held = []

        def alive(s):  # not closed by the daemon (nothing to read, no EOF)
            try:
                return s.recv(1, socket.MSG_PEEK) != b""
            except BlockingIOError:
                return True
            except OSError:
                return False

        def status_line():
            return raw_request(port, b"GET /api/v1/status HTTP/1.0\r\n\r\n")[9:12]

        def fourth_refused():
            # three live connections held (one the daemon refused because
            # an earlier probe of the port still counted is replaced) ...
            for s in [s for s in held if not alive(s)]:
                held.remove(s)
                s.close()
            while len(held) < 3:
                s = socket.create_connection((GW_ADDR, port), timeout=timeout(10))
                s.setblocking(False)  # alive() peeks without waiting
                held.append(s)
            time.sleep(0.1)
            # ... and a fourth closed unanswered; without the limit it is
            # always answered, and this waits in vain
            return status_line() == b"" and all(alive(s) for s in held)

        try:
            wait_for(fourth_refused, 10, "a fourth connection closed unanswered")
            held.pop().close()
            wait_for(lambda: status_line() == b"200", 10, "a connection served once one is let go")
        finally:
            for s in held:
                s.close()
