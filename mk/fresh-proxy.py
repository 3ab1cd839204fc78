#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
# The only way out of a fresh root (mk/fresh-root.sh): an HTTP proxy on a
# unix socket that forwards plain HTTP GET/HEAD requests and HTTPS CONNECT
# tunnels to the hosts it is given, and refuses everything else with 403.
# One request per connection (it answers "Connection: close"; the root's
# apt is told Pipeline-Depth 0). Every request is logged, one line each:
#   TIME allow|DENY METHOD HOST:PORT [PATH] BYTES|REASON
# usage: fresh-proxy.py SOCKET LOG HOST...
#   SOCKET  the unix socket to listen on (created; removed at exit)
#   LOG     the log file (appended)
#   HOST    an allowed host name (exact match); ports 80 and 443 only
# Stops on SIGTERM or SIGINT. Python 3 standard library only.
import os
import select
import signal
import socket
import socketserver
import sys
import threading
import time

CONNECT_TIMEOUT = 20   # seconds to reach an upstream host
IDLE_TIMEOUT = 300     # seconds a tunnel or a response may stay silent
HEAD_MAX = 65536       # bytes of request head

sock_path, log_path = sys.argv[1], sys.argv[2]
allowed = {h.lower() for h in sys.argv[3:]}
log_lock = threading.Lock()


def log(*words):
    line = time.strftime("%H:%M:%S ") + " ".join(str(w) for w in words) + "\n"
    with log_lock, open(log_path, "a") as f:
        f.write(line)


def relay(a, b):
    """Copy both ways between sockets a and b until one side closes or
    nothing moves for IDLE_TIMEOUT; return the bytes sent from b to a."""
    n = 0
    socks = [a, b]
    while True:
        r, _, _ = select.select(socks, [], [], IDLE_TIMEOUT)
        if not r:
            return n
        for s in r:
            try:
                data = s.recv(65536)
            except OSError:
                return n
            if not data:
                return n
            other = b if s is a else a
            try:
                other.sendall(data)
            except OSError:
                return n
            if s is b:
                n += len(data)


class Handler(socketserver.BaseRequestHandler):
    def refuse(self, code, why, method, target):
        log("DENY", method, target, why)
        msg = f"fresh-proxy: {why}\n".encode()
        self.request.sendall(
            f"HTTP/1.1 {code} {'Forbidden' if code == 403 else 'Bad Request'}\r\n"
            f"Content-Type: text/plain\r\nContent-Length: {len(msg)}\r\n"
            f"Connection: close\r\n\r\n".encode() + msg)

    def handle(self):
        c = self.request
        c.settimeout(IDLE_TIMEOUT)
        head = b""
        try:
            while b"\r\n\r\n" not in head:
                d = c.recv(4096)
                if not d:
                    return
                head += d
                if len(head) > HEAD_MAX:
                    return self.refuse(400, "request head too long", "?", "?")
        except OSError:
            return
        head, _, body = head.partition(b"\r\n\r\n")
        lines = head.decode("latin-1").split("\r\n")
        try:
            method, target, version = lines[0].split(" ", 2)
        except ValueError:
            return self.refuse(400, "bad request line", "?", lines[0][:80])
        if method == "CONNECT":
            host, _, port = target.rpartition(":")
            path = ""
        elif method in ("GET", "HEAD") and target.startswith("http://"):
            rest = target[len("http://"):]
            hostport, slash, path = rest.partition("/")
            path = slash + path
            host, _, port = hostport.partition(":")
            port = port or "80"
        else:
            return self.refuse(403, "only GET/HEAD http:// and CONNECT", method, target[:200])
        host = host.strip("[]").lower()
        if host not in allowed:
            return self.refuse(403, "host not allowed", method, f"{host}:{port}")
        if port not in ("80", "443"):
            return self.refuse(403, "port not allowed", method, f"{host}:{port}")
        try:
            up = socket.create_connection((resolve(host), int(port)), timeout=CONNECT_TIMEOUT)
        except OSError as e:
            log("FAIL", method, f"{host}:{port}", path, e)
            msg = f"fresh-proxy: {host}:{port}: {e}\n".encode()
            c.sendall(b"HTTP/1.1 502 Bad Gateway\r\nContent-Length: %d\r\n"
                      b"Connection: close\r\n\r\n" % len(msg) + msg)
            return
        up.settimeout(IDLE_TIMEOUT)
        try:
            if method == "CONNECT":
                c.sendall(b"HTTP/1.1 200 Connection established\r\n\r\n")
                if body:
                    up.sendall(body)
            else:
                hdrs = [l for l in lines[1:] if l.split(":", 1)[0].lower() not in
                        ("connection", "proxy-connection", "keep-alive", "proxy-authorization")]
                req = f"{method} {path} {version}\r\n" + "\r\n".join(hdrs) + \
                    "\r\nConnection: close\r\n\r\n"
                up.sendall(req.encode("latin-1") + body)
            n = relay(c, up)
            log("allow", method, f"{host}:{port}", path, n)
        finally:
            up.close()


resolved = {}
resolve_lock = threading.Lock()


def resolve(host):
    """The host's address, looked up once (npm opens a dozen connections
    at once: as many lookups side by side failed here with EAI_AGAIN),
    with a few tries a second apart."""
    with resolve_lock:
        if host in resolved:
            return resolved[host]
        for attempt in range(5):
            try:
                addr = socket.getaddrinfo(host, None, socket.AF_INET, socket.SOCK_STREAM)[0][4][0]
                resolved[host] = addr
                return addr
            except socket.gaierror:
                if attempt == 4:
                    raise
                time.sleep(1)


class Server(socketserver.ThreadingMixIn, socketserver.UnixStreamServer):
    daemon_threads = True


def stop(*_):
    raise SystemExit(0)


signal.signal(signal.SIGTERM, stop)
signal.signal(signal.SIGINT, stop)
if os.path.exists(sock_path):
    os.unlink(sock_path)
srv = Server(sock_path, Handler)
os.chmod(sock_path, 0o666)
log("listening", sock_path, "allow:", " ".join(sorted(allowed)))
try:
    srv.serve_forever()
finally:
    try:
        os.unlink(sock_path)
    except OSError:
        pass
