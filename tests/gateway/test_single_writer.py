# SPDX-License-Identifier: MIT
"""Single-writer mode (like the EK9000's write lock): the first client that
writes owns the O->T areas and must keep changing the watchdog register;
when it stops, the O->T image goes to its fallback and a fault bit latches
until the reset register is written."""
import struct
import threading
import time

import pytest

from gwlib import (EX_ILLEGAL_FUNCTION, INSTANCE, SCALE, EnipReader, dint_regs, running, timeout,
                   wait_for)

# generous for a loaded machine (the bumper thread must never be late)
WATCHDOG_MS = int(1500 * SCALE)
HR_WATCHDOG, HR_RESET = 0, 1
IR_FAULT, IR_WRITER = 26, 27


@pytest.fixture
def pair(request):
    marker = request.node.get_closest_marker("gw")
    robot = marker.kwargs.get("robot", "") if marker else ""
    modbus = marker.kwargs.get("modbus", "") if marker else ""
    name = request.node.name
    with running(name, modbus="single_writer = yes\nwriter_watchdog_ms = %d\n%s"
                 % (WATCHDOG_MS, modbus), robot=robot) as g:
        g.enip = EnipReader("127.0.0.2", g.sim.tcp)
        yield g
        g.enip.close()


def robot_int_in0(g):
    return struct.unpack_from("<i", g.enip.get(INSTANCE["int_in"]))[0]


def fault(g):
    st = g.status()
    return st[IR_FAULT]


class Bumper:
    """Keeps changing the watchdog register from its own connection."""

    def __init__(self, m, period=0.1):
        self.m = m
        self.period = period
        self.stop = threading.Event()
        self.errors = []
        self.t = threading.Thread(target=self.run, daemon=True)

    def run(self):
        n = 0
        while not self.stop.is_set():
            n = (n + 1) & 0xFFFF
            try:
                self.m.write_reg(HR_WATCHDOG, n)
            except Exception as e:  # noqa: BLE001 - reported by the test
                self.errors.append(e)
                return
            self.stop.wait(self.period)

    def __enter__(self):
        self.t.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.t.join(timeout(10))


def test_first_writer_owns_and_watchdog_keeps_it(pair, regmap):
    g = pair
    hr = regmap.addr("HR", "int_in[0]")
    with g.raw() as a, g.raw() as b:
        assert g.status()[IR_WRITER] == 0
        a.write_regs(hr, dint_regs(42, "abcd"))
        wait_for(lambda: g.status()[IR_WRITER] == 1, 10, "writer_present")
        assert a.read(2, 3, 1) == [1]
        # the second writer is refused, whatever it writes; it may read
        assert b.exception(struct.pack(">BHHB", 0x10, hr, 2, 4) + bytes(4)) == \
            EX_ILLEGAL_FUNCTION
        assert b.exception(struct.pack(">BHH", 6, HR_WATCHDOG, 7)) == EX_ILLEGAL_FUNCTION
        assert b.exception(struct.pack(">BHH", 5, regmap.addr("CO", "bit_in[0]"), 0xFF00)) == \
            EX_ILLEGAL_FUNCTION
        assert b.read(3, hr, 2) == dint_regs(42, "abcd")
        with Bumper(a) as bump:
            wait_for(lambda: robot_int_in0(g) == 42, 10, "int_in[0] at the robot")
            # three watchdog periods with the owner alive: no fault
            deadline = time.monotonic() + 3 * WATCHDOG_MS / 1000.0
            while time.monotonic() < deadline:
                assert fault(g) == 0 and robot_int_in0(g) == 42
                time.sleep(0.1)
        assert not bump.errors, bump.errors


@pytest.mark.gw(robot="fallback = zero\n")
def test_watchdog_expiry_zeroes_outputs_and_latches(pair, regmap):
    g = pair
    hr = regmap.addr("HR", "int_in[0]")
    do = regmap.addr("HR", "io_control.cb_do")
    with g.raw() as a, g.raw() as b:
        t0 = time.monotonic()  # the first write starts the owner's watchdog
        a.write_regs(hr, dint_regs(4242, "abcd"))
        a.write_reg(do, 0x8001)
        wait_for(lambda: robot_int_in0(g) == 4242, 10, "int_in[0] at the robot")
        ir_do = regmap.addr("IR", "io_state.cb_do")
        wait_for(lambda: a.read(4, ir_do, 1) == [0x8001], 10, "io_state.cb_do")
        # the owner goes quiet (never bumps the watchdog)
        wait_for(lambda: fault(g) == 1, WATCHDOG_MS / 1000.0 + 10, "write_fault")
        took = time.monotonic() - t0
        assert took >= WATCHDOG_MS / 1000.0 - 0.3, "fault before the watchdog ran out"
        print("write fault after %.2f s (watchdog %d ms)" % (took, WATCHDOG_MS))
        # write_fault, and no writer (the block is refreshed 10 times a second)
        wait_for(lambda: a.read(2, 2, 2) == [1, 0], 10, "write_fault without a writer")
        # fallback zero: the robot sees zeros, drsim echoes them back
        wait_for(lambda: robot_int_in0(g) == 0, 10, "int_in[0] = 0 at the robot")
        int_out = regmap.addr("IR", "int_out[0]")
        wait_for(lambda: a.read(4, int_out, 2) == [0, 0], 10, "int_out[0] echo of the zero")
        wait_for(lambda: a.read(4, ir_do, 1) == [0], 10, "io_state.cb_do = 0")
        assert a.read(3, hr, 2) == [0, 0] and a.read(3, do, 1) == [0]
        g.log_wait("watchdog expired")
        # latched: it stays set
        time.sleep(0.5)
        assert fault(g) == 1
        # a reset clears it; whoever writes it is the new owner
        b.write_reg(HR_RESET, 1)
        wait_for(lambda: fault(g) == 0, 10, "write_fault reset")
        wait_for(lambda: g.status()[IR_WRITER] == 1, 10, "b as the writer")
        assert a.exception(struct.pack(">BHH", 6, HR_WATCHDOG, 1)) == EX_ILLEGAL_FUNCTION
        with Bumper(b):
            b.write_regs(hr, dint_regs(7, "abcd"))
            wait_for(lambda: robot_int_in0(g) == 7, 10, "the new owner's value")
            time.sleep(2 * WATCHDOG_MS / 1000.0)
            assert fault(g) == 0 and robot_int_in0(g) == 7


@pytest.mark.gw(robot="fallback = hold\n")
def test_watchdog_expiry_hold(pair, regmap):
    g = pair
    hr = regmap.addr("HR", "int_in[0]")
    with g.raw() as a:
        a.write_regs(hr, dint_regs(99, "abcd"))
        wait_for(lambda: robot_int_in0(g) == 99, 10, "int_in[0] at the robot")
        wait_for(lambda: fault(g) == 1, WATCHDOG_MS / 1000.0 + 10, "write_fault")
        assert robot_int_in0(g) == 99 and a.read(3, hr, 2) == dint_regs(99, "abcd")


def test_writer_disconnect_is_a_fault(pair, regmap):
    g = pair
    hr = regmap.addr("HR", "int_in[0]")
    with g.raw() as a:
        a.write_regs(hr, dint_regs(5, "abcd"))
        wait_for(lambda: g.status()[IR_WRITER] == 1, 10, "writer_present")
    # the owner is gone: nobody owns the areas any more ...
    wait_for(lambda: g.status()[IR_WRITER] == 0, 10, "writer gone")
    # ... and its watchdog runs out
    wait_for(lambda: fault(g) == 1, WATCHDOG_MS / 1000.0 + 10, "write_fault")
    wait_for(lambda: robot_int_in0(g) == 0, 10, "fallback zero at the robot")


def test_new_writer_gets_its_own_watchdog(pair, regmap):
    """An owner that leaves lets its watchdog run on; a client that takes
    over has the whole watchdog time from its first write, not what was
    left of the old owner's."""
    g = pair
    w = WATCHDOG_MS / 1000.0
    hr = regmap.addr("HR", "int_in[0]")
    with g.raw() as a:
        a.write_reg(HR_WATCHDOG, 1)
        t_last = time.monotonic()
        time.sleep(0.5 * w)
    wait_for(lambda: g.status()[IR_WRITER] == 0, 10, "the first owner gone")
    with g.raw() as b:
        b.write_regs(hr, dint_regs(6, "abcd"))  # takes over, without a bump
        t_claim = time.monotonic()
        wait_for(lambda: g.status()[IR_WRITER] == 1, 0.2 * w, "the new owner")
        # past where the old owner's watchdog ran out, inside the new one's
        time.sleep(max(0.0, t_last + 1.25 * w - time.monotonic()))
        assert fault(g) == 0
        assert time.monotonic() - t_claim < w, "too slow to tell (machine overloaded)"
        # and the new owner's own watchdog does run out
        wait_for(lambda: fault(g) == 1, w + 10, "write_fault of the new owner")


def test_unchanged_watchdog_value_does_not_count(pair):
    g = pair
    with g.raw() as a:
        a.write_reg(HR_WATCHDOG, 1234)
        t0 = time.monotonic()
        while fault(g) == 0:
            a.write_reg(HR_WATCHDOG, 1234)  # written, but never changed
            assert time.monotonic() - t0 < timeout(WATCHDOG_MS / 1000.0 + 10), "no fault"
            time.sleep(0.05)


@pytest.mark.gw(modbus="allow = 127.0.0.0/8 ro\n")
def test_read_only_client_never_owns(pair):
    g = pair
    with g.raw() as a:
        assert a.exception(struct.pack(">BHH", 6, HR_WATCHDOG, 1)) == EX_ILLEGAL_FUNCTION
        time.sleep(0.3)
        assert g.status()[IR_WRITER] == 0 and fault(g) == 0


# ---- the fault latch (issue 11 item 2) ----------------------------------------------
# States: free (no owner, no fault), owned, faulted (latched, no owner).
# free --write by a rw client--> owned; owned --watchdog expires--> faulted;
# faulted --any write but the reset--> faulted, refused with 0x04 and no
# owner taken; faulted --reset by a rw client--> owned by that client;
# faulted --reset by a ro client--> faulted, 0x01.

def fc6(addr, v):
    return struct.pack(">BHH", 6, addr, v)


def fc16(addr, values):
    return struct.pack(">BHHB", 0x10, addr, len(values), 2 * len(values)) + \
        struct.pack(">%dH" % len(values), *values)


def fault_after_quiet_owner(g, a, hr, value):
    a.write_regs(hr, dint_regs(value, "abcd"))
    a.write_reg(HR_WATCHDOG, 1)
    wait_for(lambda: robot_int_in0(g) == value, 10, "int_in[0] at the robot")
    wait_for(lambda: fault(g) == 1, WATCHDOG_MS / 1000.0 + 10, "write_fault")
    wait_for(lambda: g.status()[IR_WRITER] == 0, 10, "no owner after the fault")
    wait_for(lambda: robot_int_in0(g) == 0, 10, "fallback zero at the robot")


def test_faulted_refuses_every_write_but_the_reset(pair, regmap):
    """The reported defect: after the watchdog fault, the old owner (a PLC
    rewriting its heartbeat) or any other client took ownership with an
    ordinary write, which reached the robot with write_fault still 1, and
    an HMI's reset then got 0x01. Now every write but the reset gets 0x04
    and takes no ownership."""
    from gwlib import EX_DEVICE_FAILURE
    g = pair
    hr = regmap.addr("HR", "int_in[0]")
    co = regmap.addr("CO", "bit_in[0]")
    with g.raw() as plc, g.raw() as hmi:
        fault_after_quiet_owner(g, plc, hr, 1234)
        for m in (plc, hmi):
            for pdu in (fc6(HR_WATCHDOG, 2), fc6(HR_WATCHDOG, 3),      # the heartbeat
                        fc16(hr, dint_regs(77, "abcd")),               # robot data
                        struct.pack(">BHH", 5, co, 0xFF00),            # a coil
                        fc6(HR_RESET, 0),                              # not a reset
                        fc16(HR_RESET, [1, 0]),                        # reset + more
                        fc16(HR_RESET, [1] + dint_regs(1, "abcd"))):
                assert m.exception(pdu) == EX_DEVICE_FAILURE, pdu.hex()
        time.sleep(0.3)
        st = g.status()
        assert st[IR_FAULT] == 1 and st[IR_WRITER] == 0
        assert plc.read(2, 2, 2) == [1, 0]           # DI 2 write_fault, DI 3 writer
        assert robot_int_in0(g) == 0 and plc.read(3, hr, 2) == [0, 0]
        # reads go on
        assert hmi.read(4, 32, 1) == [0x1234]
        # the HMI's reset gets through and makes it the owner
        hmi.write_reg(HR_RESET, 1)
        assert fault(g) == 0
        wait_for(lambda: g.status()[IR_WRITER] == 1, 10, "the HMI as the owner")
        assert "client 127.0.0.1:%d reset the write fault of unit 1" % \
            hmi.sock.getsockname()[1] in g.log()
        assert plc.exception(fc6(HR_WATCHDOG, 9)) == EX_ILLEGAL_FUNCTION
        with Bumper(hmi):
            hmi.write_regs(hr, dint_regs(55, "abcd"))
            wait_for(lambda: robot_int_in0(g) == 55, 10, "the new owner's value")


def test_reset_with_watchdog_in_one_request_and_pipelined_write(pair, regmap):
    """FC 16 over HR 0-1 (watchdog and reset) is a reset; a write sent in
    the same segment right behind the reset is taken (the latch clears at
    once, not at the next turn of the loop)."""
    g = pair
    hr = regmap.addr("HR", "int_in[0]")
    with g.raw() as plc:
        fault_after_quiet_owner(g, plc, hr, 4321)
        with g.raw() as m:
            reset = struct.pack(">HHHB", 1, 0, 1 + len(fc16(0, [7, 1])), 1) + fc16(0, [7, 1])
            wr = fc16(hr, dint_regs(88, "abcd"))
            write = struct.pack(">HHHB", 2, 0, 1 + len(wr), 1) + wr
            m.sock.sendall(reset + write)
            for tid in (1, 2):
                rtid, _, _, rpdu = m.recv_adu()
                assert rtid == tid and rpdu[0] == 0x10, rpdu.hex()
            assert fault(g) == 0
            wait_for(lambda: robot_int_in0(g) == 88, 10, "the write behind the reset")
            assert plc.exception(fc6(HR_WATCHDOG, 5)) == EX_ILLEGAL_FUNCTION


@pytest.mark.gw(modbus="allow = 127.0.0.3/32 ro\nallow = 127.0.0.0/8 rw\n")
def test_fault_reset_needs_the_right_to_write(pair, regmap):
    from gwlib import GW_ADDR, RawModbus
    g = pair
    hr = regmap.addr("HR", "int_in[0]")
    with g.raw() as plc, RawModbus(GW_ADDR, g.port, source="127.0.0.3") as ro:
        fault_after_quiet_owner(g, plc, hr, 99)
        assert ro.exception(fc6(HR_RESET, 1)) == EX_ILLEGAL_FUNCTION
        time.sleep(0.2)
        assert fault(g) == 1 and g.status()[IR_WRITER] == 0
        plc.write_reg(HR_RESET, 1)   # the old owner may reset too: it owns again
        assert fault(g) == 0
        wait_for(lambda: g.status()[IR_WRITER] == 1, 10, "owner again")


def test_refused_write_takes_no_ownership(pair, regmap):
    """free --a write that fails a check--> free: only an applied write
    makes its client the owner (a refused one used to claim the lock)."""
    from gwlib import EX_ILLEGAL_ADDRESS, EX_ILLEGAL_VALUE
    g = pair
    with g.raw() as a, g.raw() as b:
        assert a.exception(fc6(HR_RESET, 2)) == EX_ILLEGAL_VALUE
        assert a.exception(fc6(regmap.addr("HR", "int_in[0]"), 1)) == EX_ILLEGAL_ADDRESS
        time.sleep(0.3)
        assert g.status()[IR_WRITER] == 0
        b.write_reg(HR_WATCHDOG, 1)                  # b's applied write: b owns
        wait_for(lambda: g.status()[IR_WRITER] == 1, 10, "b as the owner")
        assert a.exception(fc6(HR_WATCHDOG, 2)) == EX_ILLEGAL_FUNCTION
