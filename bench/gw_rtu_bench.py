#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""drgatewayd's Modbus RTU throughput (issue 13), run by `make bench-gw-rtu`.

drgatewayd with one robot (drsim) is a Modbus RTU slave at 115200 baud 8N1
on one end of a socat pty pair; a master written here, on the other end,
sends FC03 reads of 125 registers (float_in, HR 400) one after the other,
each as soon as the last reply is complete, for --duration seconds, and
counts them. The line's theoretical limit for the same frames is
1 / (time of the request's 8 bytes + the reply's 255 bytes at 10 bits a
byte + two t3.5 gaps of 1.75 ms): 37.9 requests a second.

A pty has no baud rate: bytes move as fast as the kernel copies them, so
what is measured is the gateway's side (framing, the request handler, the
reply) with the line's own time taken out; the ratio says whether the
gateway could keep a real 115200 baud line busy (goal >= 0.9x). On a real
UART the line itself is the limit.
"""
import argparse
import os
import select
import statistics
import struct
import sys
import time

TOP = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(TOP, "tests", "gateway"))
from gwlib import crc16  # noqa: E402 (after the path it is found on)

BAUD = 115200
BITS = 10  # start, 8 data, stop
T35 = 0.00175  # fixed above 19200 baud
REQ, REPLY = 8, 5 + 250


def line_limit():
    return 1.0 / ((REQ + REPLY) * BITS / BAUD + 2 * T35)


def run_master(path, seconds):
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
    try:
        req = bytes([1, 3]) + struct.pack(">HH", 400, 125)
        req += crc16(req)
        n, t0 = 0, time.monotonic()
        while time.monotonic() - t0 < seconds:
            os.write(fd, req)
            got = b""
            while len(got) < REPLY:
                if not select.select([fd], [], [], 5.0)[0]:
                    raise RuntimeError("no reply within 5 s")
                got += os.read(fd, 512)
            if got[:3] != bytes([1, 3, 250]) or crc16(got[:-2]) != got[-2:]:
                raise RuntimeError("bad reply %s" % got[:8].hex())
            n += 1
        return n / (time.monotonic() - t0)
    finally:
        os.close(fd)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=2.0)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    import gwlib
    from test_rtu import pty_pair
    sim = gwlib.Drsim("bench-rtu").start()
    try:
        with pty_pair("bench-rtu") as (dev, master):
            g = gwlib.Gateway("bench-rtu", sim,
                              extra="\n[modbus_rtu l]\ndevice = %s\nbaud = %d\nparity = none\n"
                              % (dev, BAUD))
            try:
                g.start()
                rates = [run_master(master, args.duration) for _ in range(args.rounds)]
            finally:
                g.kill()
    finally:
        sim.kill()
    rate, limit = statistics.median(rates), line_limit()
    ratio = rate / limit
    print("| measure | drgatewayd | baseline | ratio | goal | result |")
    print("| RTU FC03 125 regs req/s, 115200 8N1 over a pty: vs the line's limit | "
          "%.0f (%.0f-%.0f) | %.1f (theoretical) | %.0fx | >= 0.9x | %s |"
          % (rate, min(rates), max(rates), limit, ratio, "met" if ratio >= 0.9 else "MISSED"))
    return 0 if ratio >= 0.9 else 1


if __name__ == "__main__":
    sys.exit(main())
