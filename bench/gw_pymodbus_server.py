# SPDX-License-Identifier: MIT
"""The pymodbus baseline for drgatewayd's Modbus throughput (make bench).

A pymodbus 3.8 asyncio TCP server (StartAsyncTcpServer) with the gateway's
register counts: GW_AREA_SIZE (2048) coils, discrete inputs, holding and
input registers at PDU addresses 0..2047, one unit (single context, so it
answers every unit ID, as the plain libmodbus baseline does).

usage: gw_pymodbus_server.py PORT [ADDRESS]   (default 127.0.0.1)
Runs until SIGTERM/SIGINT.
"""
import asyncio
import logging
import signal
import sys

import pymodbus
from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)
from pymodbus.server import StartAsyncTcpServer

GW_AREA_SIZE = 2048  # gateway/modbus/regmap.h


def block(values):
    # ModbusSlaveContext adds 1 to every PDU address: start the blocks at 1
    # so that PDU addresses 0..2047 are valid, as in the gateway.
    return ModbusSequentialDataBlock(1, values)


async def main():
    port = int(sys.argv[1])
    addr = sys.argv[2] if len(sys.argv) > 2 else "127.0.0.1"
    logging.getLogger("pymodbus").setLevel(logging.ERROR)
    store = ModbusSlaveContext(
        di=block([0] * GW_AREA_SIZE),
        co=block([0] * GW_AREA_SIZE),
        hr=block([i for i in range(GW_AREA_SIZE)]),
        ir=block([0x8000 | i for i in range(GW_AREA_SIZE)]),
    )
    context = ModbusServerContext(slaves=store, single=True)
    loop = asyncio.get_running_loop()
    server = asyncio.ensure_future(
        StartAsyncTcpServer(context=context, address=(addr, port)))
    stop = asyncio.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    print(f"gw_pymodbus_server: pymodbus {pymodbus.__version__} on {addr}:{port}",
          flush=True)
    await stop.wait()
    server.cancel()


if __name__ == "__main__":
    asyncio.run(main())
