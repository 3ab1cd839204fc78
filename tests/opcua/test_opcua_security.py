# SPDX-License-Identifier: MIT
"""The OPC UA side on a non-loopback endpoint (docs/opcua.md "Security"),
in a network namespace of its own (no route out: the traffic never leaves
it): only Basic256Sha256 endpoints are offered (no SecurityPolicy None),
anonymous and wrong passwords are refused, Sign&Encrypt with the right
user reads the robot. The server's certificate is DER, its key PEM (both
forms the side reads); the users file is the console's format."""
import asyncio
import subprocess

import pytest
from asyncua import Client, ua

from gwlib import (DRGATEWAYD, DRSIM, LOGDIR, in_netns, skip, spawn, timeout, wait_for)
from ualib import run

UA_IP = "10.9.2.1"
UA_PORT = 4840
MODBUS_PORT = 1502
APP_URI = "urn:drgate:test:drgatewayd"
CLIENT_URI = "urn:example.org:FreeOpcUa:opcua-asyncio"  # asyncua's own ApplicationUri


def openssl(*args, cwd):
    subprocess.run(["openssl"] + list(args), cwd=cwd, check=True, capture_output=True,
                   timeout=timeout(60))


def cert(d, name, uri, extra_san=""):
    """An RSA 2048 self-signed application instance certificate (OPC UA
    Part 6: the ApplicationUri in subjectAltName, its key usages)."""
    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", name + "-key.pem", "-out",
            name + ".pem", "-days", "2", "-sha256", "-subj", "/CN=" + name,
            "-addext", "subjectAltName=URI:%s%s" % (uri, extra_san),
            "-addext", "keyUsage=critical,digitalSignature,nonRepudiation,keyEncipherment,"
                       "dataEncipherment,keyCertSign",
            "-addext", "extendedKeyUsage=serverAuth,clientAuth", cwd=d)
    openssl("x509", "-in", name + ".pem", "-outform", "der", "-out", name + ".der", cwd=d)


class Cell:
    """The namespace (held by a sleeping process), drsim and the gateway."""

    def __init__(self, d):
        self.dir = d
        self.holder = subprocess.Popen(
            ["unshare", "-n", "sh", "-c",
             "ip link set lo up && ip addr add %s/32 dev lo && exec sleep 100000" % UA_IP])
        self.ns = "/proc/%d/ns/net" % self.holder.pid
        self.procs = []
        wait_for(self.address_up, 10, "the namespace's address")
        self.sim_log = LOGDIR / "ua_sec.drsim.log"
        self.spawn([DRSIM, "-a", "127.0.0.2", "-v", "--still"], self.sim_log)
        wait_for(lambda: "listening on" in self.sim_log.read_text(), 10, "drsim")

    def address_up(self):
        out = subprocess.run(["nsenter", "--net=" + self.ns, "ip", "-o", "addr"],
                             capture_output=True, text=True).stdout
        return UA_IP + "/32" in out

    def spawn(self, argv, log):
        if log.exists():
            log.unlink()
        p = spawn(["nsenter", "--net=" + self.ns] + [str(a) for a in argv], log)
        self.procs.append(p)
        return p

    def gateway(self, opcua):
        conf = LOGDIR / "ua_sec.ini"
        conf.write_text("[modbus]\nlisten = 127.0.0.1\nport = %d\n[robot r0]\nhost = 127.0.0.2\n"
                        "local_address = 127.0.0.1\ntimeout_multiplier = 4\n[opcua]\n"
                        "listen = %s\nport = %d\n%s" % (MODBUS_PORT, UA_IP, UA_PORT, opcua))
        log = LOGDIR / "ua_sec.gateway.log"
        p = self.spawn([DRGATEWAYD, "-c", conf], log)
        p.log = log
        wait_for(lambda: "opcua: listening on" in log.read_text() or p.poll() is not None, 20,
                 "the OPC UA server")
        assert p.poll() is None, log.read_text()
        wait_for(lambda: "link up" in log.read_text(), 20, "the robot's link up")
        return p

    def close(self):
        for p in self.procs:
            p.kill()
            p.wait()
        self.holder.kill()
        self.holder.wait()


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    if subprocess.run(["unshare", "-n", "true"], capture_output=True).returncode != 0:
        skip("test_opcua_security", "cannot make a network namespace")
    LOGDIR.mkdir(parents=True, exist_ok=True)
    d = tmp_path_factory.mktemp("ua_sec")
    cert(d, "server", APP_URI, ",IP:" + UA_IP)
    cert(d, "client", CLIENT_URI)
    hashed = subprocess.run(["openssl", "passwd", "-6", "s3cret"], capture_output=True,
                            text=True, check=True).stdout.strip()
    (d / "users").write_text("# plant clients\nplant:%s\n" % hashed)
    (d / "users").chmod(0o600)
    c = Cell(d)
    try:
        c.gw = c.gateway("security_policies = Basic256Sha256\ncert_file = %s\nkey_file = %s\n"
                         "auth_file = %s\napplication_uri = %s\n"
                         % (d / "server.der", d / "server-key.pem", d / "users", APP_URI))
        yield c
    finally:
        c.close()


URL = "opc.tcp://%s:%d" % (UA_IP, UA_PORT)


def in_cell(cell, coro_fn):
    """coro_fn() run by asyncua from inside the namespace: its sockets are
    made there (this thread is in it while the loop runs)."""
    with in_netns(cell.ns):
        return run(coro_fn())


def connect_error(cell, security=None, user=None, password=None):
    """The status code connecting and reading fails with, or None."""
    async def go():
        c = Client(URL, timeout=timeout(10))
        if security:
            await c.set_security_string(security % {"d": cell.dir})
        if user:
            c.set_user(user)
            c.set_password(password)
        try:
            await c.connect()
        except ua.UaStatusCodeError as e:
            return e.code
        except Exception as e:  # noqa: BLE001: refused before any status (no endpoint)
            return type(e).__name__
        try:
            ns = await c.get_namespace_index("urn:drgate:robots")
            dv = await c.get_node(ua.NodeId("r0/joint_state.position[3]", ns)).read_data_value(
                raise_on_bad_status=False)
            # (Uncertain: a link a loaded machine let time out a moment)
            assert not dv.StatusCode.is_bad() and dv.Value.Value == 90.0, dv
            return None
        finally:
            await c.disconnect()
    return in_cell(cell, go)


SECURE = "Basic256Sha256,SignAndEncrypt,%(d)s/client.pem,%(d)s/client-key.pem"


def test_only_secure_endpoints(cell):
    """GetEndpoints (over the None channel discovery needs): Basic256Sha256
    with Sign and SignAndEncrypt, no None endpoint, the server's certificate
    (the DER file) in each."""
    async def endpoints():
        c = Client(URL, timeout=timeout(10))
        return await c.connect_and_get_server_endpoints()
    eps = in_cell(cell, endpoints)
    assert {e.SecurityPolicyUri for e in eps} == \
        {"http://opcfoundation.org/UA/SecurityPolicy#Basic256Sha256"}
    assert {e.SecurityMode for e in eps} == {ua.MessageSecurityMode.Sign,
                                              ua.MessageSecurityMode.SignAndEncrypt}
    der = (cell.dir / "server.der").read_bytes()
    assert all(e.ServerCertificate == der for e in eps)
    assert all(e.Server.ApplicationUri == APP_URI for e in eps)
    # user names only: no anonymous, no X.509 user certificates (which,
    # without a trust list, any certificate would pass)
    assert {t.TokenType for e in eps for t in e.UserIdentityTokens} == {ua.UserTokenType.UserName}


def test_none_refused(cell):
    assert connect_error(cell) is not None


def test_anonymous_refused(cell):
    assert connect_error(cell, SECURE) is not None


def test_wrong_password_refused(cell):
    mark = len(cell.gw.log.read_text())
    assert connect_error(cell, SECURE, "plant", "wrong") is not None
    assert connect_error(cell, SECURE, "nobody", "s3cret") is not None
    wait_for(lambda: "login of 'plant' refused" in cell.gw.log.read_text()[mark:], 10,
             "the refusal in the log")


def test_sign_and_encrypt_with_the_right_user(cell):
    """Sign&Encrypt, the right user: the robot's data. (Refused logins of
    an earlier test may still hold the second's budget of password checks:
    the login is tried until that second is over.)"""
    wait_for(lambda: connect_error(cell, SECURE, "plant", "s3cret") is None, 20,
             "a login with the right password")
    # a second time: the login remembered, the same answer
    assert connect_error(cell, SECURE, "plant", "s3cret") is None
