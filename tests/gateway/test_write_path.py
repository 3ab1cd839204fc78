# SPDX-License-Identifier: MIT
"""One write path for every side (issue 30, item 4; docs/gateway.md "The
write path"): ONE table of writes, run through Modbus TCP (FC 16, a raw
client), MQTT JSON (paho, the set topics) and Sparkplug B DCMD
(pysparkplug), each against its own gateway with the same robot: every
side must take the same writes and refuse the same ones, and a refused
write must change nothing in the image (read back over Modbus, holding
registers are the O->T image).

The robot's plan opens float_out input-only (`open.float_out =
input_only`): no O->T connection carries float_in, so a write to it is
refused by every side (Modbus answered 0x02 before; MQTT and Sparkplug
wrote it into the image). A DCMD whose first metric is good and whose
second is bad (a NaN, or a payload cut inside its second metric) writes
nothing (it wrote the first before)."""
import math
import struct
import time

import pytest

from gwlib import EX_ILLEGAL_ADDRESS, EX_ILLEGAL_VALUE, GW_ADDR, ModbusError, RegMap, running, \
    timeout, wait_for

pytest.importorskip("paho.mqtt.client")

from mqttlib import PREFIX, Plant, broker_running, mqtt_section, started_after  # noqa: E402

PLAN = "open.float_out = input_only\n"
NAN = float("nan")
OK, REFUSED = "ok", "refused"

# (name, the writes (field, value) in one request, expected, Modbus's
# exception when refused). A row of several fields is one request: one
# FC 16 over their registers, one DCMD with a metric each; MQTT JSON
# names one field per message and runs the one-field rows only.
CASES = [
    ("a DINT", [("int_in[3]", 7)], OK, None),
    ("two REALs in one request", [("io_control.ao[0]", 1.5), ("io_control.ao[1]", -2.25)],
     OK, None),
    ("an assembly the plan does not send", [("float_in[1]", 2.5)], REFUSED, EX_ILLEGAL_ADDRESS),
    ("a non-finite REAL", [("io_control.ao[0]", NAN)], REFUSED, EX_ILLEGAL_VALUE),
    ("all or nothing: a good REAL, then a NaN",
     [("io_control.ao[0]", 3.5), ("io_control.ao[1]", NAN)], REFUSED, EX_ILLEGAL_VALUE),
    ("another DINT", [("int_in[4]", 11)], OK, None),
    ("two REALs the plan does not send", [("float_in[0]", 1.0), ("float_in[1]", 2.0)],
     REFUSED, EX_ILLEGAL_ADDRESS),
]
# The marker each side writes after a refused row, in the same stream of
# messages: once it is in the image, the refused write before it has been
# handled.
MARK = "int_in[7]"

_map = None


def regmap():
    global _map
    if _map is None:
        _map = RegMap()
    return _map


def kind(path):
    return "DINT" if path.startswith(("int_in", "int_")) else "REAL"


def regs_of(path, value):
    if kind(path) == "DINT":
        return list(struct.unpack(">HH", struct.pack(">i", int(value))))
    return list(struct.unpack(">HH", struct.pack(">f", value)))


def read(m, path):
    hi, lo = m.read(3, regmap().addr("HR", path), 2)
    raw = struct.pack(">HH", hi, lo)
    return struct.unpack(">i" if kind(path) == "DINT" else ">f", raw)[0]


def image(m, paths):
    return {p: read(m, p) for p in paths}


def same(a, b):
    return a == b or (isinstance(a, float) and isinstance(b, float) and
                      math.isnan(a) and math.isnan(b))


def all_paths():
    return sorted({p for _, writes, _, _ in CASES for p, _ in writes} | {MARK})


# ---- the sides: each writes one row and says what it saw -----------------------------

class ModbusSide:
    name = "modbus"

    def __init__(self, g):
        self.m = g.raw()
        self.m.__enter__()

    def write(self, writes, mark):
        addr = regmap().addr("HR", writes[0][0])
        regs = []
        for i, (p, v) in enumerate(writes):
            assert regmap().addr("HR", p) == addr + 2 * i, "a row's fields are contiguous"
            regs += regs_of(p, v)
        try:
            self.m.write_regs(addr, regs)
            return None
        except ModbusError as e:
            return e.code

    def close(self):
        self.m.close()


class JsonSide:
    name = "mqtt"

    def __init__(self, g, plant):
        self.plant = plant

    def write(self, writes, mark):
        (p, v), = writes
        n = len(self.plant.all(PREFIX + "/r0/error"))
        self.plant.set(p, "nan" if isinstance(v, float) and math.isnan(v) else repr(v))
        self.plant.set(MARK, str(mark))
        return n  # errors before: a refusal adds one

    def refused(self, before):
        return len(self.plant.all(PREFIX + "/r0/error")) > before


class SparkplugSide:
    name = "sparkplug"

    def __init__(self, g, host):
        self.host = host

    def metric(self, p, v):
        from pysparkplug import DataType, Metric, get_current_timestamp
        dt = DataType.INT32 if kind(p) == "DINT" else DataType.FLOAT
        return Metric(timestamp=get_current_timestamp(), name=p, datatype=dt, value=v)

    def write(self, writes, mark):
        self.host.send("DCMD", [self.metric(p, v) for p, v in writes], device="r0")
        self.host.send("DCMD", [self.metric(MARK, mark)], device="r0")
        return None


def run_table(g, side, check_refusal):
    """Every row through `side`; the image read back over Modbus."""
    with g.raw() as m:
        for mark, (name, writes, expect, ex) in enumerate(CASES, start=100):
            if side.name == "mqtt" and len(writes) > 1:
                continue
            before = image(m, all_paths())
            got = side.write(writes, mark)
            if side.name != "modbus":
                wait_for(lambda: read(m, MARK) == mark, 10, "%s: the marker after %r"
                         % (side.name, name))
            after = image(m, all_paths())
            changed = {p for p in before if p != MARK and not same(before[p], after[p])}
            fields = {p for p, _ in writes}
            if expect == OK:
                for p, v in writes:
                    assert same(after[p], v), (side.name, name, p, after[p], v)
                assert changed <= fields, (side.name, name, changed)
            else:
                assert changed == set(), (side.name, name, "a refused write changed", changed,
                                          before, after)
            check_refusal(name, expect, ex, got)


def test_modbus_runs_the_table():
    with running("wpath_mb", robot=PLAN) as g:
        side = ModbusSide(g)
        try:
            def check(name, expect, ex, got):
                assert got == (ex if expect == REFUSED else None), (name, got)
            run_table(g, side, check)
        finally:
            side.close()


@pytest.fixture
def broker(request):
    with broker_running(request.node.name) as b:
        yield b


def test_mqtt_json_runs_the_table(broker):
    with started_after("wpath_mqtt", [lambda: Plant(broker)], robot=PLAN,
                       extra=mqtt_section(broker, "writes = yes")) as (g, plant):
        wait_for(lambda: plant.last(PREFIX + "/r0/state") == "up", 20, "state up")
        side = JsonSide(g, plant)

        def check(name, expect, ex, got):
            if expect == REFUSED:
                wait_for(lambda: side.refused(got), 10, "%s: the error message" % name)
            else:
                assert not side.refused(got), (name, plant.all(PREFIX + "/r0/error"))
        run_table(g, side, check)
        errors = [p for _, p, _ in plant.all(PREFIX + "/r0/error")]
        assert any("not sent" in e and "float_in" in e for e in errors), errors


def spb_gateway(name, broker):
    pytest.importorskip("pysparkplug")
    from test_sparkplug import Host, spb_section
    return started_after(name, [lambda: Host(broker)], robot=PLAN,
                         extra=spb_section(broker, "writes = yes"))


def test_sparkplug_runs_the_table(broker):
    with spb_gateway("wpath_spb", broker) as (g, host):
        from test_sparkplug import wait_born
        wait_born(host)
        side = SparkplugSide(g, host)

        def check(name, expect, ex, got):
            pass  # the image says it: the marker came, the refused fields did not
        run_table(g, side, check)
        g.log_wait("refused: not sent: the connection plan opens no connection for float_in")


def test_sparkplug_dcmd_with_a_bad_second_metric_writes_nothing(broker):
    """The first metric good, the second not: a NaN (the codec refuses
    it); below, a payload cut in the middle of its second metric (nanopb
    fails after the first one decoded): neither writes the first."""
    with spb_gateway("wpath_spb_partial", broker) as (g, host), g.raw() as m:
        from test_sparkplug import wait_born
        wait_born(host)
        side = SparkplugSide(g, host)
        host.send("DCMD", [side.metric("int_in[5]", 55), side.metric("io_control.ao[1]", NAN)],
                  device="r0")
        host.send("DCMD", [side.metric(MARK, 1)], device="r0")
        wait_for(lambda: read(m, MARK) == 1, 10, "the marker")
        assert read(m, "int_in[5]") == 0, "the good first metric of a refused DCMD was written"
        g.log_wait("DCMD r0 io_control.ao[1] refused: invalid value")


# (the test's own host application sees the cut payload too, and says so
# from its thread)
@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")
def test_sparkplug_dcmd_cut_in_its_second_metric_writes_nothing(broker):
    with spb_gateway("wpath_spb_cut", broker) as (g, host), g.raw() as m:
        from test_sparkplug import wait_born
        wait_born(host)
        side = SparkplugSide(g, host)
        # cut inside the second metric: raw bytes over paho
        from pysparkplug import DCmd, get_current_timestamp
        payload = DCmd(timestamp=get_current_timestamp(),
                       metrics=(side.metric("int_in[6]", 66),
                                side.metric("int_in[7]", 77))).encode(include_dtypes=True)
        whole = DCmd(timestamp=get_current_timestamp(),
                     metrics=(side.metric("int_in[6]", 66),)).encode(include_dtypes=True)
        cut = payload[:len(whole) + 6]  # the first metric whole, the second begun
        import paho.mqtt.client as mqtt
        c = mqtt.Client()
        c.connect(GW_ADDR, broker.port, 30)
        c.loop_start()
        try:
            from test_sparkplug import EDGE, GROUP
            c.publish("spBv1.0/%s/DCMD/%s/r0" % (GROUP, EDGE), cut, qos=1).wait_for_publish(
                timeout(5))
            g.log_wait("malformed payload")
            # (the host's own client may have stopped on the cut payload: the
            # marker goes the same raw way)
            mark = DCmd(timestamp=get_current_timestamp(),
                        metrics=(side.metric(MARK, 2),)).encode(include_dtypes=True)
            c.publish("spBv1.0/%s/DCMD/%s/r0" % (GROUP, EDGE), mark, qos=1).wait_for_publish(
                timeout(5))
            wait_for(lambda: read(m, MARK) == 2, 10, "the marker")
            time.sleep(timeout(0.2))
            assert read(m, "int_in[6]") == 0, "the first metric of a malformed DCMD was written"
        finally:
            c.loop_stop()
            c.disconnect()
