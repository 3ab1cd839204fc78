# SPDX-License-Identifier: MIT
"""The status block: readable in every state, and its values mean what the
register map says."""
import socket
import time

import pytest

from gwlib import GW_ADDR, SCALE, running, wait_for


@pytest.fixture(scope="module")
def gw(regmap):
    with running("status", robot="rpi_ms = 20\n") as g:
        yield g


def st_addr(regmap, name):
    for e in regmap.area("IR"):
        if e["name"] == name or e["name"].startswith(name + " "):
            return e["address"]
    raise KeyError(name)


class Status:
    """Named status registers, addresses from the map."""

    def __init__(self, regs, regmap):
        self.regs = regs
        self.regmap = regmap

    def __getitem__(self, name):
        return self.regs[st_addr(self.regmap, "status." + name)]

    def u32(self, name):
        return self[name + " (high word)"] << 16 | self[name + " (low word)"]


def status(g, regmap, unit=1):
    return Status(g.status(unit), regmap)


def test_layout(regmap):
    names = [e["name"] for e in regmap.area("IR") if e["address"] < 44]
    assert [e["address"] for e in regmap.area("IR") if e["address"] < 44] == list(range(44))
    assert names[0] == "status.layout_version"
    assert names[31] == "status.reserved31" and names[32].startswith("test.")
    # the block goes on after the test registers: two 32-bit RTU counters
    assert names[40:44] == ["status.rtu_frames_%s (%s word)" % (c, w)
                            for c in ("dropped", "other_slave") for w in ("high", "low")]
    assert [e["name"] for e in regmap.area("DI") if e["address"] < 4] == [
        "status.link_up", "status.data_fresh", "status.write_fault", "status.writer_present"]


def test_values_while_up(gw, regmap):
    s = status(gw, regmap)
    assert s["layout_version"] == 1
    assert s["link_state"] == 2
    assert s["data_fresh"] == 1
    assert s["data_age_ms"] < 1000 * SCALE  # RPI 20 ms: a few RPIs old at most
    assert s["rpi_ms"] == 20
    assert s["last_error"] == 0
    assert s["write_fault"] == 0 and s["writer_present"] == 0
    assert s["word_order"] == 0
    assert s["config_generation"] == 0
    assert s["reserved31"] == 0
    assert s.u32("rtu_frames_dropped") == 0 and s.u32("rtu_frames_other_slave") == 0
    # six Class 1 connections, all established (dr_conn_state_t 2)
    assert [s["conn_state[%d]" % i] for i in range(10)] == [2] * 6 + [0] * 4
    with gw.raw() as m:
        assert m.read(2, 0, 4) == [1, 1, 0, 0]


def test_counters_move(gw, regmap):
    s0 = status(gw, regmap)
    t0 = time.monotonic()
    s1 = wait_for(lambda: (lambda s: s if s["heartbeat"] != s0["heartbeat"] and
                           s.u32("uptime_s") > s0.u32("uptime_s") else None)(status(gw, regmap)),
                  10, "heartbeat and uptime to move")
    elapsed = time.monotonic() - t0
    assert (s1["heartbeat"] - s0["heartbeat"]) % 65536 <= elapsed + 2
    assert s1.u32("rx_packets") > s0.u32("rx_packets")
    assert s1.u32("lost_packets") == 0
    # uptime follows the wall clock, roughly
    assert s1.u32("uptime_s") - s0.u32("uptime_s") <= elapsed + 2


def test_client_count(gw, regmap):
    with gw.raw() as m:
        def clients():
            return Status(m.read(4, 0, 40), regmap)["clients"]
        wait_for(lambda: clients() == 1, 10, "this client alone")
        extra = [socket.create_connection((GW_ADDR, gw.port)) for _ in range(3)]
        try:
            wait_for(lambda: clients() == 4, 10, "3 more clients")
        finally:
            for s in extra:
                s.close()
        wait_for(lambda: clients() == 1, 10, "the 3 clients to go")


def test_status_of_each_unit_only(gw):
    with gw.raw() as m:
        assert m.exception(bytes([4, 0, 0, 0, 1]), unit=2) == 0x0A


@pytest.fixture(scope="module")
def gw_lossy():
    with running("status-drop", sim_args=("--drop", "10", "--seed", "7")) as g:
        yield g


def test_lost_packets_counted(gw_lossy, regmap):
    wait_for(lambda: status(gw_lossy, regmap).u32("lost_packets") > 0, 20,
             "lost packets with drsim --drop 10")
    s = status(gw_lossy, regmap)
    assert s.u32("rx_packets") > s.u32("lost_packets")


@pytest.mark.parametrize("order", ["cdab", "dcba"])
def test_counters_high_word_first_in_every_word_order(order, regmap):
    """Issue 11 item 6, decided: the 32-bit status counters do not follow
    word_order (docs/register-map.md says so in its first table). A
    counter far below 65536 shows its value in the low word, the high
    word 0, also in the swapped orders."""
    with running("status-order-" + order, modbus="word_order = %s\n" % order) as g:
        s = wait_for(lambda: (lambda x: x if x["uptime_s (low word)"] >= 1 and
                              x.u32("rx_packets") > 0 else None)(status(g, regmap)),
                     10, "uptime and rx_packets to count")
        assert s["word_order"] == ("abcd", "cdab", "badc", "dcba").index(order)
        assert s["uptime_s (high word)"] == 0 and 1 <= s["uptime_s (low word)"] < 600
        assert s["rx_packets (high word)"] == 0 and s["rx_packets (low word)"] > 0
        # while the test registers do follow the order
        with g.raw() as m:
            from gwlib import REAL_123456
            assert m.read(4, 35, 2) == REAL_123456[order]
