# SPDX-License-Identifier: MIT
"""Wireshark's dissectors (tshark) decode a capture of our client talking to
drsim, explicit and implicit.

tests/interop/enip_session.c runs one whole session (RegisterSession, Gets
of every assembly, Identity, a Set, ListIdentity, Forward Open and Large
Forward Open, Class 1 I/O both ways, Forward Close, UnRegisterSession) and
prints what it sent; dumpcap captures it on the loopback interface; tshark
decodes the capture. The dissectors are Wireshark's, not ours: a frame they
cannot place, a malformed packet, an expert error, a request or connection
ID other than the ones we sent all fail here.

drsim listens on the standard ports (TCP 44818, UDP 2222), because the ENIP
dissector tells requests from replies by port 44818 only, and it links
replies and Class 1 frames to their Forward Open only when it can tell. So
that no other program (make demo, another build's tests) holds those ports
on the same address, drsim gets an address of its own in 127/8, derived
from our PID; no root is needed. The client's UDP socket is on 127.0.0.1 at
a free port, announced in the Forward Open's 0x8001 item.
"""
import collections
import os
import shutil
import subprocess
import tempfile
import time
import unittest

import peers

SESSION = os.path.join(peers.build_dir(), "tests", "interop", "enip_session")
ERROR = 0x00800000  # expert severities: note 0x400000, warn 0x600000, error 0x800000
WARN = 0x00600000


def sim_address(attempt):
    n = os.getpid() * 7 + attempt * 101
    return "127.77.%d.%d" % (n // 250 % 250 + 1, n % 250 + 1)


def hexint(s):
    return int(s, 16) if s.startswith("0x") else int(s)


class TsharkDecodesOurSession(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        for tool in ("tshark", "dumpcap"):
            if shutil.which(tool) is None:
                raise unittest.SkipTest("%s not installed (make test-deps installs it)" % tool)
        if not os.access(SESSION, os.X_OK):
            raise RuntimeError("no %s (build it first)" % SESSION)
        cls.tmp = tempfile.mkdtemp(prefix="drgate-tshark-")
        cls.pcap = os.path.join(cls.tmp, "session.pcapng")
        cls.sim = None
        for attempt in range(5):
            addr = sim_address(attempt)
            try:
                cls.sim = peers.Server("drsim", [peers.drsim_path(), "--address", addr, "-v"],
                                       addr, 44818)
                break
            except RuntimeError as e:
                err = e
        if cls.sim is None:
            raise err
        cls.addr = cls.sim.addr
        try:
            cls.capture()
        finally:
            cls.sim_rc = cls.sim.stop()
        cls.all_frames = cls.fields(
            "frame.number", "frame.protocols", "ip.src", "ip.dst", "tcp.len", "udp.srcport",
            "udp.dstport", "enip.command", "enip.session", "enip.status",
            "enip.response_to", "enip.fwd_open_in", "cip.sc", "cip.rr", "cip.class",
            "cip.instance", "cip.attribute", "cip.genstat", "cip.cm.ot_connid",
            "cip.cm.to_connid", "cip.cm.conn_serial_num", "cip.cm.fwo.consize",
            "cip.cm.otrpi", "cip.cm.otapi", "cip.cm.toapi", "cip.connid",
            "enip.cpf.sai.seq", "cip.seq", "cip.32bitheader.run_idle", "cipio.data",
            "_ws.malformed", "_ws.expert.severity", "tcp.analysis.flags",
            "tcp.analysis.retransmission")
        # A retransmitted TCP segment carries data already seen: the checks
        # of content look at each message once.
        cls.frames = [f for f in cls.all_frames if not f["tcp.analysis.retransmission"]]

    @classmethod
    def capture(cls):
        dumpcap = subprocess.Popen(["dumpcap", "-i", "lo", "-f", "host " + cls.addr,
                                    "-a", "duration:120", "-w", cls.pcap],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        try:
            # dumpcap says "Capturing on ..." once its filter is in place
            started = time.monotonic()
            line = ""
            while "Capturing on" not in line and time.monotonic() - started < 20:
                line = dumpcap.stderr.readline()
                if line == "" and dumpcap.poll() is not None:
                    break
            if "Capturing on" not in line:
                raise RuntimeError("dumpcap did not start: %s" % line)
            time.sleep(0.2)
            udp = peers.free_port(peers.LOCAL_ADDR)
            r = peers.run([SESSION, cls.addr, "44818", peers.LOCAL_ADDR, str(udp)], timeout=60)
            cls.session_out = r.stdout
            print(r.stdout, r.stderr, end="")
            if r.returncode != 0:
                raise RuntimeError("enip_session failed (%d): %s" % (r.returncode, r.stderr))
            time.sleep(0.3)  # the last replies and FINs
        finally:
            dumpcap.send_signal(subprocess.signal.SIGINT)
            try:
                cls.dumpcap_err = dumpcap.communicate(timeout=10)[1]
            except subprocess.TimeoutExpired:
                dumpcap.kill()
                cls.dumpcap_err = dumpcap.communicate()[1]
        # what the session says it sent
        cls.sent_requests = []
        cls.sent_conns = []
        cls.sent_output = {}
        for line in cls.session_out.splitlines():
            w = line.split()
            if w and w[0] == "request":
                cls.sent_requests.append((int(w[1], 16), int(w[2], 16), int(w[3], 16),
                                          None if w[4] == "-" else int(w[4], 16)))
            elif w and w[0] == "conn":
                cls.sent_conns.append({"o2t": int(w[2], 16), "t2o": int(w[3], 16),
                                       "large": w[4] == "1", "tx": int(w[5]), "rx": int(w[6])})
            elif w and w[0] == "output":
                cls.sent_output[int(w[1])] = w[2]

    @classmethod
    def fields(cls, *names):
        args = ["tshark", "-2", "-n", "-r", cls.pcap, "-T", "fields", "-E", "separator=\t",
                "-E", "occurrence=a", "-E", "aggregator=,"]
        for n in names:
            args += ["-e", n]
        r = peers.run(args, timeout=120)
        if r.returncode != 0:
            raise RuntimeError("tshark: %s" % r.stderr)
        rows = []
        for line in r.stdout.splitlines():
            vals = line.split("\t")
            vals += [""] * (len(names) - len(vals))
            rows.append({n: v for n, v in zip(names, vals)})
        return rows

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(getattr(cls, "tmp", "/nonexistent"), ignore_errors=True)
        if getattr(cls, "sim", None) is not None:
            cls.sim.cleanup()

    def first(self, row, name):
        v = row[name]
        return v.split(",")[0] if v else ""

    def from_client(self, row):
        return row["ip.src"] == peers.LOCAL_ADDR

    # ---- the capture itself ---------------------------------------------------

    def test_capture_is_complete(self):
        self.assertEqual(self.sim_rc, 0, "drsim exit status")
        self.assertIn("dumpcap:0", self.dumpcap_err.replace(" ", ""), self.dumpcap_err)
        self.assertGreater(len(self.frames), 50)
        cmds = [self.first(f, "enip.command") for f in self.frames if f["enip.command"]]
        self.assertEqual(cmds[0], "0x0065", "starts with RegisterSession")
        self.assertEqual(cmds[-1], "0x0066", "ends with UnRegisterSession")

    # ---- every frame recognised, nothing malformed -------------------------------

    def test_every_frame_recognised(self):
        for f in self.all_frames:
            protos = f["frame.protocols"].split(":")
            with self.subTest(frame=f["frame.number"], protocols=f["frame.protocols"]):
                self.assertNotIn("icmp", protos, "nobody listened where a datagram went")
                self.assertNotIn("data", protos, "payload no dissector claimed")
                if "udp" in protos:
                    self.assertIn("cipio", protos)
                elif f["tcp.len"] not in ("", "0") and not f["tcp.analysis.retransmission"]:
                    # a TCP retransmission (on a busy machine, a tail loss
                    # probe can fire even on loopback) is not dissected again
                    self.assertIn("enip", protos)

    def test_no_malformed_packets_or_expert_errors(self):
        bad = [f["frame.number"] for f in self.all_frames if f["_ws.malformed"]]
        self.assertEqual(bad, [], "malformed frames")
        # Expert entries by severity and protocol. Errors: none at all.
        # Warnings: none from ENIP/CIP; TCP's own (a spurious retransmission
        # and its D-SACK when the machine is busy) say nothing about us.
        r = peers.run(["tshark", "-2", "-n", "-r", self.pcap, "-q", "-z", "expert,note"], timeout=60)
        print(r.stdout)
        entries = {"Errors": [], "Warns": []}
        section = None
        for line in r.stdout.splitlines():
            w = line.split()
            if w and w[0] in ("Errors", "Warns", "Notes", "Chats", "Comments"):
                section = w[0]
            elif section in entries and len(w) >= 4 and w[0].isdigit():
                entries[section].append((w[2], " ".join(w[3:])))  # protocol, summary
        self.assertEqual(entries["Errors"], [], "expert errors")
        ours = [e for e in entries["Warns"] if e[0] != "TCP"]
        self.assertEqual(ours, [], "expert warnings from the EtherNet/IP dissectors")
        # and per frame, the same by severity (any protocol but TCP analysis)
        for f in self.all_frames:
            sev = [hexint(v) for v in f["_ws.expert.severity"].split(",") if v]
            if any(v >= ERROR for v in sev):
                self.fail("frame %s has an expert error" % f["frame.number"])
            if any(v >= WARN for v in sev) and not f["tcp.analysis.flags"]:
                self.fail("frame %s has an expert warning" % f["frame.number"])

    # ---- what was decoded is what we sent -----------------------------------------

    def test_encapsulation(self):
        reqs = [f for f in self.frames if f["enip.command"] and self.from_client(f)]
        reps = [f for f in self.frames if f["enip.command"] and not self.from_client(f)]
        handles = {f["enip.session"] for f in reps if f["enip.command"] == "0x0065"}
        self.assertEqual(len(handles), 1)
        handle = handles.pop()
        self.assertNotEqual(hexint(handle), 0)
        for f in reqs[1:]:
            if f["enip.command"] != "0x0063":  # ListIdentity carries no session
                self.assertEqual(f["enip.session"], handle, "frame %s" % f["frame.number"])
        for f in reps:
            self.assertEqual(hexint(f["enip.status"]), 0, "frame %s" % f["frame.number"])
        commands = collections.Counter(f["enip.command"] for f in reqs)
        self.assertEqual(commands["0x0065"], 1)
        self.assertEqual(commands["0x0063"], 1)
        self.assertEqual(commands["0x0066"], 1)
        # every reply was matched to its request by Wireshark
        for f in reps:
            if f["enip.command"] == "0x006f":
                self.assertTrue(f["enip.response_to"], "frame %s" % f["frame.number"])

    def test_cip_requests_are_what_we_sent(self):
        decoded = []
        for f in self.frames:
            if not f["cip.sc"] or not self.from_client(f):
                continue
            attr = self.first(f, "cip.attribute")
            decoded.append((hexint(self.first(f, "cip.sc")), hexint(self.first(f, "cip.class")),
                            hexint(self.first(f, "cip.instance")),
                            hexint(attr) if attr else None))
        self.assertEqual(collections.Counter(decoded), collections.Counter(self.sent_requests))
        # the explicit requests in the order sent
        explicit = [r for r in self.sent_requests if r[1] != 6]
        self.assertEqual([d for d in decoded if d[1] != 6], explicit)
        # every CIP reply says success
        for f in self.frames:
            if f["cip.genstat"] and not self.from_client(f):
                self.assertEqual(hexint(self.first(f, "cip.genstat")), 0, "frame %s" % f["frame.number"])

    def test_forward_open_parameters(self):
        opens = [f for f in self.frames if self.first(f, "cip.sc") in ("0x54", "0x5b")
                 and self.from_client(f)]
        self.assertEqual(len(opens), 2)
        # sizes incl. the sequence count (2) and the O->T run/idle header (4):
        # io_control 12 + 6, io_state 36 + 2; heartbeat 0 + 2, joint_state 144 + 2
        sizes = sorted(tuple(int(s) for s in f["cip.cm.fwo.consize"].split(",")) for f in opens)
        self.assertEqual(sizes, [(2, 146), (18, 38)])
        for f in opens:
            self.assertEqual(int(f["cip.cm.otrpi"]), 10000)
        replies = [f for f in self.frames if self.first(f, "cip.sc") in ("0x54", "0x5b")
                   and not self.from_client(f)]
        self.assertEqual(len(replies), 2)
        for f in replies:
            self.assertEqual((int(f["cip.cm.otapi"]), int(f["cip.cm.toapi"])), (10000, 10000))

    def test_connection_ids_are_what_we_sent(self):
        replies = [f for f in self.frames if self.first(f, "cip.sc") in ("0x54", "0x5b")
                   and not self.from_client(f)]
        decoded = sorted((hexint(f["cip.cm.ot_connid"]), hexint(f["cip.cm.to_connid"]))
                         for f in replies)
        self.assertEqual(decoded, sorted((c["o2t"], c["t2o"]) for c in self.sent_conns))
        o2t = {c["o2t"] for c in self.sent_conns}
        t2o = {c["t2o"] for c in self.sent_conns}
        seen = collections.Counter()
        for f in self.frames:
            if "cipio" not in f["frame.protocols"]:
                continue
            cid = hexint(f["cip.connid"])
            with self.subTest(frame=f["frame.number"]):
                self.assertIn(cid, o2t if self.from_client(f) else t2o)
                self.assertTrue(f["enip.fwd_open_in"], "linked to its Forward Open")
            seen[cid] += 1
        for c in self.sent_conns:
            self.assertGreaterEqual(seen[c["o2t"]], c["tx"])
            self.assertGreaterEqual(seen[c["t2o"]], c["rx"])
        # Forward Close names the serials of the opens
        serials = lambda sc, mine: sorted(self.first(f, "cip.cm.conn_serial_num") for f in self.frames
                                          if self.first(f, "cip.sc") in sc and self.from_client(f) == mine)
        self.assertEqual(serials(("0x54", "0x5b"), True), serials(("0x4e",), True))

    def test_io_sequence_and_data(self):
        per_cid = collections.defaultdict(list)
        for f in self.frames:
            if "cipio" in f["frame.protocols"]:
                per_cid[hexint(f["cip.connid"])].append(f)
        for cid, frames in per_cid.items():
            seqs = [int(f["enip.cpf.sai.seq"]) for f in frames]
            with self.subTest(cid="%08x" % cid):
                self.assertEqual(seqs, list(range(seqs[0], seqs[0] + len(seqs))),
                                 "one more every packet, no gap, no repeat")
        conn0 = self.sent_conns[0]
        for f in per_cid[conn0["o2t"]]:
            self.assertEqual(f["cipio.data"], self.sent_output[0])
            self.assertEqual(hexint(f["cip.32bitheader.run_idle"]), 1, "run")
        io_state = per_cid[conn0["t2o"]][-1]["cipio.data"]
        self.assertEqual(len(io_state), 2 * 36)
        self.assertEqual(io_state[4:8], "0180", "drsim applied cb_do 1, 16 (io_state over T->O)")
        joint = per_cid[self.sent_conns[1]["t2o"]][-1]["cipio.data"]
        self.assertEqual(len(joint), 2 * 144)


if __name__ == "__main__":
    unittest.main()
