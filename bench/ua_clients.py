# SPDX-License-Identifier: MIT
"""OPC UA clients for bench/opcua_bench.py, in a process of their own (so
that their Python work is not the bench's): N python asyncua clients (the
independent client the tests use, pinned in tests/requirements.txt), each
with one subscription to PATH... of robot r0 in the flat view, sampling
and publishing every MS milliseconds.

Prints "ready" once every subscription is made; then, with --print, one
line per notification: "MONOTONIC REALTIME SOURCE_TIMESTAMP VALUE PATH"
(the first two when the callback ran, seconds; the third the value's
source timestamp, seconds since the epoch). On SIGUSR1: "count N" (the
notifications received so far); on SIGTERM the same, and it exits.

usage: ua_clients.py URL N MS PATH... [--print]
"""
import asyncio
import signal
import sys
import time

from asyncua import Client, ua

NS_URI = "urn:drgate:robots"


class Handler:
    def __init__(self, show):
        self.show = show
        self.count = 0

    def datachange_notification(self, node, val, data):
        self.count += 1
        if self.show:
            dv = data.monitored_item.Value
            src = dv.SourceTimestamp.timestamp() if dv.SourceTimestamp else 0.0
            print("%.6f %.6f %.6f %s %s" % (time.monotonic(), time.time(), src, val,
                                            node.nodeid.Identifier), flush=True)


async def main(url, n, ms, paths, show):
    stop = asyncio.Event()
    handler = Handler(show)
    loop = asyncio.get_running_loop()
    loop.add_signal_handler(signal.SIGTERM, stop.set)
    loop.add_signal_handler(signal.SIGUSR1, lambda: print("count %d" % handler.count, flush=True))
    clients = []
    try:
        for _ in range(n):
            c = Client(url, timeout=30)
            await c.connect()
            clients.append(c)
            ns = await c.get_namespace_index(NS_URI)
            nodes = [c.get_node(ua.NodeId("r0/" + p, ns)) for p in paths]
            sub = await c.create_subscription(ms, handler)
            await sub.subscribe_data_change(nodes, sampling_interval=ms)
        print("ready", flush=True)
        await stop.wait()
        print("count %d" % handler.count, flush=True)
    finally:
        for c in clients:
            try:
                await asyncio.wait_for(c.disconnect(), 5)
            except Exception:  # the bench is ending anyway
                pass


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--print"]
    if len(args) < 4:
        sys.exit(__doc__.strip().splitlines()[-1])
    import logging
    logging.disable(logging.WARNING)  # asyncua's notes on revised parameters
    asyncio.run(main(args[0], int(args[1]), float(args[2]), args[3:], "--print" in sys.argv))
