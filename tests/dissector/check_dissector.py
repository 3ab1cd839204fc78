#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""check-dissector: dissector/drgate.lua against a real capture.

1. dissector/drgate.lua is what mk/gen-dissector.py writes from the field
   table now (not stale);
2. dumpcap captures, on the loopback, drsim (a real EtherNet/IP adapter, on
   an address of its own in 127/8, standard ports so that Wireshark's ENIP
   dissector knows it) and drgatewayd with its six Class 1 connections;
   mbpoll writes int_in[0] through the gateway, drcli reads fields with
   Get_Attribute_Single;
3. tshark with the dissector shows: all ten assemblies in Class 1 frames;
   in the Get replies, the values drcli printed for the same fields; the
   value mbpoll wrote in int_in[0] (O->T) and its echo in int_out[0]
   (T->O); nothing marked malformed;
4. the same capture cut down to one Forward Open and one joint_state frame
   whose payload is shortened to 20 bytes: the frame is marked malformed
   (expert group Malformed, "truncated") and no field of it is decoded.
usage: check_dissector.py BUILD_DIR [RESULTS]
"""
import os
import re
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import time

TOP = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LUA = os.path.join(TOP, "dissector", "drgate.lua")
LABEL = "Wireshark dissector on a capture (tests/dissector/check_dissector.py)"
MALFORMED = 0x07000000  # PI_MALFORMED

passed = failed = 0


def ok(what):
    global passed
    passed += 1
    print("  ok: " + what)


def bad(what):
    global failed
    failed += 1
    print("  FAIL: " + what)


def check(cond, what):
    (ok if cond else bad)(what)
    return cond


def free_port(addr, kind=socket.SOCK_STREAM):
    s = socket.socket(socket.AF_INET, kind)
    s.bind((addr, 0))
    port = s.getsockname()[1]
    s.close()
    return port


def wait_for(path, text, proc, seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            if text in open(path).read():
                return True
        except OSError:
            pass
        if proc.poll() is not None:
            return False
        time.sleep(0.1)
    return False


def tshark(pcap, *fields, filt="drgate"):
    args = ["tshark", "-n", "-2", "-X", "lua_script:" + LUA, "-r", pcap, "-Y", filt,
            "-T", "fields", "-E", "separator=\t", "-E", "occurrence=a", "-E", "aggregator=,"]
    for f in fields:
        args += ["-e", f]
    r = subprocess.run(args, capture_output=True, text=True, timeout=120)
    if r.returncode != 0 or "Lua: Error" in r.stderr:
        raise RuntimeError("tshark: " + r.stderr)
    return [dict(zip(fields, line.split("\t"))) for line in r.stdout.splitlines()]


def abbrev(path, asm):
    p = path if path.startswith(asm + ".") else asm + "." + path
    return "drgate." + re.sub(r"[^A-Za-z0-9_.]", "_", p.replace("]", ""))


def capture(b, tmp):
    """drsim + drgatewayd + mbpoll + drcli under dumpcap; returns the pcap,
    what drcli printed and the value mbpoll wrote."""
    n = os.getpid() % 60000
    addr = "127.78.%d.%d" % (n // 250 % 250 + 1, n % 250 + 1)
    pcap = os.path.join(tmp, "gw.pcapng")
    procs = []
    dump = subprocess.Popen(["dumpcap", "-i", "lo", "-f", "host " + addr, "-a", "duration:90",
                             "-w", pcap], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    try:
        line, end = "", time.monotonic() + 20
        while "Capturing on" not in line and time.monotonic() < end and dump.poll() is None:
            line = dump.stderr.readline()
        if "Capturing on" not in line:
            raise RuntimeError("dumpcap did not start: " + line)
        sim_log = os.path.join(tmp, "drsim.log")
        with open(sim_log, "w") as f:
            procs.append(subprocess.Popen([os.path.join(b, "drsim"), "--address", addr],
                                          stdout=f, stderr=subprocess.STDOUT))
        time.sleep(0.3)
        mport = free_port("127.0.0.1")
        uport = free_port("127.0.0.1", socket.SOCK_DGRAM)
        ini = os.path.join(tmp, "gw.ini")
        with open(ini, "w") as f:
            f.write("[modbus]\nlisten = 127.0.0.1\nport = %d\n\n[robot r1]\nhost = %s\n"
                    "local_address = 127.0.0.1\nlocal_udp_port = %d\nrpi_ms = 50\n"
                    % (mport, addr, uport))
        gw_log = os.path.join(tmp, "gw.log")
        with open(gw_log, "w") as f:
            gw = subprocess.Popen([os.path.join(b, "drgatewayd"), "-c", ini], stdout=f,
                                  stderr=subprocess.STDOUT)
            procs.append(gw)
        if not wait_for(gw_log, "link up", gw, 30):
            raise RuntimeError("the gateway did not connect: " + open(gw_log).read())
        time.sleep(3)  # drsim reaches OPERATING and its joints start moving
        pmap = subprocess.run([os.path.join(b, "drgatewayd"), "--print-map"],
                              capture_output=True, text=True, check=True).stdout
        hr = next(int(w[1].split("-")[0]) for w in (l.split() for l in pmap.splitlines())
                  if len(w) > 3 and w[3] == "int_in[0]")
        value = 4242
        r = subprocess.run(["mbpoll", "-m", "tcp", "-p", str(mport), "-0", "-1", "-t", "4:int",
                            "-B", "-r", str(hr), "127.0.0.1", str(value)],
                           capture_output=True, text=True, timeout=30)
        if "Written" not in r.stdout:
            raise RuntimeError("mbpoll: " + r.stdout + r.stderr)
        time.sleep(1.0)  # the robot echoes int_in to int_out
        names = ["joint_state.position[1]", "joint_state.position[3]",
                 "io_state.version.major", "int_out[0]"]
        r = subprocess.run([os.path.join(b, "drcli"), "-H", addr, "get"] + names,
                           capture_output=True, text=True, timeout=30)
        if r.returncode != 0:
            raise RuntimeError("drcli get: " + r.stderr)
        got = {}
        for line in r.stdout.splitlines():
            m = re.match(r"(\S+) = (\S+)", line)
            if m:
                got[m.group(1)] = m.group(2)
        time.sleep(0.3)
        return pcap, got, value
    finally:
        for p in reversed(procs):
            p.terminate()
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        time.sleep(0.3)
        dump.send_signal(subprocess.signal.SIGINT)
        try:
            dump.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            dump.kill()
            dump.communicate()


def ip_checksum(hdr):
    s = sum(struct.unpack("!%dH" % (len(hdr) // 2), hdr))
    while s >> 16:
        s = (s & 0xFFFF) + (s >> 16)
    return ~s & 0xFFFF


def shorten(frame, keep):
    """An Ethernet/IPv4/UDP ENIP Class 1 frame with its connected data item
    cut to `keep` bytes of payload (after the 2-byte sequence count)."""
    ihl = (frame[14] & 0x0F) * 4
    udp = 14 + ihl
    cpf = udp + 8
    count = struct.unpack_from("<H", frame, cpf)[0]
    off = cpf + 2
    for _ in range(count):
        typ, ln = struct.unpack_from("<HH", frame, off)
        if typ == 0x00B1:
            newlen = 2 + keep
            out = bytearray(frame[:off + 4 + newlen])
            struct.pack_into("<H", out, off + 2, newlen)
            struct.pack_into("!H", out, udp + 4, len(out) - udp)
            struct.pack_into("!H", out, udp + 6, 0)
            struct.pack_into("!H", out, 14 + 2, len(out) - 14)
            struct.pack_into("!H", out, 14 + 10, 0)
            struct.pack_into("!H", out, 14 + 10, ip_checksum(bytes(out[14:14 + ihl])))
            return bytes(out)
        off += 4 + ln
    raise RuntimeError("no connected data item")


def truncated_capture(pcap, tmp, fo, frame_no):
    """The Forward Open request and reply and frame_no, the last shortened,
    in a classic pcap."""
    small = os.path.join(tmp, "three.pcap")
    subprocess.run(["tshark", "-n", "-r", pcap, "-Y", "frame.number == %d || enip.response_to "
                    "== %d || frame.number == %d" % (fo, fo, frame_no), "-F", "pcap", "-w", small],
                   check=True, capture_output=True, timeout=60)
    data = open(small, "rb").read()
    hdr, pos, recs = data[:24], 24, []
    while pos < len(data):
        ts1, ts2, incl, orig = struct.unpack_from("<IIII", data, pos)
        recs.append([ts1, ts2, data[pos + 16:pos + 16 + incl]])
        pos += 16 + incl
    recs[-1][2] = shorten(recs[-1][2], 20)
    out = os.path.join(tmp, "truncated.pcap")
    with open(out, "wb") as f:
        f.write(hdr)
        for ts1, ts2, fr in recs:
            f.write(struct.pack("<IIII", ts1, ts2, len(fr), len(fr)) + fr)
    return out


def main():
    b = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build")
    res = sys.argv[2] if len(sys.argv) > 2 else ""
    missing = [t for t in ("tshark", "dumpcap", "mbpoll") if shutil.which(t) is None]
    if missing:
        return subprocess.call(["sh", os.path.join(TOP, "tests", "skip.sh"), "check-dissector",
                                "%s missing (make test-deps)" % " ".join(missing), res, LABEL])
    drcli = os.path.join(b, "drcli")
    r = subprocess.run([sys.executable, os.path.join(TOP, "mk", "gen-dissector.py"), "--check",
                        drcli, LUA], capture_output=True, text=True)
    check(r.returncode == 0, "dissector/drgate.lua is generated from the field table "
          "(make dissector)" + ("" if r.returncode == 0 else ": " + r.stdout.strip()))
    tmp = tempfile.mkdtemp(prefix="drgate-dissector-")
    try:
        pcap, got, value = capture(b, tmp)
        names = ["joint_state.position[1]", "joint_state.position[3]", "io_state.version.major",
                 "int_out[0]"]
        fields = ["frame.number", "drgate.assembly", "udp.srcport", "tcp.srcport",
                  "enip.fwd_open_in", "_ws.expert.group"]
        fields += [abbrev(n, n.split(".")[0].split("[")[0]) for n in names]
        fields += ["drgate.int_in.int_in_0"]
        rows = tshark(pcap, *fields)
        io = [r for r in rows if r["udp.srcport"]]
        asms = sorted({r["drgate.assembly"] for r in io})
        check(len(asms) == 10, "Class 1 frames of all ten assemblies decoded: %s" % ", ".join(asms))
        check(not any(str(MALFORMED) in r["_ws.expert.group"] or "0x07000000" in r["_ws.expert.group"]
                      for r in rows), "nothing marked malformed in the gateway's capture")
        gets = [r for r in rows if r["tcp.srcport"] == "44818"]
        # the robot state by its name from the field table (drcli list
        # --json's "enum"), not a bare number (issue 30)
        v = subprocess.run(["tshark", "-n", "-r", pcap, "-X", "lua_script:" + LUA, "-V",
                            "-Y", "drgate.io_state.robot_state"], capture_output=True,
                           text=True, timeout=120).stdout
        check(re.search(r"io_state\.robot_state: OPERATING \(2\)", v) is not None,
              "io_state.robot_state shown by its name (OPERATING (2))")
        for n in names:
            col = abbrev(n, n.split(".")[0].split("[")[0])
            seen = [r[col] for r in gets if r[col]]
            want = got.get(n)
            if not seen or want is None:
                bad("%s: no Get reply decoded (drcli printed %s)" % (n, want))
                continue
            if "." in want or "e" in want:
                good = abs(float(seen[-1]) - float(want)) <= 1e-5 * max(1.0, abs(float(want)))
            else:
                good = int(seen[-1]) == int(want)
            check(good, "%s: the dissector's Get reply %s, drcli get %s" % (n, seen[-1], want))
        o2t = {r["drgate.int_in.int_in_0"] for r in io if r["drgate.assembly"] == "int_in"}
        check(str(value) in o2t, "int_in[0] = %d (written with mbpoll) in the O->T Class 1 "
              "frames: %s" % (value, sorted(o2t)))
        t2o = {r["drgate.int_out.int_out_0"] for r in io if r["drgate.assembly"] == "int_out"}
        check(str(value) in t2o, "int_out[0] = %d (the robot's echo) in the T->O Class 1 frames"
              % value)
        js = [r for r in io if r["drgate.assembly"] == "joint_state"]
        if check(bool(js), "a joint_state Class 1 frame to cut"):
            fr = js[-1]
            tp = truncated_capture(pcap, tmp, int(fr["enip.fwd_open_in"]), int(fr["frame.number"]))
            rows = tshark(tp, "frame.number", "drgate.assembly", "_ws.expert.group",
                          "_ws.expert.message", "drgate.joint_state.position_1",
                          filt="drgate.assembly == \"joint_state\"")
            check(len(rows) == 1, "the shortened joint_state frame is dissected (%d)" % len(rows))
            for r in rows:
                grp = r["_ws.expert.group"].split(",")
                check(any(g in (str(MALFORMED), "0x07000000") for g in grp) and
                      "truncated" in r["_ws.expert.message"],
                      "a 20-byte joint_state payload is marked malformed: %s"
                      % r["_ws.expert.message"])
                check(r["drgate.joint_state.position_1"] == "",
                      "and none of its fields is decoded")
    except Exception as e:  # a peer that did not start, a tshark error
        bad("%s: %s" % (type(e).__name__, e))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("%s: %d passed, %d failed" % (LABEL, passed, failed))
    if res:
        with open(res, "a") as f:
            f.write("%d %d %s\n" % (passed, failed, LABEL))
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
