# SPDX-License-Identifier: MIT
"""Run a command next to cpppo's EtherNet/IP server (python -m
cpppo.server.enip), which serves one tag per robot assembly at the
assembly's CIP path (class 4, instance, attribute 3), e.g.
io_state@0x04/101/3=USINT[36], plus `short` at instance 111 with 35 bytes
(one fewer than io_state) for the wrong-size test, and the two points of a
combined layout (issue 31): `input` at instance 120 (476 bytes) and
`output` at 121 (212 bytes).

usage: with_cpppo.py RESULTS LABEL -- COMMAND...

The server listens on 127.0.0.3 at a free port; the command gets it in
CPPPO_HOST / CPPPO_PORT. If the server does not come up, one failure is
recorded in RESULTS under LABEL (the command would record nothing).
The command runs under a 300 s limit; the server is stopped afterwards.
"""
import os
import subprocess
import sys

import peers


def main():
    sep = sys.argv.index("--")
    results, label = sys.argv[1:sep]
    cmd = sys.argv[sep + 1:]
    tags = ["%s@0x04/%d/3=USINT[%d]" % (name, inst, size)
            for name, inst, _, size in peers.ASSEMBLIES]
    tags.append("short@0x04/111/3=USINT[35]")
    tags += ["input@0x04/120/3=USINT[476]", "output@0x04/121/3=USINT[212]"]
    server = None
    err = None
    for _ in range(3):
        port = peers.free_port(peers.PEER_ADDR)
        argv = [sys.executable, "-m", "cpppo.server.enip", "--no-config", "--no-print",
                "-a", "%s:%d" % (peers.PEER_ADDR, port)] + tags
        try:
            server = peers.Server("cpppo", argv, peers.PEER_ADDR, port, ready_timeout=30)
            break
        except RuntimeError as e:
            err = e
    if server is None:
        print("with_cpppo: %s" % err)
        with open(results, "a") as f:
            f.write("0 1 %s (cpppo server did not start)\n" % label)
        return 1
    env = dict(os.environ, CPPPO_HOST=peers.PEER_ADDR, CPPPO_PORT=str(port))
    try:
        rc = subprocess.run(cmd, env=env, timeout=300).returncode
    except subprocess.TimeoutExpired:
        print("with_cpppo: %s timed out" % " ".join(cmd))
        with open(results, "a") as f:
            f.write("0 1 %s (timed out)\n" % label)
        rc = 1
    alive = server.alive()
    server.stop()
    if rc != 0 or not alive:
        print("---- cpppo's log (tail) ----\n%s" % server.log_text())
    server.cleanup()
    return rc


if __name__ == "__main__":
    sys.exit(main())
