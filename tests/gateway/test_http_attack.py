# SPDX-License-Identifier: MIT
"""The console against an attacker on the plant network (issue 29): the
gateway, drsim and the attacker's sockets all in one network namespace of
their own, the attacker coming from addresses that are not loopback
(10.9.1.2 ...), the gateway's console on 10.9.1.1 with TLS and a password
file of yescrypt hashes (what Debian's mkpasswd makes). No packet leaves
the namespace.

- a flood of wrong passwords: Modbus p99 within 3x of a quiet run, the
  robot's link never drops, the console's log not flushed;
- an unknown user refused as slowly as a known one (within 2x);
- a user name with "\\n<0>..." logged as one line, escaped;
- 32 live streams held from four addresses: `drgatewayd status` and
  /metrics still answer, streams bounded;
- TLS 1.0 and 1.1 (and CBC suites) refused."""
import base64
import http.client
import os
import re
import socket
import ssl
import statistics
import subprocess
import threading
import time

import pytest

from gwlib import (DRGATEWAYD, DRSIM, LOGDIR, NetnsCell, RawModbus, in_netns, skip,
                   status_read_latencies, thread_of, timeout, wait_for, yescrypt)

GW_IP = "10.9.1.1"
ATTACKERS = ["10.9.1.%d" % i for i in range(2, 40)]
MODBUS_PORT, HTTPS_PORT, STATUS_PORT, PLAIN_PORT = 1502, 8443, 8080, 8090


def openssl(*args, cwd):
    subprocess.run(["openssl"] + list(args), cwd=cwd, check=True, capture_output=True,
                   timeout=timeout(60))


class Cell(NetnsCell):
    """The namespace (gwlib.NetnsCell), drsim and gateways in it."""

    def __init__(self, d):
        super().__init__([GW_IP] + list(ATTACKERS))
        self.dir = d
        self.sim_log = LOGDIR / "attack.drsim.log"
        self.sim = self.spawn([DRSIM, "-a", "127.0.0.2", "-v"], self.sim_log)
        wait_for(lambda: "listening on" in self.sim_log.read_text(), 10, "drsim")

    def gateway(self, name, http):
        conf = LOGDIR / ("attack_%s.ini" % name)
        conf.write_text("[modbus]\nlisten = 127.0.0.1\nport = %d\n[robot r0]\nhost = 127.0.0.2\n"
                        "local_address = 127.0.0.1\nlocal_udp_port = 2223\ntimeout_multiplier = 4\n[http]\n%s" % (MODBUS_PORT, http))
        log = LOGDIR / ("attack_%s.gateway.log" % name)
        p = self.spawn([DRGATEWAYD, "-c", conf], log)
        p.conf, p.log = conf, log
        wait_for(lambda: "http: console on" in log.read_text() or p.poll() is not None, 20,
                 "the console")
        assert p.poll() is None, log.read_text()
        wait_for(lambda: self.modbus_status()[1] == 2, 20, "the robot's link up")
        return p

    def modbus(self):
        with in_netns(self.ns):
            return RawModbus("127.0.0.1", MODBUS_PORT, connect_timeout=5)

    def modbus_status(self):
        with self.modbus() as m:
            return m.read(4, 0, 31)


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    if not NetnsCell.possible():
        skip("test_http_attack", "cannot make a network namespace")
    LOGDIR.mkdir(parents=True, exist_ok=True)
    d = tmp_path_factory.mktemp("attack")
    openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
            "-nodes", "-keyout", "server.key", "-out", "server.crt", "-days", "2", "-subj",
            "/CN=%s" % GW_IP, cwd=d)
    (d / "users").write_text("admin:%s\n" % yescrypt("s3cret"))
    (d / "users").chmod(0o600)
    (d / "server.key").chmod(0o600)
    c = Cell(d)
    try:
        yield c
    finally:
        c.close()


def tls_http(cell, d):
    return ("listen = 0.0.0.0\nport = %d\ntls_cert = %s\ntls_key = %s\nauth_file = %s\n"
            "status_port = %d\n" % (HTTPS_PORT, d / "server.crt", d / "server.key",
                                    d / "users", STATUS_PORT))


def ctx_for(cell):
    ctx = ssl.create_default_context(cafile=str(cell.dir / "server.crt"))
    ctx.check_hostname = False
    return ctx


def login_request(user, password):
    auth = base64.b64encode(("%s:%s" % (user, password)).encode()).decode()
    return ("GET /api/v1/status HTTP/1.1\r\nHost: %s\r\nAuthorization: Basic %s\r\n\r\n"
            % (GW_IP, auth)).encode()


def read_answer(s):
    """One HTTP answer's status (its body read by Content-Length)."""
    buf = b""
    while b"\r\n\r\n" not in buf:
        b = s.recv(65536)
        if not b:
            raise ConnectionError("closed")
        buf += b
    head, body = buf.split(b"\r\n\r\n", 1)
    m = re.search(rb"(?i)content-length: *(\d+)", head)
    n = int(m.group(1)) if m else 0
    while len(body) < n:
        b = s.recv(65536)
        if not b:
            break
        body += b
    return int(head.split()[1])


def modbus_latencies(cell, seconds):
    with cell.modbus() as m:
        lat = status_read_latencies(m, seconds)
    return lat[int(len(lat) * 0.99)], len(lat)


def link_faults(cell, p):
    text = p.log.read_text()
    return text.count("no packet from the robot") + text.count("timed out")


def test_wrong_password_flood(cell):
    """Wrong passwords for a yescrypt user from eight addresses, as fast as
    they are answered: the robot's link never drops (before issue 29 it
    dropped 7-15 times in 10 s), and the console's last 200 events are not
    pushed out. Modbus p99 beside the flood is printed, a figure: its goal
    (1.5x of none) is make bench's (bench/console_bench.py), as a busy
    machine's stalls are no attack's."""
    p = cell.gateway("flood", tls_http(cell, cell.dir))
    try:
        # the passwords' crypt on its worker, in the idle scheduling class:
        # the loop's thread takes a CPU from it whenever it wakes
        login = thread_of(p.pid, "http-login")
        assert login is not None and os.sched_getscheduler(login) == os.SCHED_IDLE
        quiet, n_quiet = modbus_latencies(cell, 3)
        faults0 = link_faults(cell, p)
        stop = threading.Event()
        sent = [0]
        ctx = ctx_for(cell)

        def attacker(src, k):
            i = 0
            while not stop.is_set():
                try:
                    s = ctx.wrap_socket(cell.sock(GW_IP, HTTPS_PORT, src))
                    while not stop.is_set():
                        s.sendall(login_request("admin", "guess%d-%d" % (k, i)))
                        i += 1
                        read_answer(s)
                        sent[0] += 1
                    s.close()
                except (OSError, ConnectionError, ssl.SSLError):
                    time.sleep(0.01)

        threads = [threading.Thread(target=attacker, args=(ATTACKERS[k % 8], k), daemon=True)
                   for k in range(16)]
        for t in threads:
            t.start()
        time.sleep(0.5)
        try:
            flood, n_flood = modbus_latencies(cell, 5)
        finally:
            stop.set()
            for t in threads:
                t.join(timeout(30))
        faults = link_faults(cell, p) - faults0
        ratio = flood / quiet
        print("\nwrong-password flood: %d answers; Modbus p99 quiet %.3f ms (%d reads), "
              "flood %.3f ms (%d reads): x%.2f; link faults %d"
              % (sent[0], quiet * 1e3, n_quiet, flood * 1e3, n_flood, ratio, faults))
        assert faults == 0, p.log.read_text()[-3000:]
        # the log: one line per address per 10 s, and the start still in
        # the console's last 200 events
        text = p.log.read_text()
        assert text.count("login refused") <= 40, text.count("login refused")
        with cell.sock("127.0.0.1", STATUS_PORT) as s:
            s.sendall(b"GET /api/v1/log HTTP/1.0\r\nHost: localhost\r\n\r\n")
            got = b""
            while True:
                b = s.recv(65536)
                if not b:
                    break
                got += b
        assert b"http: console on https://0.0.0.0:8443/" in got
        # refused logins are counted in /metrics
        with cell.sock("127.0.0.1", STATUS_PORT) as s:
            s.sendall(b"GET /metrics HTTP/1.0\r\nHost: localhost\r\n\r\n")
            got = b""
            while True:
                b = s.recv(65536)
                if not b:
                    break
                got += b
        m = re.search(rb"drgate_http_logins_failed_total (\d+)", got)
        assert m and int(m.group(1)) > 0
    finally:
        cell.stop(p)


def timed_login(cell, src, user, password):
    s = cell.sock(GW_IP, PLAIN_PORT, src)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    try:
        t0 = time.perf_counter()
        s.sendall(login_request(user, password))
        st = read_answer(s)
        dt = time.perf_counter() - t0
    finally:
        s.close()
    assert st == 401
    return dt


def test_unknown_user_costs_what_a_known_one_does(cell):
    """A wrong password for the yescrypt user and any password for a user
    that does not exist take the same time (medians within 2x): the user
    list cannot be read off the clock. Each try from an address of its
    own and with a password of its own (no wait, no cache); plain HTTP
    (insecure = yes), so that TLS's own delays do not hide the difference."""
    p = cell.gateway("timing", "listen = 0.0.0.0\nport = %d\ninsecure = yes\nauth_file = %s\n"
                     % (PLAIN_PORT, cell.dir / "users"))
    known, unknown = [], []
    try:
        for i in range(7):
            known.append(timed_login(cell, ATTACKERS[10 + 2 * i], "admin", "k%d" % i))
            unknown.append(timed_login(cell, ATTACKERS[11 + 2 * i], "nobody%d" % i, "u%d" % i))
        k, u = statistics.median(known), statistics.median(unknown)
        print("\nrefusal: known user %.2f ms, unknown user %.2f ms (medians of 7)"
              % (k * 1e3, u * 1e3))
        assert 0.5 <= u / k <= 2.0, (k, u)
    finally:
        cell.stop(p)


def test_held_logins_of_clients_gone(cell):
    """Wrong passwords from six addresses over TLS, two kept-alive
    connections each, as the attacker of test_wrong_password_flood, which
    then goes away while logins are held for their address's wait (from
    the 5th refusal): when the waits end the daemon answers into closed
    connections, which MHD closes and frees while the console walks its
    list of connections (a use-after-free in ht_tick found by make
    bench-console's flood: the daemon died of SIGSEGV, under ASan
    heap-use-after-free). It lives on and answers a good login."""
    p = cell.gateway("held", tls_http(cell, cell.dir))
    ctx = ctx_for(cell)
    stop = threading.Event()

    def attacker(src, k):
        i = 0
        while not stop.is_set():
            try:
                s = ctx.wrap_socket(cell.sock(GW_IP, HTTPS_PORT, src))
                s.settimeout(0.2)
                while not stop.is_set():
                    s.sendall(login_request("admin", "held%d-%d" % (k, i)))
                    i += 1
                    try:
                        read_answer(s)
                    except socket.timeout:
                        break  # held: this client goes away
                s.close()
            except (OSError, ConnectionError, ssl.SSLError):
                time.sleep(0.01)

    try:
        threads = [threading.Thread(target=attacker, args=(ATTACKERS[20 + k % 6], k), daemon=True)
                   for k in range(12)]
        for t in threads:
            t.start()
        time.sleep(4)
        stop.set()
        for t in threads:
            t.join(timeout(30))
        time.sleep(3)  # every wait (1, 2 s) is over
        assert p.poll() is None, p.log.read_text()[-3000:]
        s = ctx.wrap_socket(cell.sock(GW_IP, HTTPS_PORT, ATTACKERS[27]))
        s.sendall(login_request("admin", "s3cret"))
        assert read_answer(s) == 200
        s.close()
        assert p.poll() is None, p.log.read_text()[-3000:]
    finally:
        cell.stop(p)


def test_held_logins_bounded_per_address(cell):
    """From the 5th refusal of an address its logins are held to the end
    of its wait, but two at a time at most: the other connections of that
    address get 429 at once, with Retry-After, and are closed, so that a
    few flooding addresses cannot keep every connection slot (before: each
    held up to max_connections_per_ip connections for up to 32 s)."""
    p = cell.gateway("held-bound", tls_http(cell, cell.dir))
    ctx = ctx_for(cell)
    src = ATTACKERS[35]
    socks = []
    try:
        # refusals one after the other until the address's wait (1, 2, 4
        # ... s after each) is 2 s or more: the next one is 4 s or more
        for i in range(12):
            s = ctx.wrap_socket(cell.sock(GW_IP, HTTPS_PORT, src))
            s.settimeout(timeout(40))
            t0 = time.monotonic()
            s.sendall(login_request("admin", "bound%d" % i))
            assert read_answer(s) == 401
            s.close()
            if time.monotonic() - t0 >= 1.9:
                break
        else:
            assert False, "no wait of 2 s after 12 refusals"
        # five more within that wait: two held, three answered 429 at once;
        # the held ones get their 401 when the wait is over
        for i in range(5):
            s = ctx.wrap_socket(cell.sock(GW_IP, HTTPS_PORT, src))
            s.settimeout(timeout(40))
            s.sendall(login_request("admin", "held%d" % i))
            socks.append(s)
        answers = [read_answer(s) for s in socks]
        print("\nfive logins of one address in its wait: %s" % answers)
        assert answers.count(429) == 3 and answers.count(401) == 2, answers
    finally:
        for s in socks:
            s.close()
        cell.stop(p)


def test_forged_log_line_is_escaped(cell):
    """A user name "x\\n<0>forged ..." (an emergency in the journal if it
    became a line of its own) is logged on the refusal's own line, its
    newline escaped, with the client's address."""
    p = cell.gateway("forge", tls_http(cell, cell.dir))
    try:
        s = ctx_for(cell).wrap_socket(cell.sock(GW_IP, HTTPS_PORT, ATTACKERS[30]))
        s.sendall(login_request("x\n<0>forged emergency", "pw"))
        assert read_answer(s) == 401
        s.close()
        wait_for(lambda: "forged" in p.log.read_text(), 10, "the refusal logged")
        lines = p.log.read_text().splitlines()
        assert not [ln for ln in lines if ln.startswith("<0>") or ln.startswith("forged")]
        line = [ln for ln in lines if "forged" in ln]
        assert len(line) == 1 and "x\\x0a<0>forged emergency" in line[0], line
        assert "from %s" % ATTACKERS[30] in line[0]
    finally:
        cell.stop(p)


def test_held_streams_leave_status_and_metrics(cell):
    """32 live streams held by four addresses (a console served to the
    plant, insecure = yes: no login to get past): streams are bounded in
    all and per address, and `drgatewayd status` and /metrics (from a
    fifth address) still answer at once."""
    p = cell.gateway("streams", "listen = 0.0.0.0\nport = %d\ninsecure = yes\n" % PLAIN_PORT)
    held = []
    try:
        for k in range(32):
            s = cell.sock(GW_IP, PLAIN_PORT, ATTACKERS[k % 4])
            s.sendall(b"GET /api/v1/events?robot=r0 HTTP/1.1\r\nHost: %s\r\n\r\n"
                      % GW_IP.encode())
            held.append(s)
        time.sleep(1)
        st = subprocess.run(["nsenter", "--net=" + cell.ns, str(DRGATEWAYD), "status", "-c",
                             str(p.conf)], capture_output=True, text=True, timeout=timeout(30))
        print("\ndrgatewayd status: exit %d" % st.returncode)
        assert st.returncode in (0, 1), st.stderr
        with cell.sock(GW_IP, PLAIN_PORT, ATTACKERS[5]) as s:
            s.settimeout(5)
            s.sendall(b"GET /metrics HTTP/1.0\r\nHost: %s\r\n\r\n" % GW_IP.encode())
            got = b""
            while True:
                b = s.recv(65536)
                if not b:
                    break
                got += b
        assert got.startswith(b"HTTP/1.1 200"), got[:200]
        m = re.search(rb"drgate_http_streams (\d+)", got)
        assert m and 0 < int(m.group(1)) <= 16, m
        assert re.search(rb"drgate_http_streams_refused_total [1-9]", got)
    finally:
        for s in held:
            s.close()
        cell.stop(p)


@pytest.mark.parametrize("version", ["TLSv1", "TLSv1_1"])
def test_old_tls_refused(cell, version):
    """TLS 1.0 and 1.1 are refused, and so are CBC suites on TLS 1.2; TLS
    1.2 with an AEAD suite is taken."""
    p = cell.gateway("tls_" + version, tls_http(cell, cell.dir))
    try:
        ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
        ctx.check_hostname = False
        ctx.verify_mode = ssl.CERT_NONE
        ctx.set_ciphers("ALL:@SECLEVEL=0")
        v = getattr(ssl.TLSVersion, version)
        ctx.minimum_version = ctx.maximum_version = v
        with pytest.raises((ssl.SSLError, ConnectionError)):
            ctx.wrap_socket(cell.sock(GW_IP, HTTPS_PORT, ATTACKERS[31])).close()
        cbc = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
        cbc.check_hostname = False
        cbc.verify_mode = ssl.CERT_NONE
        cbc.minimum_version = cbc.maximum_version = ssl.TLSVersion.TLSv1_2
        cbc.set_ciphers("ECDHE-ECDSA-AES128-SHA:ECDHE-ECDSA-AES256-SHA:@SECLEVEL=0")
        with pytest.raises((ssl.SSLError, ConnectionError)):
            cbc.wrap_socket(cell.sock(GW_IP, HTTPS_PORT, ATTACKERS[31])).close()
        good = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
        good.check_hostname = False
        good.verify_mode = ssl.CERT_NONE
        good.minimum_version = good.maximum_version = ssl.TLSVersion.TLSv1_2
        s = good.wrap_socket(cell.sock(GW_IP, HTTPS_PORT, ATTACKERS[31]))
        assert "GCM" in s.cipher()[0] or "CHACHA" in s.cipher()[0], s.cipher()
        s.sendall(login_request("admin", "s3cret"))
        assert read_answer(s) == 200
        s.close()
    finally:
        cell.stop(p)
