# SPDX-License-Identifier: MIT
"""Debian's mbpoll, a third independent client: 32-bit values in its two
word orders (-B: high word first = abcd; default: low word first = cdab),
writes that reach the robot, and exceptions as mbpoll reports them."""
import re
import shutil
import struct
import subprocess

import pytest

from gwlib import GW_ADDR, INSTANCE, EnipReader, running, timeout, wait_for

MBPOLL = shutil.which("mbpoll")
pytestmark = pytest.mark.skipif(MBPOLL is None, reason="mbpoll is not installed (make test-deps)")


@pytest.fixture(scope="module", params=["abcd", "cdab"])
def gw(request):
    order = request.param
    with running("mbpoll-%s" % order, modbus="word_order = %s\n" % order) as g:
        g.order = order
        g.enip = EnipReader("127.0.0.2", g.sim.tcp)
        yield g
        g.enip.close()


def mbpoll(g, kind, ref, *values, count=1):
    """mbpoll in PDU addressing (-0), once (-1); word order from the gateway's."""
    args = [MBPOLL, "-m", "tcp", "-p", str(g.port), "-a", "1", "-t", kind, "-0",
            "-r", str(ref), "-o", "5"]
    if g.order == "abcd" and (kind.endswith(":float") or kind.endswith(":int")):
        args.append("-B")
    if values:
        args += [GW_ADDR, "--"] + [str(v) for v in values]
    else:
        args += ["-c", str(count), "-1", GW_ADDR]
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout(30),
                          stdin=subprocess.DEVNULL)


def values(out):
    return [v for _, v in re.findall(r"^\[(\d+)\]:\s+(\S+)", out, re.M)]


def test_read_test_registers(gw):
    r = mbpoll(gw, "3:hex", 32)
    assert r.returncode == 0, r.stderr
    assert values(r.stdout) == ["0x1234"]
    r = mbpoll(gw, "3:float", 35, count=2)
    assert r.returncode == 0, r.stderr
    assert values(r.stdout) == ["123456", "-1.5"]
    r = mbpoll(gw, "3:int", 33)
    assert r.returncode == 0, r.stderr
    assert values(r.stdout) == [str(0x12345678)]


def test_write_float_and_int(gw, regmap):
    r = mbpoll(gw, "4:float", regmap.addr("HR", "float_in[2]"), 2.5, -0.125)
    assert r.returncode == 0 and "Written 2 references" in r.stdout, r.stdout + r.stderr
    wait_for(lambda: struct.unpack_from("<2f", gw.enip.get(INSTANCE["float_in"]), 8) ==
             (2.5, -0.125), 10, "float_in[2..3] at the robot")
    r = mbpoll(gw, "4:int", regmap.addr("HR", "int_in[1]"), -123456)
    assert r.returncode == 0, r.stderr
    wait_for(lambda: struct.unpack_from("<i", gw.enip.get(INSTANCE["int_in"]), 4)[0] ==
             -123456, 10, "int_in[1] at the robot")
    wait_for(lambda: values(mbpoll(gw, "3:int", regmap.addr("IR", "int_out[1]")).stdout) ==
             ["-123456"], 10, "int_out[1] through mbpoll")
    r = mbpoll(gw, "3:float", regmap.addr("IR", "float_out[2]"), count=2)
    assert values(r.stdout) == ["2.5", "-0.125"]


def test_coils_and_inputs(gw, regmap):
    r = mbpoll(gw, "0", regmap.addr("CO", "bit_in[10]"), 1, 0, 1)
    assert r.returncode == 0, r.stderr
    wait_for(lambda: values(mbpoll(gw, "1", regmap.addr("DI", "bit_out[10]"), count=3).stdout)
             == ["1", "0", "1"], 10, "bit_out[10..12] through mbpoll")


def test_exception_reported(gw):
    r = mbpoll(gw, "3", 1624)  # past the last input register
    assert r.returncode != 0
    assert "Illegal data address" in r.stderr
    r = mbpoll(gw, "3", 50)  # a reserved register between blocks reads 0
    assert r.returncode == 0 and values(r.stdout) == ["0"], (r.stdout, r.stderr)
    r = mbpoll(gw, "4", 2, 7)
    assert r.returncode != 0 and "Illegal data address" in r.stderr
