# SPDX-License-Identifier: MIT
"""Helpers of the OPC UA tests: drsim and drgatewayd with [opcua] (gwlib's
processes), and python asyncua (the independent client, pinned in
tests/requirements.txt) driven synchronously."""
import asyncio
import contextlib
import json
import struct
import subprocess

from asyncua import Client, ua

import gwlib
from gwlib import DRCLI, GW_ADDR, SIM_ADDR, Drsim, Gateway, free_port, timeout

NS_URI = "urn:drgate:robots"
T2O = ("io_state", "joint_state", "task_state", "bit_out", "int_out", "float_out")
O2T = ("io_control", "bit_in", "int_in", "float_in")


def run(coro, seconds=60):
    """The coroutine to its end in a loop of its own, bounded."""
    return asyncio.run(asyncio.wait_for(coro, timeout(seconds)))


def opcua_section(port, extra="", listen=GW_ADDR):
    return "\n[opcua]\nlisten = %s\nport = %d\n%s\n" % (listen, port, extra)


@contextlib.contextmanager
def gateway(name, sim_args=("--still",), opcua="writes = yes", sim_start=True, listen=GW_ADDR,
            **gw_kw):
    """drsim NAME and a gateway in front of it with [opcua] (opcua: its
    extra keys) on a free port of `listen`; g.ua_port, g.url; both killed
    on the way out. sim_start False: drsim's ports are taken but it is not
    started (a robot that never answers)."""
    sim = Drsim(name, *sim_args)
    if sim_start:
        sim.start()
    else:
        sim.tcp = free_port(SIM_ADDR)
        sim.udp = free_port(SIM_ADDR, tcp=False)
    port = free_port(listen, udp=False)
    extra = gw_kw.pop("extra", "") + opcua_section(port, opcua, listen)
    g = Gateway(name, sim, extra=extra, **gw_kw)
    g.sim, g.ua_port = sim, port
    g.url = "opc.tcp://%s:%d" % (listen, port)
    try:
        g.start(wait_link=sim_start)
        g.log_wait("opcua: listening on", 20)
        yield g
    finally:
        g.kill()
        sim.kill()


@contextlib.asynccontextmanager
async def client(url, **kw):
    c = Client(url, timeout=timeout(10))
    for k, v in kw.items():
        if k == "user":
            c.set_user(v)
        elif k == "password":
            c.set_password(v)
        elif k == "security":
            await c.set_security_string(v)
    await c.connect()
    try:
        yield c
    finally:
        await c.disconnect()


async def ns_of(c):
    return await c.get_namespace_index(NS_URI)


async def node(c, robot, path):
    return c.get_node(ua.NodeId("%s/%s" % (robot, path), await ns_of(c)))


async def read(c, robot, path):
    """The DataValue, whatever its status."""
    n = await node(c, robot, path)
    return await n.read_data_value(raise_on_bad_status=False)


def drcli_get(sim, *paths):
    """drcli get --json from the robot itself: {path: value}."""
    out = subprocess.run([str(DRCLI), "-H", SIM_ADDR, "--port", str(sim.tcp), "get", "--json"]
                         + list(paths), capture_output=True, text=True, timeout=timeout(30),
                         check=True).stdout
    return json.loads(out)


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]



wait_for = gwlib.wait_for
NS_DI = "http://opcfoundation.org/UA/DI/"
NS_ROBOTICS = "http://opcfoundation.org/UA/Robotics/"
