# SPDX-License-Identifier: MIT
"""A Class 1 scanner built on python-ethernetip (the `ethernetip` package),
run against drsim by test_ethernetip.py, either on this host (free ports,
announced through the Forward Open's 0x8001 item) or inside a network
namespace (the standard ports 44818 / 2222). Prints one JSON object.

usage: ethernetip_scanner.py HOST TCP_PORT UDP_PORT SCANNER_UDP_PORT RPI_MS [LAYOUT]
       SCANNER_UDP_PORT 0: any free port, announced in the 0x8001 item.
       LAYOUT: per_assembly (default), combined or gpr_only (drsim --layout).

Three connections, each with its own session, as python-ethernetip does it:
  A  O->T io_control (107, 12 bytes)  T->O io_state (101, 36 bytes)
  B  O->T bit_in (108, 8 bytes)       T->O bit_out (104, 8 bytes)
  C  O->T heartbeat 198 (no data)     T->O joint_state (102, 144 bytes)
With LAYOUT combined or gpr_only, one connection between drsim's two
points (issue 31):
  A  O->T 150 (212 bytes: io_control, bit_in, int_in, float_in; gpr_only
     200: bit_in, int_in, float_in)  T->O 100 (476 bytes: io_state,
     joint_state, task_state, bit_out, int_out, float_out; gpr_only 200:
     bit_out, int_out, float_out)
Everything has a deadline; a failure is reported in the JSON, not hung on.
"""
import json
import struct
import sys
import time

import ethernetip
import ethernetip.ethernetip as E

IN, OUT = ethernetip.EtherNetIP.ENIP_IO_TYPE_INPUT, ethernetip.EtherNetIP.ENIP_IO_TYPE_OUTPUT


def to_bytes(bits):
    out = bytearray(len(bits) // 8)
    for i, b in enumerate(bits):
        if b:
            out[i // 8] |= 1 << (i % 8)
    return bytes(out)


def set_bytes(bits, data):
    for i in range(len(data) * 8):
        bits[i] = bool(data[i // 8] >> (i % 8) & 1)


def connect(enip, host, timeout=10.0):
    """A new session object; retries while drsim is still starting (in a
    namespace, nobody else can wait for it to listen)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            return enip.explicit_conn(host)
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def run_point(res, conns, ins, outs, closed, plan, layout, ctl, bits):
    """The one connection of a combined or gpr_only layout: O->T with
    io_control (combined) and bit_in in their places of the output image,
    T->O read back at their places of the input image, twice 0.3 s apart,
    and both images read explicitly."""
    c = conns["A"]
    combined = layout == "combined"
    out_img = (ctl + bits if combined else bits).ljust(plan["A"][3], b"\0")
    set_bytes(outs["A"], out_img)
    res["out_sent"] = out_img.hex()
    res["bit_in_sent"] = bits.hex()
    c.produce()
    bit_out = 36 + 144 + 96 if combined else 0  # bit_out's place in the input
    deadline = time.monotonic() + 8.0
    while time.monotonic() < deadline:
        img = to_bytes(ins["A"])
        if img[bit_out:bit_out + 8] == bits and (not combined or img[2:4] == b"\x01\x80"):
            break
        time.sleep(0.05)
    r1 = to_bytes(ins["A"])
    time.sleep(0.3)
    r2 = to_bytes(ins["A"])
    res["in_rx"] = [r1.hex(), r2.hex()]
    res["bit_out_offset"] = bit_out
    for key, inst in (("out_get", 150), ("in_get", 100)):
        r = c.getAttrSingle(4, inst, 3)
        res[key] = None if r is None else [r[0], bytes(r[1]).hex()]
    c.stopProduce()
    time.sleep(0.05)
    res["fc_A"] = c.sendFwdCloseReq(plan["A"][0], plan["A"][2], 1)
    closed.add("A")
    res["ok"] = True
    return res


def main():
    host, tcp_port, udp_port, scan_port, rpi = sys.argv[1], *map(int, sys.argv[2:6])
    layout = sys.argv[6] if len(sys.argv) > 6 else "per_assembly"
    # python-ethernetip connects to ENIP_TCP_PORT and sends O->T to
    # ENIP_UDP_PORT, module constants; it ignores the 0x8000 item of the
    # Forward Open reply. Point them at drsim's ports (a no-op in the
    # namespace, where they are the standard ones).
    E.ENIP_TCP_PORT = tcp_port
    E.ENIP_UDP_PORT = udp_port
    E.config.DEFAULT_TIMEOUT = 5
    E.config.IO_SOCKET_SELECT_TIMEOUT = 0.2
    E.config.UDP_IO_MIN_RPI = 1
    res = {"ok": False}
    enip = ethernetip.EtherNetIP(host)
    enip.startIO(udp_port=scan_port)
    res["scanner_udp_port"] = enip.originator_udp_port
    announce = enip.originator_udp_port if scan_port == 0 else None
    plan = {
        "A": (101, 36, 107, 12),
        "B": (104, 8, 108, 8),
        "C": (102, 144, 198, 0),
    }
    if layout != "per_assembly":
        plan = {"A": (100, 476, 150, 212) if layout == "combined" else (100, 200, 150, 200)}
    conns, ins, outs, closed = {}, {}, {}, set()
    try:
        for key, (t2o, t2o_size, o2t, o2t_size) in plan.items():
            c = connect(enip, host)
            c.sock.settimeout(5)
            conns[key] = c
            # Each session object counts connection serials from 1, and the
            # originator vendor/serial are constants: a second connection
            # would repeat the triad, which drsim rightly refuses (0x0100).
            c.conn_serial_num = 0x100 * (len(conns) + 1)
            if c.registerSession() != 0:
                closed.add(key)
                res["error"] = "RegisterSession failed for %s" % key
                return res
            ins[key] = enip.registerAssembly(IN, t2o_size, t2o, c)
            outs[key] = enip.registerAssembly(OUT, o2t_size, o2t, c)
            # timeout x32 (multiplier code 3): a Python producer thread on a
            # busy machine must not time the connection out
            st = c.sendFwdOpenReq(t2o, o2t, 1, torpi=rpi, otrpi=rpi, multiplier=3,
                                  originator_udp_port=announce)
            res["fo_" + key] = st
            if st != 0:
                closed.add(key)
                res["error"] = "Forward Open %s: status %r" % (key, st)
                return res
            res["cid_" + key] = [c.otconnid, c.toconnid]
        ctl = struct.pack("<I2f", 0x8001 | 0x04 << 16, 0.0, 0.0)  # cb_do 1, 16; tool_do 3
        bits = bytes([0x5A, 0x01, 0x80, 0xFF, 0x00, 0x3C, 0xC3, 0x81])
        if layout != "per_assembly":
            return run_point(res, conns, ins, outs, closed, plan, layout, ctl, bits)
        set_bytes(outs["A"], ctl)
        set_bytes(outs["B"], bits)
        res["io_control_sent"] = ctl.hex()
        res["bit_in_sent"] = bits.hex()
        for c in conns.values():
            c.produce()
        # T->O, as python-ethernetip received it: wait (bounded) for drsim
        # to have applied our O->T data and sent it back.
        deadline = time.monotonic() + 8.0
        while time.monotonic() < deadline:
            io, bo = to_bytes(ins["A"]), to_bytes(ins["B"])
            if io[2:4] == b"\x01\x80" and bo == bits:
                break
            time.sleep(0.05)
        res["io_state_rx"] = to_bytes(ins["A"]).hex()
        res["bit_out_rx"] = to_bytes(ins["B"]).hex()
        j1 = to_bytes(ins["C"])
        time.sleep(0.3)
        j2 = to_bytes(ins["C"])
        res["joint_state_rx"] = [j1.hex(), j2.hex()]
        # What drsim holds, read explicitly over another request.
        for key, inst in (("io_control_get", 107), ("io_state_get", 101), ("bit_out_get", 104)):
            r = conns["A"].getAttrSingle(4, inst, 3)
            res[key] = None if r is None else [r[0], bytes(r[1]).hex()]
        for c in conns.values():
            c.stopProduce()
        time.sleep(0.05)
        for key, (t2o, _, o2t, _) in plan.items():
            res["fc_" + key] = conns[key].sendFwdCloseReq(t2o, o2t, 1)
            closed.add(key)
        res["ok"] = True
        return res
    finally:
        # Every exit path closes what it opened, so that a failed run does
        # not leave drsim holding the connections (it would refuse the next
        # open of the same O->T instance: 0x0106 ownership conflict).
        for key, c in conns.items():
            try:
                c.stopProduce()
                if key not in closed:
                    t2o, _, o2t, _ = plan[key]
                    c.sendFwdCloseReq(t2o, o2t, 1)
                c.unregisterSession()
            except OSError:
                pass
        enip.stopIO()


if __name__ == "__main__":
    out = main()
    print(json.dumps(out))
    sys.stdout.flush()
    # the I/O threads are daemons of nobody: leave without waiting for them
    import os
    os._exit(0 if out.get("ok") else 1)
