# SPDX-License-Identifier: MIT
"""Assembly layouts (issue 31): drgatewayd against drsim speaking each
layout (--layout per_assembly, combined, gpr_only), implicit and explicit.
Every field the layout carries reads the same through Modbus as `drcli get`
says over explicit messaging (drcli with the same --layout), O->T values
written through Modbus reach the robot, the assemblies a layout does not
carry read 0 and refuse writes, and a plan whose sizes are not the
adapter's is refused with both sizes in the log."""
import json
import os
import struct
import subprocess

import pytest

from gwlib import (DRCLI, EX_ILLEGAL_ADDRESS, SIM_ADDR, Drsim, Gateway, dint_regs, f32,
                   free_port, real_regs,
                   regs_dint, regs_real, running, timeout, wait_for)
from test_metrics import PROMTOOL, get, http_section, samples

T2O = ["io_state", "joint_state", "task_state", "bit_out", "int_out", "float_out"]
O2T = ["io_control", "bit_in", "int_in", "float_in"]
GPR = {"bit_out", "int_out", "float_out", "bit_in", "int_in", "float_in"}
CARRIED = {"per_assembly": set(T2O + O2T), "combined": set(T2O + O2T), "gpr_only": GPR}


def drcli_get(sim, layout, assemblies):
    out = subprocess.run([str(DRCLI), "-H", SIM_ADDR, "--port", str(sim.tcp), "--layout",
                          layout, "get", "--json"] + sorted(assemblies),
                         capture_output=True, text=True, timeout=timeout(30))
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def modbus_value(m, e):
    """The value of regmap entry e as Modbus shows it, or None for a type
    this comparison does not cover (scaled views, packed masks)."""
    t, area, a = e["type"], e["area"], e["address"]
    if t == "bit":
        return bool(m.read(1 if area == "CO" else 2, a, 1)[0])
    fc = 3 if area == "HR" else 4
    if t.startswith("REAL, 2 registers"):
        return regs_real(m.read(fc, a, 2), "abcd")
    if t.startswith("DINT, 2 registers"):
        return regs_dint(m.read(fc, a, 2), "abcd")
    if t.startswith("BOOL"):
        return bool(m.read(fc, a, 1)[0])
    if t.startswith("USINT"):
        return m.read(fc, a, 1)[0]
    return None


def same(mb, cli):
    if isinstance(mb, float):
        return mb == f32(cli) or (mb != mb and cli == "nan")
    return mb == cli


def write_outputs(m, regmap, layout):
    """O->T values through Modbus, which drsim echoes into T->O."""
    m.write_regs(regmap.addr("HR", "int_in[2]"), dint_regs(-123456, "abcd"))
    m.write_regs(regmap.addr("HR", "float_in[1]"), real_regs(2.5, "abcd"))
    m.write_coil(regmap.addr("CO", "bit_in[3]"), True)
    if layout != "gpr_only":
        m.write_coil(regmap.addr("CO", "io_control.cb_do[2]"), True)
    def echoed():
        return (regs_dint(m.read(4, regmap.addr("IR", "int_out[2]"), 2), "abcd") == -123456
                and regs_real(m.read(4, regmap.addr("IR", "float_out[1]"), 2), "abcd") == 2.5
                and m.read(2, regmap.addr("DI", "bit_out[3]"), 1)[0]
                and (layout == "gpr_only" or m.read(2, regmap.addr("DI", "io_state.cb_do[2]"),
                                                    1)[0]))
    # one O->T packet may leave between two writes: wait for every echo
    wait_for(echoed, 10, "int_out[2], float_out[1], bit_out[3] echoing the writes")


CASES = [("per_assembly", "implicit"), ("combined", "implicit"), ("gpr_only", "implicit"),
         ("combined", "explicit"), ("gpr_only", "explicit")]


@pytest.mark.parametrize("layout,mode", CASES)
def test_every_field_as_drcli_reads_it(regmap, layout, mode):
    robot = "layout = %s\nmode = %s\nrpi_ms = 20\n" % (layout, mode)
    with running("layout-%s-%s" % (layout, mode), sim_args=("--layout", layout, "--still"),
                 robot=robot) as g:
        assert ("layout %s" % layout in g.log()) == (layout != "per_assembly")
        with g.raw() as m:
            if "io_state" in CARRIED[layout]:
                wait_for(lambda: m.read(4, regmap.addr("IR", "io_state.robot_state"), 1)[0]
                         == 2, 15, "robot_state OPERATING")
            write_outputs(m, regmap, layout)
            cli = drcli_get(g.sim, layout, CARRIED[layout])
            compared = 0
            for e in regmap.entries:
                asm = e["name"].split(".")[0].split("[")[0]
                if asm not in CARRIED["combined"] or e["type"].startswith("INT16 = REAL"):
                    continue
                mb = modbus_value(m, e)
                if mb is None:
                    continue
                if asm not in CARRIED[layout]:
                    # not carried by this layout: never received, reads 0
                    assert not mb, (e["name"], mb)
                    continue
                assert e["name"] in cli, e["name"]
                assert same(mb, cli[e["name"]]), (e["name"], mb, cli[e["name"]])
                compared += 1
            # every leaf of the carried assemblies that the map shows
            assert compared >= (180 if layout == "gpr_only" else 350), compared
            assert cli["int_out[2]"] == -123456 and cli["float_out[1]"] == 2.5
            assert cli["bit_out[3]"] is True
            if layout == "gpr_only":
                # io_control is not carried: nothing would send a write
                write = struct.pack(">BHH", 0x05, regmap.addr("CO", "io_control.cb_do[1]"),
                                    0xFF00)
                assert m.exception(write) == EX_ILLEGAL_ADDRESS
            else:
                assert cli["io_state.cb_do[2]"] is True
        assert "refused" not in g.sim.log()


def log_line(g, text, seconds=20):
    g.log_wait(text, seconds)
    return next(x for x in g.log().splitlines() if text in x)


def test_size_mismatch_names_both_sizes():
    """The gateway's plan is combined (T->O 478, O->T 218 bytes with their
    headers), the adapter offers gpr_only (200 + 6 = 206 O->T): the Forward
    Open is refused with 0x0109, and the log names the plan's sizes and
    the adapter's."""
    with running("layout-mismatch", sim_args=("--layout", "gpr_only"),
                 robot="layout = combined\n", start=False) as g:
        g.start(wait_link=False)
        line = log_line(g, "0x0109")
        assert "input (layout combined)" in line, line
        assert "T->O 478 bytes (476 data)" in line and "O->T 218 bytes (212 data)" in line, line
        assert "the robot's 206 bytes" in line, line


def test_explicit_size_mismatch_names_both_sizes():
    """Explicit mode: the input instance answers with 200 bytes, the plan
    says 476; the link stays down and the log says both."""
    with running("layout-mismatch-explicit", sim_args=("--layout", "gpr_only"),
                 robot="layout = combined\nmode = explicit\n", start=False) as g:
        g.start(wait_link=False)
        line = log_line(g, "200 bytes, the plan's input_size is 476")
        assert "get input (instance 100)" in line, line
        assert g.status()[1] != 2  # link_state: never up


def links_with(section, name, sim):
    """drgatewayd with the [robot] section a probe printed (its lines after
    the header; host and port are the test's) brings the link up."""
    robot = "".join(x + "\n" for x in section if x and not x.startswith(("host", "tcp_port")))
    g = Gateway(name, sim, robot=robot)
    try:
        g.start()  # waits for the link
    finally:
        g.kill()


@pytest.mark.parametrize("layout", ["per_assembly", "combined", "gpr_only"])
def test_probe_prints_a_plan_that_links(layout):
    """`drcli probe` against drsim in each layout: read-only (drsim sees no
    Set and no Forward Open), names the layout, and the [robot] section it
    prints brings drgatewayd's link up."""
    sim = Drsim("probe-%s" % layout, "--layout", layout, "-v").start()  # every request
    try:
        out = subprocess.run([str(DRCLI), "-H", SIM_ADDR, "--port", str(sim.tcp), "probe"],
                             capture_output=True, text=True, timeout=timeout(30))
        assert out.returncode == 0, out.stdout + out.stderr
        assert "layout: %s\n" % layout in out.stdout, out.stdout
        section = out.stdout.split("[robot arm1]\n", 1)[1].splitlines()
        assert "layout = %s" % layout in section
        if layout != "per_assembly":
            size = {"combined": (476, 212), "gpr_only": (200, 200)}[layout]
            assert "input_size = %d" % size[0] in section, section
            assert "output_size = %d" % size[1] in section, section
            assert "input_instance = 100" in section and "output_instance = 150" in section
        log = sim.log()
        assert "request 0x0E class 0x04" in log, log[-2000:]  # it did ask
        for svc in ("0x10", "0x54", "0x5B"):  # Set_Attribute_Single, Forward Opens
            assert "request %s " % svc not in log, log[-2000:]
        links_with(section, "probe-%s" % layout, sim)
    finally:
        sim.kill()


def probe(sim, *args):
    return subprocess.run([str(DRCLI), "-H", SIM_ADDR, "--port", str(sim.tcp), "probe"]
                          + list(args), capture_output=True, text=True,
                          timeout=timeout(60))


def opened_then_closed(sim):
    """drsim's connections, once drcli's session ended: each one opened
    was closed by Forward Close before the next opened, none applied O->T
    data, none is left. Returns the "connection open" lines."""
    wait_for(lambda: "session ended" in sim.log(), 10, "drcli's session to end")
    events = [x for x in sim.log().splitlines()
              if "connection open" in x or " closed (" in x and "connection 0x" in x]
    assert len(events) % 2 == 0, events
    for i in range(0, len(events), 2):
        assert "connection open" in events[i], events
        assert "closed (forward close)" in events[i + 1], events
        assert " 0 applied" in events[i + 1], events
    return events[0::2]


@pytest.mark.parametrize("layout", ["per_assembly", "combined", "gpr_only"])
def test_probe_open_finds_the_sizes_get_does_not_give(layout):
    """drsim --no-get-assembly answers no Get on its assemblies. The
    read-only probe finds no layout and says --open would try; with
    --open, a Forward Open trial per instance whose size is unknown finds
    the layout, and each connection it opened is closed by Forward Close
    before the next Forward Open (drsim's log: opens and closes alternate,
    the same number of each, none left), with no O->T data applied (the
    trial's O->T is idle). The printed [robot] section links drgatewayd."""
    sim = Drsim("probe-open-%s" % layout, "--layout", layout, "--no-get-assembly").start()
    try:
        out = probe(sim)
        assert out.returncode == 4, out.stdout + out.stderr
        assert "layout: none matches" in out.stdout and "probe --open" in out.stdout
        assert "connection open" not in sim.log() and "forward open" not in sim.log()
        out = probe(sim, "--open", "--udp-port", str(free_port("0.0.0.0", tcp=False)))
        assert out.returncode == 0, out.stdout + out.stderr
        assert "layout: %s\n" % layout in out.stdout, out.stdout
        assert "forward open trial: " in out.stdout
        section = out.stdout.split("[robot arm1]\n", 1)[1].splitlines()
        if layout != "per_assembly":
            size = {"combined": (476, 212), "gpr_only": (200, 200)}[layout]
            assert "input_size = %d" % size[0] in section, section
            assert "output_size = %d" % size[1] in section, section
        # what the trial opened, drsim saw closed, each before the next open
        opens = opened_then_closed(sim)
        # gpr_only: the sizes asked for (the combined ones) are refused with
        # 0x0109 naming drsim's, nothing opens; the others open and close
        assert bool(opens) == (layout != "gpr_only"), sim.log()[-3000:]
        assert ("0x0109" in sim.log()) == (layout == "gpr_only"), sim.log()[-3000:]
        links_with(section, "probe-open-%s" % layout, sim)
    finally:
        sim.kill()


def test_probe_open_closes_an_open_whose_reply_was_lost():
    """drsim opens the trial's first connection but its reply is lost
    (--lose-forward-open-reply 1): the probe's open times out, the session
    is reset, and in the next session the open is closed by its connection
    triad before anything else; the trial is made once more, answered this
    time, and the layout found. drsim's log: two opens, each closed by
    Forward Close, nothing left."""
    sim = Drsim("probe-open-lost", "--layout", "combined", "--no-get-assembly",
                "--lose-forward-open-reply", "1").start()
    try:
        out = probe(sim, "--open", "--udp-port", str(free_port("0.0.0.0", tcp=False)))
        assert out.returncode == 0, out.stdout + out.stderr
        assert "layout: combined\n" in out.stdout, out.stdout
        assert "asked 476 bytes: no answer" in out.stdout, out.stdout
        assert "forward open reply not sent" in sim.log()
        opens = opened_then_closed(sim)
        assert len(opens) == 3, opens  # the lost one, its repeat, the output's
        assert sim.log().count(" registered by ") == 2  # a new session
    finally:
        sim.kill()


@pytest.mark.parametrize("layout,name", [
    ("combined", "combined T->O (6 assemblies, 476 bytes)"),
    ("gpr_only", "gpr_only T->O (3 assemblies, 200 bytes)")])
def test_combined_connection_named_for_what_it_carries(layout, name):
    """The console's /api/v1 and /metrics name a combined layout's one
    connection for what it carries; `assembly` stays the first assembly
    it carries (as before: label compat, docs/http.md), the metrics add
    `connection`; the text passes promtool."""
    port, sect = http_section()
    with running("layout-name-%s" % layout, sim_args=("--layout", layout), robot="layout = %s\n"
                 % layout, extra=sect) as g:
        wait_for(lambda: g.listening(port), 10, "the console's port")
        st = json.loads(get(port, "/api/v1/status")[2])
        conns = st["robots"][0]["connections"]
        first = "io_state" if layout == "combined" else "bit_out"
        assert [(c["assembly"], c["name"]) for c in conns] == [(first, name)], conns
        text = get(port, "/metrics")[2]
        got = {k[1] for k in samples(text) if k[0] == "drgate_link_packets_received_total"}
        assert got == {frozenset({("robot", "r0"), ("assembly", first),
                                  ("connection", name)})}, got
        if os.access(PROMTOOL, os.X_OK):
            r = subprocess.run([PROMTOOL, "check", "metrics"], input=text, text=True,
                               capture_output=True, timeout=timeout(30))
            assert r.returncode == 0, r.stdout + r.stderr
