# SPDX-License-Identifier: MIT
"""A gateway that crashed gets its robot back (issue 19, item 1).

drsim holds an exclusive-owner connection whose originator went silent, as
an ODVA adapter (OpENer) does, and lets only the same vendor ID and
originator serial take it over; anyone else gets 0x01/0x0106 for as long
as it holds it (drsim: until it stops). drgatewayd's originator serial is
the same at every start (`originator_serial`, by default derived from
/etc/machine-id and the robot's name), so a gateway killed with SIGKILL
and started again takes its four owner connections back at its first
Forward Opens; one with another serial is refused.
"""
import re
import signal

from gwlib import running, wait_for

OWNERS = range(0, 4)      # conn_state of io_state, bit_out, int_out, float_out
INPUT_ONLY = range(4, 6)  # joint_state, task_state
ESTABLISHED = 2
CONN_OPEN = "connection open:"
HELD = "held, "
TAKEN_OVER = "closed (taken over by its originator)"
# x256: 2.56 s at RPI 10 ms, so that a stall of a loaded machine (ASan)
# never times a connection out by itself and every count below is exact
ROBOT = "timeout_multiplier = 6\n"


def conn_states(st):
    return [st[16 + i] for i in range(6)]


def all_up(g):
    st = g.status()
    return st[1] == 2 and all(s == ESTABLISHED for s in conn_states(st)) and st


def serials(log):
    return re.findall(r"originator serial (0x[0-9A-F]{8})", log)


def crash(g):
    """SIGKILL, no Forward Close; then wait until drsim has timed the
    connections out: the four owners held, the two input-only closed. A
    restart within the connection timeout would meet established owners,
    which refuse even their own originator (OpENer's rule, docs/interop.md);
    that case is test_sim_io.c's test_owner_takeover."""
    sim = g.sim
    mark = len(sim.log())
    g.proc.send_signal(signal.SIGKILL)
    g.proc.wait()
    # A gateway killed right after its link came up may not have sent an
    # O->T packet yet (seen under ASan): drsim then says "no O->T packet".
    def closed(log):
        return log.count("closed (O->T timeout)") + log.count("closed (no O->T packet)")
    wait_for(lambda: sim.log()[mark:].count(HELD) == 4 and closed(sim.log()[mark:]) == 2,
             20, "drsim to hold the four owners and close the input-only connections")


def test_killed_gateway_takes_its_connections_back():
    with running("owner_restart", robot=ROBOT) as g:
        wait_for(lambda: all_up(g), 20, "every connection up")
        crash(g)
        sim_mark, gw_mark = len(g.sim.log()), len(g.log())
        g.start(wait_link=False)
        # every connection up at the first Forward Opens: no retry (bounded
        # wait, but the counts below say there was a single round)
        st = wait_for(lambda: all_up(g), 10, "every connection up after the restart")
        assert st[12] == 0 and st[30] == 0, "last_error %#x / %#x" % (st[12], st[30])
        sim_log, gw_log = g.sim.log()[sim_mark:], g.log()[gw_mark:]
        assert sim_log.count(TAKEN_OVER) == 4, sim_log
        assert sim_log.count(CONN_OPEN) == 6, sim_log
        assert "refused" not in sim_log, sim_log
        assert "0x0106" not in gw_log and "ownership" not in gw_log, gw_log
        # the same originator serial in both runs, and not the clock's
        both = serials(g.log())
        assert len(both) == 2 and both[0] == both[1], both


def test_other_originator_is_refused():
    with running("owner_other", robot=ROBOT) as g:
        wait_for(lambda: all_up(g), 20, "every connection up")
        mine = serials(g.log())[0]
        crash(g)
        sim_mark = len(g.sim.log())
        # another originator (a replaced PC, a copied configuration): the
        # held owners stay held, refused with 0x0106; input-only opens
        g.robot_extra = ROBOT + "originator_serial = 0x5EED0001\n"
        g.start(wait_link=False)

        def refused():
            st = g.status()
            return (st[12] == 0x0106 and st[30] == 0x01 and
                    all(conn_states(st)[i] == ESTABLISHED for i in INPUT_ONLY) and st)
        st = wait_for(refused, 10, "0x0106 with the input-only connections up")
        assert all(conn_states(st)[i] != ESTABLISHED for i in OWNERS), conn_states(st)
        assert "originator serial 0x5EED0001" in g.log()
        sim_log = g.sim.log()[sim_mark:]
        assert "refused: 0x01/0x0106" in sim_log, sim_log
        assert re.search(r"owned by connection 0x[0-9A-F]{8} \(timed out, held\) of "
                         r"originator vendor 0xFFFE serial %s" % mine, sim_log), sim_log
        assert TAKEN_OVER not in sim_log
        # the rightful originator comes back and takes them over
        g.kill()
        sim_mark = len(g.sim.log())
        g.robot_extra = ROBOT
        g.start(wait_link=False)
        wait_for(lambda: all_up(g), 10, "every connection up with the first serial")
        assert g.sim.log()[sim_mark:].count(TAKEN_OVER) == 4
