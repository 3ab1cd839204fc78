# SPDX-License-Identifier: MIT
"""drsim against python-ethernetip (`ethernetip`), an independent Class 1
scanner: Forward Open with its own encoding, O->T produced by its thread,
T->O parsed by its receiver, Forward Close. The scanner runs as a separate
process (ethernetip_scanner.py) so that it can also run inside a network
namespace.

Two ways to share UDP 2222 (see ../shared/notes/enip-facts.md):
- on this host, without root: drsim on 127.0.0.2 with free ports, the
  scanner on 0.0.0.0 with a free port it announces in the Forward Open's
  0x8001 item (drsim honours it);
- as root, two network namespaces joined by a veth pair: drsim and the
  scanner each on their own host, both on the standard ports 44818 / 2222,
  nothing announced -- a real cell. Skipped without root.
"""
import json
import os
import shutil
import struct
import subprocess
import sys
import unittest

import peers

SCANNER = os.path.join(peers.HERE, "ethernetip_scanner.py")
RPI_MS = 20


class Checks:
    """Assertions on the scanner's JSON report."""

    def check_report(self, res):
        self.assertTrue(res.get("ok"), res.get("error", res))
        for key in "ABC":
            self.assertEqual(res["fo_" + key], 0, "Forward Open " + key)
            self.assertEqual(res["fc_" + key], 0, "Forward Close " + key)
        cids = [cid for key in "ABC" for cid in res["cid_" + key]]
        self.assertEqual(len(set(cids)), 6, "six distinct connection IDs")
        # O->T applied: io_control's cb_do 1, 16 and tool_do 3 show up in
        # io_state, received over T->O by python-ethernetip ...
        io = bytes.fromhex(res["io_state_rx"])
        self.assertEqual(len(io), 36)
        self.assertEqual(io[2:4], b"\x01\x80", "io_state.cb_do over T->O")
        self.assertEqual(io[26] & 0x3F, 0x04, "io_state.tool_do over T->O")
        self.assertEqual(tuple(io[28:31]), (2, 12, 3), "controller version")
        # ... bit_in echoes to bit_out ...
        self.assertEqual(res["bit_out_rx"], res["bit_in_sent"], "bit_in -> bit_out over T->O")
        # ... and the same through explicit reads of drsim's assemblies
        self.assertEqual(res["io_control_get"], [0, res["io_control_sent"]])
        self.assertEqual(res["bit_out_get"], [0, res["bit_in_sent"]])
        io_get = bytes.fromhex(res["io_state_get"][1])
        self.assertEqual(io_get[2:4], b"\x01\x80")
        # the input-only connection (heartbeat 198) carries joint_state,
        # and it moves: two snapshots 0.3 s apart differ
        j1, j2 = (bytes.fromhex(h) for h in res["joint_state_rx"])
        self.assertEqual(len(j1), 144)
        self.assertNotEqual(j1, j2, "joint_state changes between T->O packets")
        for pos in struct.unpack_from("<6f", j2, 0):
            self.assertTrue(-360.0 <= pos <= 360.0, pos)


def scan_on_this_host(test, check, *sim_args):
    """The scanner (its LAYOUT: drsim's --layout, if sim_args give one)
    against a drsim of its own with sim_args; check(res) on its report;
    drsim must stop cleanly."""
    sim = peers.Drsim(*sim_args)
    layout = list(sim_args[1:2]) if sim_args[:1] == ("--layout",) else []
    res = {}
    try:
        r = peers.run([sys.executable, SCANNER, peers.SIM_ADDR, str(sim.tcp_port),
                       str(sim.udp_port), "0", str(RPI_MS)] + layout, timeout=60)
        print(r.stderr[-2000:], end="")
        res = json.loads(r.stdout.strip().splitlines()[-1]) if r.stdout.strip() else {}
        check(res)
    finally:
        rc = sim.stop()
        if rc != 0 or not res.get("ok"):
            print(sim.log_text())
        sim.cleanup()
    test.assertEqual(rc, 0, "drsim exit status")


class EthernetipOnThisHost(unittest.TestCase, Checks):
    def test_class1_with_announced_ports(self):
        def check(res):
            self.check_report(res)
            self.assertNotEqual(res["scanner_udp_port"], 2222)
        scan_on_this_host(self, check)


class EthernetipLayouts(unittest.TestCase):
    """drsim --layout combined and gpr_only (issue 31): python-ethernetip
    opens the one connection between the two points with its own Forward
    Open (T->O 476 + 2, O->T 212 + 6 bytes; gpr_only 200 each way), its
    O->T lands in io_control and bit_in at their places, T->O brings
    io_state and the bit_out echo at theirs and moving joint positions,
    and explicit Gets of the points agree."""

    def run_layout(self, layout):
        def check(res):
            self.assertTrue(res.get("ok"), res.get("error", res))
            self.assertEqual((res["fo_A"], res["fc_A"]), (0, 0))
            size = 476 if layout == "combined" else 200
            r1, r2 = (bytes.fromhex(h) for h in res["in_rx"])
            self.assertEqual(len(r2), size)
            bo = res["bit_out_offset"]
            self.assertEqual(r2[bo:bo + 8].hex(), res["bit_in_sent"], "bit_in -> bit_out")
            self.assertEqual(res["out_get"], [0, res["out_sent"]], "O->T point as sent")
            in_get = bytes.fromhex(res["in_get"][1])
            self.assertEqual((res["in_get"][0], len(in_get)), (0, size))
            self.assertEqual(in_get[bo:bo + 8].hex(), res["bit_in_sent"])
            if layout == "combined":
                self.assertEqual(r2[2:4], b"\x01\x80", "io_state.cb_do over T->O")
                self.assertEqual(tuple(r2[28:31]), (2, 12, 3), "controller version")
                self.assertNotEqual(r1[36:180], r2[36:180], "joint_state moves")
                for pos in struct.unpack_from("<6f", r2, 36):
                    self.assertTrue(-360.0 <= pos <= 360.0, pos)
        scan_on_this_host(self, check, "--layout", layout)

    def test_combined(self):
        self.run_layout("combined")

    def test_gpr_only(self):
        self.run_layout("gpr_only")


def ip(*args, check=True):
    return subprocess.run(["ip"] + list(args), capture_output=True, text=True,
                          timeout=20, check=check)


class EthernetipInNamespaces(unittest.TestCase, Checks):
    """Two hosts: namespace A runs drsim on 10.222.0.2, namespace B the
    scanner on 10.222.0.1, each on 44818 / 2222. The names carry our PID,
    so concurrent runs do not meet."""

    def setUp(self):
        if os.geteuid() != 0:
            self.skipTest("network namespaces need root")
        if shutil.which("ip") is None:
            self.skipTest("no ip(8) (iproute2)")
        tag = "drg%d" % os.getpid()
        self.ns = (tag + "a", tag + "b")
        self.made = []
        try:
            for ns in self.ns:
                ip("netns", "add", ns)
                self.made.append(ns)
            ip("link", "add", "veth0", "netns", self.ns[0], "type", "veth",
               "peer", "name", "veth0", "netns", self.ns[1])
            for ns, addr in zip(self.ns, ("10.222.0.2/24", "10.222.0.1/24")):
                ip("-n", ns, "addr", "add", addr, "dev", "veth0")
                ip("-n", ns, "link", "set", "veth0", "up")
                ip("-n", ns, "link", "set", "lo", "up")
        except subprocess.CalledProcessError as e:
            self.tearDown()
            self.skipTest("cannot make network namespaces here: %s" % e.stderr.strip())

    def tearDown(self):
        for ns in self.made:
            ip("netns", "del", ns, check=False)
        self.made = []

    def test_class1_standard_ports_two_hosts(self):
        sim = subprocess.Popen(["ip", "netns", "exec", self.ns[0], os.path.abspath(peers.drsim_path()),
                                "--address", "10.222.0.2", "-v"],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                               stdin=subprocess.DEVNULL)
        res = {}
        try:
            r = subprocess.run(["ip", "netns", "exec", self.ns[1], sys.executable, SCANNER,
                                "10.222.0.2", "44818", "2222", "2222", str(RPI_MS)],
                               capture_output=True, text=True, timeout=60)
            print(r.stderr[-2000:], end="")
            res = json.loads(r.stdout.strip().splitlines()[-1]) if r.stdout.strip() else {}
            self.check_report(res)
            self.assertEqual(res["scanner_udp_port"], 2222)
        finally:
            rc = peers.stop(sim)
            out = sim.stdout.read()
            if rc != 0 or not res.get("ok"):
                print(out[-4000:])
        # The scanner listened on 2222 only and announced nothing, so the
        # T->O data it checked came to the standard port.
        self.assertEqual(rc, 0, "drsim exit status")


if __name__ == "__main__":
    unittest.main()
