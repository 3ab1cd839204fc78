# SPDX-License-Identifier: MIT
"""The connection plan ([robot] config_instance, *_heartbeat, open.*) against
drsim acting as a controller whose EDS decides the connection points, and
the status block saying why a link never came up: every refused Forward
Open shows in IR 12 (last_error) and IR 30 (last_cip_general), with a log
line naming the robot and the CIP status in hex and words."""
import struct

import pytest

from gwlib import (EX_ILLEGAL_ADDRESS, Drsim, Gateway, real_regs, regs_real, running,
                   wait_for)

LAST_ERROR, CONN_STATE, LAST_CIP_GENERAL = 12, 16, 30
# conn_state[0..5]: the connections of these T->O assemblies, whatever the plan
SLOTS = ["io_state", "bit_out", "int_out", "float_out", "joint_state", "task_state"]


def test_status_registers_where_the_map_says(regmap):
    assert regmap.addr("IR", "status.last_error") == LAST_ERROR
    assert regmap.addr("IR", "status.last_cip_general") == LAST_CIP_GENERAL
    assert regmap.addr("IR", "status.conn_state[0]") == CONN_STATE


def wait_refusal(g, extended, general=0x01):
    """The refusal shows in the status block after the first retry at the
    latest (the bound is generous, not a timing goal)."""
    def seen():
        st = g.status()
        return st[LAST_ERROR] == extended and st[LAST_CIP_GENERAL] == general
    wait_for(seen, 15, "IR 12 = 0x%04X and IR 30 = 0x%02X" % (extended, general))
    return g.status()


# The default plan's connections as (T->O, O->T point) by instance: the
# owners' O->T assemblies, the input-only heartbeat 198.
DEFAULT_PATHS = {(101, 107), (104, 108), (105, 109), (106, 110), (102, 198), (103, 198)}
HEARTBEAT_PATHS = {(102, 198), (103, 198)}


@pytest.mark.parametrize("sim_args,extended,words,paths", [
    (("--config-instance", "199"), 0x0129, "invalid configuration application path",
     DEFAULT_PATHS),
    (("--refuse-forward-open", "0x012F"), 0x012F, "inconsistent application path combination",
     DEFAULT_PATHS),
    (("--input-only-heartbeat", "0"), 0x012A, "invalid consuming application path",
     HEARTBEAT_PATHS),
])
def test_refusal_before_the_first_success(sim_args, extended, words, paths):
    """The link never comes up, yet the status block and the log say why
    (before, IR 12 stayed 0: it was written only when the link changed).
    The log line names the instances of the refused path (config, O->T,
    T->O): adapters answer a wrong point with different statuses."""
    import re
    name = "plan-refused-%04x" % extended
    with running(name, sim_args=sim_args, start=False) as g:
        g.start(wait_link=False)
        st = wait_refusal(g, extended)
        assert st[1] != 2 and st[2] == 0
        g.log_wait("robot r0: ")
        g.log_wait("Forward Open refused: CIP 0x01/0x%04X %s" % (extended, words))
        assert "refused: 0x01/0x%04X" % extended in g.sim.log()
        found = re.findall(r"Forward Open refused: CIP 0x01/0x%04X [^(]*"
                           r"\(path: config (\d+), O->T (\d+), T->O (\d+)\)" % extended, g.log())
        assert found, g.log()
        for config, o2t, t2o in found:
            assert int(config) == 1 and (int(t2o), int(o2t)) in paths, (config, o2t, t2o)


def test_listen_only_needs_an_owner():
    """drsim refuses a listen-only connection to a T->O nobody produces
    (0x0119); the other connections come up, the status says which failed."""
    with running("plan-listen-only", start=False,
                 robot="open.task_state = listen_only\n") as g:
        g.start(wait_link=False)
        st = wait_refusal(g, 0x0119)
        g.log_wait("robot r0: task_state (listen-only): ")
        g.log_wait("CIP 0x01/0x0119 non-listen only connection not opened")
        wait_for(lambda: g.status()[CONN_STATE:CONN_STATE + 5] == [2] * 5, 20,
                 "the five other connections established")
        assert g.status()[CONN_STATE + 5] != 2
        assert st[1] != 2


LISTEN_ONLY = "".join("open.%s = none\n" % a for a in SLOTS[:5]) + "open.task_state = listen_only\n"


def test_listen_only_ends_with_its_owner():
    """A listen-only connection lives on another originator's: when that
    one's connections time out, drsim closes the listen-only ones too (as
    ODVA adapters do); the gateway sees its connection time out, is refused
    (0x0119) while nobody produces task_state, and comes back with the
    other originator."""
    sim = Drsim("plan-lo-sim").start()
    owner = Gateway("plan-lo-owner", sim)
    listener = Gateway("plan-lo-listener", sim, robot=LISTEN_ONLY)
    try:
        owner.start()                   # task_state input-only: its producer
        listener.start()
        assert listener.status()[CONN_STATE:CONN_STATE + 6] == [0] * 5 + [2]
        owner.kill()                    # its connections time out at drsim
        wait_for(lambda: "closed (its producer closed)" in sim.log(), 20,
                 "drsim to close the listen-only connection with its producer")
        listener.wait_link(False)
        listener.log_wait("robot r0: task_state (listen-only): ")
        wait_refusal(listener, 0x0119)
        owner.start()
        listener.wait_link(True, seconds=30)
        assert listener.status()[CONN_STATE + 5] == 2
    finally:
        listener.kill()
        owner.kill()
        sim.kill()


PLAN = ("config_instance = 199\ninput_only_heartbeat = 250\nlisten_only_heartbeat = 251\n"
        "open.bit_out = input_only\nopen.joint_state = none\n")


def test_configured_plan(regmap):
    """A controller with configuration instance 199 and input-only heartbeat
    250 (drsim refuses 1 and 198): the plan's connections come up, data
    flows both ways on the owner connections, the assembly that is not
    opened reads 0 and the O->T assemblies without an owner refuse writes."""
    sim_args = ("--config-instance", "199", "--input-only-heartbeat", "250",
                "--listen-only-heartbeat", "251")
    with running("plan-configured", sim_args=sim_args, robot=PLAN) as g:
        st = g.status()
        assert st[CONN_STATE:CONN_STATE + 6] == [2, 2, 2, 2, 0, 2], st[CONN_STATE:CONN_STATE + 6]
        assert st[LAST_ERROR] == 0 and st[LAST_CIP_GENERAL] == 0
        log = g.sim.log()
        assert log.count("connection open:") == 5
        assert "O->T 250 (" in log and "refused" not in log
        with g.raw() as m:
            assert m.read(4, regmap.addr("IR", "io_state.version.major"), 3) == [2, 12, 3]
            # float_in is still owned (with float_out): drsim echoes it back
            m.write_regs(regmap.addr("HR", "float_in[3]"), real_regs(2.5, "abcd"))
            fo = regmap.addr("IR", "float_out[3]")
            wait_for(lambda: regs_real(m.read(4, fo, 2), "abcd") == 2.5, 10,
                     "float_out[3] echoing float_in[3]")
            # joint_state is not opened: never received, reads 0 (drsim's
            # joints move: opened, they never read all 0)
            assert m.read(4, regmap.addr("IR", "joint_state.position[1]"), 72) == [0] * 72
            # bit_in has no owner connection: nothing would carry a write
            # to the robot; int_in still has one
            write_bit = struct.pack(">BHH", 0x05, regmap.addr("CO", "bit_in[0]"), 0xFF00)
            assert m.exception(write_bit) == EX_ILLEGAL_ADDRESS
            m.write_regs(regmap.addr("HR", "int_in[0]"), [0, 7])
            # bit_out (input-only now) still flows
            assert g.status()[CONN_STATE + 1] == 2


def test_plan_in_explicit_mode(regmap):
    """Explicit mode has no Class 1 connections: the plan says what is
    polled. joint_state and int_out (none) are not read, int_in (no owner)
    not written and its registers refuse writes; the rest is polled as
    before, and config_instance is not used."""
    with running("plan-explicit", sim_args=("--config-instance", "199"),
                 robot="mode = explicit\nrpi_ms = 20\nconfig_instance = 7\n"
                       "open.int_out = none\nopen.joint_state = none\n") as g:
        with g.raw() as m:
            assert m.read(4, regmap.addr("IR", "io_state.version.major"), 3) == [2, 12, 3]
            assert m.read(4, regmap.addr("IR", "joint_state.position[1]"), 72) == [0] * 72
            write_int = struct.pack(">BHHBi", 0x10, regmap.addr("HR", "int_in[0]"), 2, 4, 7)
            assert m.exception(write_int) == EX_ILLEGAL_ADDRESS
            m.write_regs(regmap.addr("HR", "float_in[1]"), real_regs(-4.0, "abcd"))
            fo = regmap.addr("IR", "float_out[1]")
            wait_for(lambda: regs_real(m.read(4, fo, 2), "abcd") == -4.0, 10,
                     "float_out[1] echoing float_in[1]")
        st = g.status()
        assert st[LAST_ERROR] == 0
        log = g.sim.log()
        assert "refused" not in log and "connection open" not in log
