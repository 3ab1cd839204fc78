# SPDX-License-Identifier: MIT
"""Wrong passwords for bench/opcua_bench.py's (d), in a process of its own:
N python asyncua clients (the independent client the tests use, pinned in
tests/requirements.txt), each connecting over Basic256Sha256
SignAndEncrypt with DIR/client.pem and DIR/client-key.pem as USER with a
new wrong password, again and again, as fast as the server answers.
Prints "tries N" (refused logins) on SIGTERM and exits.

usage: ua_flood.py URL N DIR USER
"""
import asyncio
import signal
import sys

from asyncua import Client


async def attacker(url, sec, user, k, tries, stop):
    i = 0
    while not stop.is_set():
        c = Client(url, timeout=10)
        await c.set_security_string(sec)
        c.set_user(user)
        c.set_password("guess-%d-%d" % (k, i))
        i += 1
        try:
            await c.connect()
            await c.disconnect()
        except Exception:  # noqa: BLE001: a refusal, whatever its form
            tries[0] += 1


async def main():
    url, n, d, user = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
    sec = "Basic256Sha256,SignAndEncrypt,%s/client.pem,%s/client-key.pem" % (d, d)
    stop, tries = asyncio.Event(), [0]
    asyncio.get_running_loop().add_signal_handler(signal.SIGTERM, stop.set)
    print("ready", flush=True)
    tasks = [asyncio.create_task(attacker(url, sec, user, k, tries, stop)) for k in range(n)]
    await stop.wait()
    for t in tasks:
        t.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)
    print("tries %d" % tries[0], flush=True)


if __name__ == "__main__":
    import logging
    logging.disable(logging.WARNING)  # asyncua's line per refusal
    asyncio.run(main())
