# SPDX-License-Identifier: MIT
"""drgatewayd's `eds` key of [robot] (issue 31): the plan an EDS gives
(layout, instances, sizes, configuration instance, heartbeats, rpi_ms),
read with drcli eds's reader, as the robot's defaults; keys in the section
win; an EDS's errors are told as its FILE:LINE at the config line of the
key, by --check-config, at start and at reload; and drgatewayd links with
drsim through drsim's own EDS and through a vendor-style combined one."""
import shutil
import signal

import pytest

from gwlib import (EXIT_CONFIG, EXIT_OK, LOGDIR, TOP, running, wait_for)
from test_config import run, write

VENDOR = TOP / "tests" / "cli" / "eds" / "vendor_robot.eds"  # combined, RPI 2..100 ms
DRSIM_EDS = TOP / "sim" / "drsim.eds"
ROBOT = "[robot a]\nhost = 127.0.0.2\n"


def eds_copy(name, text=None, src=VENDOR):
    """An EDS beside the test's configuration files, changed if text says."""
    LOGDIR.mkdir(parents=True, exist_ok=True)
    p = LOGDIR / ("%s.eds" % name)
    if text is None:
        shutil.copyfile(src, p)
    else:
        p.write_text(text)
    return p


def check(name, text):
    p = write(name, text)
    return p, run("--check-config", p)


# (robot keys after host, the config line of the error, words)
BAD = {
    # the reader's own error, at the EDS's line, and the key's line
    "malformed": ("eds = %s\n" % (TOP / "tests/cli/eds/malformed.eds"), 3,
                  ["eds %s:10: " % (TOP / "tests/cli/eds/malformed.eds"),
                   "';' missing"]),
    "unclosed": ("rpi_ms = 8\neds = %s\n" % (TOP / "tests/cli/eds/unclosed.eds"), 4,
                 ["unclosed.eds:2: ", "string not closed"]),
    "missing": ("eds = no-such.eds\n", 3, ["no-such.eds: cannot open"]),
    # rpi_ms outside the EDS's RPI range (Param1/Param2: 2000..100000 us)
    "rpi_range": ("eds = %s\nrpi_ms = 500\n" % VENDOR, 4,
                  ["rpi_ms 500 is outside the robot's RPI range 2..100 ms",
                   "vendor_robot.eds:83, Connection1"]),
    # a key of the section wins, and is checked as written
    "override_size": ("eds = %s\ninput_size = 480\n" % VENDOR, 4,
                      ["input_size 480 does not add up", "= 476 bytes"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_eds_errors(case):
    keys, line, words = BAD[case]
    p, r = check("eds-" + case, ROBOT + keys)
    assert r.returncode == EXIT_CONFIG, r
    msg = r.stderr.strip()
    assert len(msg.splitlines()) == 1, msg
    assert ("%s:%d: robot 'a': " % (p, line)) in msg, msg
    for w in words:
        assert w in msg, (w, msg)


def test_eds_matching_no_layout():
    """An EDS whose plan has sizes of no layout: refused at the key, naming
    the EDS's connection; with layout set in the section it is taken."""
    eds = eds_copy("eds-odd", VENDOR.read_text().replace("476", "400"))
    p, r = check("eds-odd", ROBOT + "eds = %s\n" % eds)
    assert r.returncode == EXIT_CONFIG
    assert "%s:3: " % p in r.stderr and "eds %s:83: its sizes match no layout" % eds \
        in r.stderr and "input 400, output 212 bytes" in r.stderr, r.stderr
    p, r = check("eds-odd-layout", ROBOT + "layout = per_assembly\neds = %s\n" % eds)
    assert r.returncode == EXIT_OK, r.stderr


def test_eds_relative_to_the_config_file():
    eds_copy("eds-rel")
    p, r = check("eds-rel", ROBOT + "eds = eds-rel.eds\n")
    assert r.returncode == EXIT_OK, r.stderr


@pytest.mark.parametrize("case", ["drsim", "vendor"])
def test_eds_links(case, regmap):
    """drsim (per_assembly) with sim/drsim.eds, drsim --layout combined with
    the vendor-style EDS (one input, one output assembly, RPI 2..100 ms,
    default 8): the link comes up with the EDS's plan only (no layout key),
    the log names the layout, and a register written through Modbus is
    echoed by the robot. Then the EDS is made malformed and a reload is
    refused with its FILE:LINE, the link kept."""
    eds = eds_copy("eds-link-%s" % case, src=DRSIM_EDS if case == "drsim" else VENDOR)
    sim_args = ("--still",) if case == "drsim" else ("--layout", "combined", "--still")
    robot = "eds = %s\n" % eds
    with running("eds-link-%s" % case, sim_args=sim_args, robot=robot) as g:
        if case == "vendor":  # the EDS's plan: points, sizes, its default RPI
            assert "layout combined: input 100 (476 bytes), output 150 (212 bytes), " \
                "RPI 8 ms" in g.log(), g.log()[-2000:]
        else:
            assert "layout" not in g.log().split("link up")[0], g.log()[-2000:]
        with g.raw() as m:
            m.write_regs(regmap.addr("HR", "int_in[0]"), [0, 4242])
            wait_for(lambda: m.read(4, regmap.addr("IR", "int_out[0]"), 2) == [0, 4242], 10,
                     "int_out[0] echoing int_in[0]")
        text = eds.read_text()
        eds.write_text(text.replace("MajRev = ", "MajRev ", 1))
        mark = len(g.log())
        g.signal(signal.SIGHUP)
        g.log_wait("reload refused", 20, start=mark)
        assert "%s:" % eds in g.log()[mark:], g.log()[mark:]
        assert g.alive() and g.status()[1] == 2  # still linked
