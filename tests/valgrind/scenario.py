# SPDX-License-Identifier: MIT
"""One integration scenario with drsim and drgatewayd both under valgrind
memcheck (make check-valgrind, mk/valgrind.mk): drsim on 127.0.0.2,
drgatewayd (Class 1, RPI 20 ms, no GPIO) connected to it, Modbus clients
reading every area and writing the O->T ones, a write checked through
the robot's echo, exception replies, a second client coming and going, a
session drop by drsim and the gateway's reconnect, a SIGHUP reload, drcli
(also under valgrind) reading drsim directly, then SIGTERM to both.

Each program must exit 0 with valgrind reporting 0 errors, 0 bytes
definitely or indirectly lost and no descriptor left open but stdio and
valgrind's own log. One "passed failed label" line per program goes to
the results file.

usage: scenario.py BUILD_DIR RESULTS LOGDIR [SUPPRESSIONS]
"""
import logging
import re
import signal
import struct
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "soak"))
import harness as H  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402

logging.getLogger("pymodbus").setLevel(logging.CRITICAL)  # exceptions are expected here

# valgrind makes everything 20-50x slower: every wait here is generous.
SLOW = 60


def valgrind(logdir, name, supp):
    cmd = ["valgrind", "--tool=memcheck", "--leak-check=full",
           "--show-leak-kinds=definite,indirect",
           "--errors-for-leak-kinds=definite,indirect",
           "--error-exitcode=99", "--track-fds=yes", "--num-callers=30",
           "--log-file=%s" % (Path(logdir) / ("%s.valgrind" % name))]
    if supp:
        cmd.append("--suppressions=%s" % supp)
    return cmd


def check_valgrind_log(path):
    """Problems valgrind reported in its log (an empty list: clean)."""
    text = Path(path).read_text(errors="replace")
    bad = []
    m = re.search(r"ERROR SUMMARY: (\d+) errors", text)
    if m is None:
        bad.append("no ERROR SUMMARY (valgrind did not finish?)")
    elif m.group(1) != "0":
        bad.append("%s errors" % m.group(1))
    for kind in ("definitely", "indirectly"):
        m = re.search(r"%s lost: ([\d,]+) bytes" % kind, text)
        if m is not None and m.group(1) != "0":
            bad.append("%s lost: %s bytes" % (kind, m.group(1)))
    if "All heap blocks were freed" not in text and "LEAK SUMMARY" not in text:
        bad.append("no heap summary")
    # --track-fds: stdin/out/err and valgrind's log are expected; any
    # other descriptor open at exit is a leak.
    m = re.search(r"FILE DESCRIPTORS: (\d+) open(?: \((\d+) std\))? at exit", text)
    if m is None:
        bad.append("no FILE DESCRIPTORS report")
    else:
        extra = []
        # one block per descriptor: "Open ... N: what", then where it was
        # opened, or "<inherited from parent>" (not ours to close)
        for blk in re.split(r"==\d+== (?=Open )", text)[1:]:
            head = re.match(r"Open (?:AF_\w+ socket|file descriptor) (\d+):? ?(.*)", blk)
            if head and int(head.group(1)) > 2 and "<inherited from parent>" not in blk:
                extra.append(head.groups())
        if extra:
            bad.append("descriptors open at exit: %s" % ", ".join(
                "%s (%s)" % (fd, what or "?") for fd, what in extra))
    return bad


def regs_of_real(f):
    return list(struct.unpack(">HH", struct.pack(">f", f)))


def regs_of_dint(i):
    return list(struct.unpack(">HH", struct.pack(">i", i)))


def status(mb):
    r = mb.read_input_registers(0, count=40, slave=1)
    assert not r.isError(), r
    return r.registers


def wait_link(mb, seconds):
    H.wait_for(lambda: (lambda st: st[1] == 2 and st[2] == 1)(status(mb)), seconds,
               "the gateway's link to drsim (IR 1 = 2, IR 2 = 1)", interval=0.2)


def scenario(build, logdir, supp, results):
    drsim_vg = valgrind(logdir, "drsim", supp)
    gw_vg = valgrind(logdir, "drgatewayd", supp)
    # drsim drops the gateway's TCP session 8 s after each accept: the
    # gateway registers again while its Class 1 connections carry on.
    sim, sim_tcp, sim_udp = H.start_drsim(build / "drsim", logdir, "valgrind",
                                          extra=["--drop-session-after", "8"],
                                          wrapper=drsim_vg, seconds=SLOW)
    gw, port, conf = H.start_gateway(build / "drgatewayd", logdir, "valgrind", sim_tcp,
                                     sim_udp, robot_extra="rpi_ms = 20\ntimeout_multiplier = 5\n",
                                     wrapper=gw_vg, seconds=SLOW)
    H.log("valgrind: drsim (pid %d) on %s:%d, drgatewayd (pid %d) on %s:%d" %
          (sim.pid, H.SIM_ADDR, sim_tcp, gw.pid, H.GW_ADDR, port))
    mb = ModbusTcpClient(H.GW_ADDR, port=port, timeout=10, retries=0)
    assert mb.connect(), "pymodbus cannot connect"
    wait_link(mb, 2 * SLOW)
    H.log("valgrind: link up")

    # reads of every area
    st = status(mb)
    assert st[0] == 1 and st[32] == 0x1234, st  # layout version, test register
    for fc, addr, n in ((4, 100, 25), (4, 200, 72), (4, 300, 48), (4, 400, 4),
                        (4, 500, 48), (4, 600, 48), (4, 1200, 36), (3, 0, 2),
                        (3, 100, 8), (3, 300, 48), (3, 400, 48), (2, 0, 4), (2, 100, 53),
                        (1, 100, 24), (1, 200, 64)):
        fn = {1: mb.read_coils, 2: mb.read_discrete_inputs, 3: mb.read_holding_registers,
              4: mb.read_input_registers}[fc]
        r = fn(addr, count=n, slave=1)
        assert not r.isError(), (fc, addr, n, r)

    # writes of every O->T kind, then the robot's echo of int_in/float_in
    ints = [1000 + 7 * i for i in range(24)]
    regs = []
    for v in ints:
        regs += regs_of_dint(v)
    assert not mb.write_registers(300, regs, slave=1).isError()
    assert not mb.write_registers(400, regs_of_real(-12.5) + regs_of_real(3.25), slave=1).isError()
    assert not mb.write_register(1402, 1234, slave=1).isError()  # scaled float_in[2] = 12.34
    assert not mb.write_coils(200, [True, False, True, True] * 4, slave=1).isError()
    assert not mb.write_coil(100, True, slave=1).isError()
    assert not mb.write_registers(200, [0xA5A5, 0x0F0F], slave=1).isError()

    def echoed():
        r = mb.read_input_registers(500, count=48, slave=1)
        f = mb.read_input_registers(600, count=4, slave=1)
        return (not r.isError() and r.registers == regs and not f.isError() and
                f.registers == regs_of_real(-12.5) + regs_of_real(3.25))
    H.wait_for(echoed, SLOW, "drsim's echo of int_in and float_in in int_out/float_out",
               interval=0.2)
    H.log("valgrind: writes echoed by drsim")

    # exception replies: an address past the map, a unit no robot has, a half REAL
    assert mb.read_input_registers(2000, count=2, slave=1).isError()
    assert mb.read_input_registers(0, count=2, slave=9).isError()
    assert mb.write_register(400, 1, slave=1).isError()

    # a second client comes and goes
    for _ in range(3):
        other = ModbusTcpClient(H.GW_ADDR, port=port, timeout=10, retries=0)
        assert other.connect()
        assert not other.read_input_registers(0, count=8, slave=1).isError()
        other.close()

    # drsim drops the session; the gateway registers again
    H.wait_for(lambda: "closed (--drop-session-after)" in sim.log(), 3 * SLOW,
               "drsim's session drop", interval=0.5)
    H.wait_for(lambda: sim.log().count("registered by") >= 2, 3 * SLOW,
               "a second session from the gateway", interval=0.5)
    wait_link(mb, 2 * SLOW)

    # a reload that is taken, and one that is refused
    text = conf.read_text()
    conf.write_text(text.replace("log_level = info", "log_level = debug"))
    gw.p.send_signal(signal.SIGHUP)
    H.wait_for(lambda: "reloaded (generation 1)" in gw.log(), SLOW, "the reload")
    conf.write_text(text + "\n[robot r1]\n")
    gw.p.send_signal(signal.SIGHUP)
    H.wait_for(lambda: "reload refused" in gw.log(), SLOW, "the refused reload")
    conf.write_text(text)
    wait_link(mb, 2 * SLOW)
    assert not mb.write_registers(300, regs_of_dint(-5), slave=1).isError()
    H.wait_for(lambda: mb.read_input_registers(500, count=2, slave=1).registers ==
               regs_of_dint(-5), SLOW, "the echo after the reload", interval=0.2)
    mb.close()

    # drcli under valgrind, straight to drsim
    cli_log = Path(logdir) / "drcli.log"
    cli = H.Proc(valgrind(logdir, "drcli", supp) +
                 [build / "drcli", "-H", H.SIM_ADDR, "--port", sim_tcp, "--timeout", "20000",
                  "get", "int_out[0]", "float_out[0]", "io_state.robot_state"], cli_log)
    cli_rc = cli.p.wait(3 * SLOW)
    H.log("valgrind: drcli exit %d: %s" % (cli_rc, cli.log().strip().replace("\n", "; ")))
    assert "int_out[0]" in cli.log() and "-5" in cli.log(), cli.log()

    gw_rc = gw.stop(3 * SLOW)
    sim_rc = sim.stop(3 * SLOW)
    return {"drgatewayd": gw_rc, "drsim": sim_rc, "drcli": cli_rc}


def main():
    build, results, logdir = Path(sys.argv[1]), sys.argv[2], Path(sys.argv[3])
    supp = sys.argv[4] if len(sys.argv) > 4 else None
    logdir.mkdir(parents=True, exist_ok=True)
    for p in logdir.glob("*.valgrind"):
        p.unlink()
    t0 = time.monotonic()
    codes = {}
    failure = None
    try:
        codes = scenario(build, logdir, supp, results)
    except Exception as e:  # the scenario itself failed: still read the logs
        failure = "%s: %s" % (type(e).__name__, e)
        H.log("valgrind: scenario FAILED: %s" % failure)
    finally:
        H.kill_all()
    status = 0
    for name in ("drsim", "drgatewayd", "drcli"):
        vlog = logdir / ("%s.valgrind" % name)
        bad = [] if failure is None else ["scenario: " + failure]
        rc = codes.get(name)
        if rc != 0:
            bad.append("exit status %s%s" % (rc, " (valgrind found errors)" if rc == 99 else ""))
        if vlog.exists():
            bad += check_valgrind_log(vlog)
        else:
            bad.append("no valgrind log")
        label = "valgrind %s (0 errors, 0 leaks, no fd left open)" % name
        if bad:
            status = 1
            H.log("valgrind: FAIL %s: %s (see %s)" % (name, "; ".join(bad), vlog))
            if vlog.exists():
                print(vlog.read_text(errors="replace")[-6000:])
        else:
            H.log("valgrind: PASS %s" % name)
        H.append_result(results, 0 if bad else 1, 1 if bad else 0, label)
    H.log("valgrind: scenario took %.0f s" % (time.monotonic() - t0))
    return status


if __name__ == "__main__":
    sys.exit(main())
