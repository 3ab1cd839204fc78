# SPDX-License-Identifier: MIT
"""Configuration errors name FILE:LINE and exit 78, both for --check-config
and at start-up; the command line's other exit codes."""
import re
import socket
import subprocess

import pytest

from gwlib import (DRGATEWAYD, EXIT_CONFIG, EXIT_OK, EXIT_RUNTIME, EXIT_USAGE, GW_ADDR, LOGDIR,
                   TOP, free_port, running, timeout)

ROBOT = "[robot a]\nhost = 127.0.0.2\n"

# (file text, line, words the message must contain)
BAD = {
    "word_order": ("[modbus]\nport = 5020\nword_order = abdc\n" + ROBOT, 3,
                   ["word_order 'abdc' invalid", "abcd, cdab, badc, dcba"]),
    "unknown_key": ("[modbus]\nwordorder = abcd\n" + ROBOT, 2,
                    ["unknown key 'wordorder'", "did you mean 'word_order'"]),
    "no_host": ("[robot a]\ntcp_port = 44818\n", 1, ["no host"]),
    "unit_clash": (ROBOT + "\n[robot b]\nhost = 127.0.0.3\n", 4, ["unit_id 1", "robot 'a'"]),
    "port_range": ("[modbus]\nport = 70000\n" + ROBOT, 2, ["port 70000 out of range",
                                                            "1..65535"]),
    "number_unit": (ROBOT + "rpi_ms = 10ms\n", 3, ["rpi_ms '10ms' invalid"]),
    "gpio_field": (ROBOT + "[gpio x]\nchip = gpiochip0\nline = 3\ndirection = output\n"
                   "field = io_state.cb_dl[3]\n", 7, ["io_state.cb_dl[3]", "io_state.cb_di[3]"]),
    "gpio_input_t2o": (ROBOT + "[gpio x]\nchip = gpiochip0\nline = 3\ndirection = input\n"
                       "field = io_state.cb_do[3]\n", 7, ["input cannot drive"]),
    "indented": (ROBOT + "  port = 5\n", 3, ["whitespace"]),
    "no_robot": ("[modbus]\nport = 5020\n", 2, ["no robot section"]),
    # the docs' example config_instance and the default listen-only heartbeat
    "config_is_heartbeat": (ROBOT + "config_instance = 199\nopen.task_state = listen_only\n", 3,
                            ["config_instance 199 is also listen_only_heartbeat",
                             "its default", "set listen_only_heartbeat"]),
    "allow_shadowed": ("[modbus]\nallow = 127.0.0.0/8 ro\nallow = 127.0.0.1 rw\n" + ROBOT, 3,
                       ["never matches", "line 2"]),
    "allow_host_bits": ("[modbus]\nallow = 127.0.0.1/8\n" + ROBOT, 2, ["127.0.0.0/8"]),
    "on_link_loss": ("[modbus]\non_link_loss = keep\n" + ROBOT, 2,
                     ["hold, zero, exception"]),
    "bool": ("[modbus]\nkeepalive = true\n" + ROBOT, 2, ["yes, no"]),
    "section": (ROBOT + "[robots b]\nhost = 1.2.3.4\n", 3, ["robots"]),
    "instance": (ROBOT + "instance.io_state = 101\ninstance.dr1 = 102\n", 4, ["instance"]),
    "timeout_mult": (ROBOT + "timeout_multiplier = 8\n", 3, ["0..7"]),
    # a layout whose sizes do not add up (issue 31)
    "layout_size": (ROBOT + "layout = combined\ninput_size = 480\n", 4,
                    ["input_size 480 does not add up", "= 476 bytes", "set input_size to 476"]),
    "layout_gpr_size": (ROBOT + "layout = gpr_only\noutput_size = 32\n", 4,
                        ["output_size 32 does not add up", "= 200 bytes"]),
    "layout_key": (ROBOT + "input_instance = 100\n", 3,
                   ["applies to layout combined or gpr_only"]),
}


def write(name, text):
    LOGDIR.mkdir(parents=True, exist_ok=True)
    p = LOGDIR / ("cfg-%s.ini" % name)
    p.write_text(text)
    return p


def run(*args):
    return subprocess.run([str(DRGATEWAYD)] + [str(a) for a in args], capture_output=True,
                          text=True, timeout=timeout(30), stdin=subprocess.DEVNULL)


@pytest.mark.parametrize("case", sorted(BAD))
def test_check_config_error(case):
    text, line, words = BAD[case]
    p = write(case, text)
    r = run("--check-config", p)
    assert r.returncode == EXIT_CONFIG, r
    msg = r.stderr.strip()
    assert len(msg.splitlines()) == 1, msg
    assert ("%s:%d: " % (p, line)) in msg, msg
    for w in words:
        assert w in msg, (w, msg)
    assert r.stdout == ""


@pytest.mark.parametrize("case", ["word_order", "no_host", "gpio_field", "allow_shadowed"])
def test_start_with_bad_config(case):
    """The daemon refuses to start with the same message and status."""
    text, line, words = BAD[case]
    p = write("start-" + case, text)
    r = run("-c", p)
    assert r.returncode == EXIT_CONFIG
    assert ("%s:%d: " % (p, line)) in r.stderr
    for w in words:
        assert w in r.stderr


def test_missing_file():
    p = LOGDIR / "no-such-file.ini"
    for args in (("--check-config", p), ("-c", p)):
        r = run(*args)
        assert r.returncode == EXIT_CONFIG
        assert "%s: cannot open" % p in r.stderr


def test_check_config_good():
    p = write("good", "[modbus]\nport = 5020\nword_order = dcba\n" + ROBOT +
              "[robot b]\nhost = 127.0.0.3\nunit_id = 2\n")
    r = run("--check-config", p)
    assert r.returncode == EXIT_OK, r.stderr
    assert "valid (2 robot(s), 0 GPIO line(s))" in r.stdout


@pytest.mark.parametrize("example", sorted(
    p.name for p in (TOP / "gateway" / "examples").glob("*.ini")))
def test_examples_are_valid(example):
    r = run("--check-config", TOP / "gateway" / "examples" / example)
    assert r.returncode == EXIT_OK, r.stderr


def test_usage_errors():
    for args in (("--bogus",), ("extra",), ("-c",)):
        r = run(*args)
        assert r.returncode == EXIT_USAGE, (args, r)
    assert run("--help").returncode == EXIT_OK
    r = run("--version")
    assert r.returncode == EXIT_OK and r.stdout.startswith("drgatewayd ")


# A file with one unknown key in each section, which lists the keys it takes.
UNKNOWN_KEY_IN = {
    "daemon": "[daemon]\n",
    "modbus": "[modbus]\n",
    "robot": ROBOT,
    "gpio": ROBOT + "[gpio g]\n",
    "modbus_rtu": ROBOT + "[modbus_rtu l]\n",
    "mqtt": ROBOT + "[mqtt]\n",
}


@pytest.mark.parametrize("section", sorted(UNKNOWN_KEY_IN))
def test_help_config_lists_the_loaders_keys(section):
    """--help-config SECTION (the key tables of docs/configuration.md) names
    exactly the keys the loader takes, in the order its messages list
    them."""
    r = run("--help-config", section)
    assert r.returncode == EXIT_OK, r.stderr
    assert r.stdout.startswith("| key | default | allowed | meaning |\n")
    keys = re.findall(r"^\| `([^`]+)` \|", r.stdout, re.M)
    # With a path as long as the loader takes (255 bytes): CI's checkout is
    # deeper than a developer's, and the message (path first) was cut there.
    name = "cfg-help-%s.ini" % section
    deep = LOGDIR / ("d" * max(1, 255 - len(str(LOGDIR)) - len(name) - 2))
    deep.mkdir(parents=True, exist_ok=True)
    p = deep / name
    assert len(str(p)) <= 255
    p.write_text(UNKNOWN_KEY_IN[section] + "no_such_key = 1\n")
    c = run("--check-config", p)
    assert c.returncode == EXIT_CONFIG
    m = re.search(r"unknown key 'no_such_key' in \[.*\] \(allowed: (.*)\)$", c.stderr.strip())
    assert m, c.stderr
    assert keys == m.group(1).split(", ")


def test_help_config_unknown_section():
    r = run("--help-config", "robots")
    assert r.returncode == EXIT_USAGE
    assert r.stdout == ""
    assert "no section [robots]" in r.stderr and "[robot NAME]" in r.stderr


def test_runtime_error_exit_1():
    """A valid configuration that cannot be served (the Modbus port is
    taken) is a runtime error: exit 1, and the reason on stderr."""
    busy = socket.socket()
    busy.bind((GW_ADDR, 0))
    busy.listen(1)
    try:
        port = busy.getsockname()[1]
        p = write("busy", "[modbus]\nlisten = %s\nport = %d\n[robot a]\nhost = 127.0.0.2\n"
                  "tcp_port = %d\nlocal_address = 127.0.0.1\nlocal_udp_port = %d\n"
                  % (GW_ADDR, port, free_port("127.0.0.2"), free_port(GW_ADDR, tcp=False)))
        r = run("-c", p)
        assert r.returncode == EXIT_RUNTIME
        assert "cannot listen on %s:%d" % (GW_ADDR, port) in r.stderr
    finally:
        busy.close()


def test_gpio_chip_missing_exit_1():
    p = write("nochip", "[modbus]\nlisten = 127.0.0.1\nport = %d\n" % free_port(GW_ADDR) +
              ROBOT + "tcp_port = %d\nlocal_address = 127.0.0.1\nlocal_udp_port = %d\n"
              % (free_port("127.0.0.2"), free_port(GW_ADDR, tcp=False)) +
              "[gpio lamp]\nchip = no-such-gpio-chip\nline = 0\ndirection = output\n"
              "field = io_state.cb_do[1]\n")
    assert run("--check-config", p).returncode == EXIT_OK
    r = run("-c", p)
    assert r.returncode == EXIT_RUNTIME
    assert "gpio lamp" in r.stderr


def test_log_level_from_config():
    with running("cfg-loglevel", start=False, extra="[daemon]\nlog_level = warning\n") as g:
        g.start(wait_link=False)
        g.wait_link(True)
        with g.raw() as m:
            m.read(4, 0, 1)
        assert "info:" not in g.log()
        rc, _ = g.stop()
        assert rc == 0


def test_docs_name_the_default_config_path():
    """The configuration file the docs, the manual pages and the README
    name is the one the daemon reads by default and the systemd unit
    passes (docs/configuration.md once said /etc/drgate/gateway.ini)."""
    import re
    usage = subprocess.run([str(DRGATEWAYD), "--help"], capture_output=True, text=True).stdout
    default = re.search(r"\(default (/\S+\.ini)\)", usage).group(1)
    unit = (TOP / "gateway" / "drgatewayd.service").read_text()
    assert re.search(r"^ExecStart=\S+ -c (\S+)$", unit, re.M).group(1) == default
    texts = sorted((TOP / "docs").glob("*.md")) + sorted((TOP / "man").glob("*.[18]")) + \
        [TOP / "README.md"]
    named = {(t.name, p) for t in texts for p in re.findall(r"/etc/drgate/[\w.-]+\.ini",
                                                          t.read_text())}
    assert ("configuration.md", default) in named, named
    assert all(p == default for _, p in named), sorted(named)


def test_opcua_section_in_either_build():
    """An [opcua] section: a daemon built with open62541 checks it (a
    non-loopback endpoint with SecurityPolicy None refused at its line); one
    built without (Debian 12) refuses the section itself at its header's
    line, saying why, at --check-config as at start."""
    p = write("opcua_either", ROBOT + "\n[opcua]\nlisten = 192.0.2.1\n")
    r = run("--check-config", p)
    assert r.returncode == EXIT_CONFIG, r
    if "built without OPC UA" in r.stderr:
        assert "%s:4: [opcua]: this drgatewayd was built without OPC UA" % p in r.stderr
        assert "libopen62541-1.4-dev" in r.stderr
        s = run("-c", p)
        assert s.returncode == EXIT_CONFIG and "%s:4: [opcua]" % p in s.stderr, s
    else:
        assert "%s:5: [opcua] listen 192.0.2.1 with security_policies None" % p in r.stderr
