# SPDX-License-Identifier: MIT
"""The console's pages in a real browser (issue 21): Debian's chromium,
headless, driven by selenium through Debian's chromium-driver, against
drgatewayd with [http] in front of drsim.

One test, so one browser and one gateway, in this order (a browser takes
seconds to start on a loaded machine, and pytest-xdist would give separate
tests separate workers):

- the robot page's value of joint_state.position[1] is the robot's: it lies
  between two `drcli get` reads of the same robot taken around it (the
  motion between them), checked on a stretch where the joint moves one way;
- typing in the filter box leaves only the rows that match, and clearing it
  brings all back;
- the overview shows a robot's link down with its reason in words when
  drsim is killed, the reason being the daemon's own (the API's and the
  log's), and up again when drsim is back; a robot that was never reachable
  shows "connection refused".

With GW_CONSOLE_SHOTS=DIR (make console-shots) the pages are also saved as
DIR/console-overview.png and DIR/console-robot.png.

SKIPPED with the banner of tests/skip.sh where chromium, its driver or
selenium is missing or chromium cannot start (a failure under CI).
"""
import contextlib
import json
import os
import shutil
import subprocess
import time

import pytest

import gwlib
from gwlib import SIM_ADDR, timeout, wait_for

CLI = gwlib.DRCLI
NAME = "console_browser"
SHOTS = os.environ.get("GW_CONSOLE_SHOTS", "")
JOINT = "joint_state.position[1]"
VELOCITY = "joint_state.velocity[1]"


class ConsoleGateway(gwlib.Gateway):
    """The gateway with [http] on a free port; its robots named arm1 and
    arm2 (the names a reader of the screenshots would see)."""

    def config_text(self, *a, **kw):
        text = super().config_text(*a, **kw)
        for i in range(len(self.sims)):
            text = text.replace("[robot r%d]" % i, "[robot arm%d]" % (i + 1))
        return text + "\n[http]\nlisten = %s\nport = %d\n" % (gwlib.GW_ADDR, self.http_port)

    @property
    def url(self):
        return "http://%s:%d" % (gwlib.GW_ADDR, self.http_port)


class NoRobot:
    """A robot's address where nothing listens: its link stays down,
    refused."""

    def __init__(self):
        self.tcp = gwlib.free_port(SIM_ADDR)
        self.udp = gwlib.free_port(SIM_ADDR, tcp=False)


def browser():
    """A headless chromium through chromedriver, or the SKIPPED banner."""
    try:
        from selenium import webdriver
        from selenium.common.exceptions import WebDriverException
        from selenium.webdriver.chrome.options import Options
        from selenium.webdriver.chrome.service import Service
    except ImportError as e:
        gwlib.skip("console in a browser", "no selenium in the venv (make test-deps): %s" % e)
    chromium = shutil.which("chromium")
    driver = shutil.which("chromedriver")
    if chromium is None or driver is None:
        gwlib.skip("console in a browser", "Debian's chromium and chromium-driver are not "
                   "installed (make test-deps)")
    o = Options()
    o.binary_location = chromium
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1280,900", "--hide-scrollbars", "--force-device-scale-factor=1"):
        o.add_argument(arg)
    try:
        d = webdriver.Chrome(service=Service(driver), options=o)
    except WebDriverException as e:
        gwlib.skip("console in a browser", "chromium cannot run here: %s" % str(e).strip()[:300])
    d.set_page_load_timeout(timeout(30))
    return d


@contextlib.contextmanager
def console_cell(name, **gateway_args):
    """drsim, a gateway with the console (robot arm1 on drsim, arm2 on
    nobody) linked, and a chromium driving it (g.driver)."""
    sim = gwlib.Drsim(name).start()
    g = ConsoleGateway(name, [sim, NoRobot()], **gateway_args)
    g.sim = sim
    g.http_port = gwlib.free_port(gwlib.GW_ADDR, udp=False)
    d = None
    try:
        g.start(wait_link=False)
        g.wait_link(True, unit=1)
        d = browser()
        g.driver = d
        yield g
    finally:
        if d is not None:
            d.quit()
        g.kill()
        sim.kill()


@pytest.fixture
def console():
    with console_cell(NAME) as g:
        yield g


def js(d, script, *args):
    return d.execute_script(script, *args)


def api(g, path):
    import urllib.request
    with urllib.request.urlopen(g.url + path, timeout=timeout(5)) as r:
        return json.loads(r.read().decode())


def cli_get(g, *paths):
    out = subprocess.run([str(CLI), "-H", SIM_ADDR, "--port", str(g.sim.tcp), "get", "--json"]
                         + list(paths), capture_output=True, text=True, timeout=timeout(10))
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def cell(d, path):
    """The robot page's value cell of path: (text, when the page got it, in
    ms since 1970 as the browser's clock says)."""
    return js(d, "var c = document.querySelector('td.v[data-value=\"' + arguments[0] + '\"]');"
                 "return c ? [c.textContent, Number(c.getAttribute('data-updated') || 0)] : null;",
              path)


def visible_paths(d):
    return js(d, "return Array.from(document.querySelectorAll('#fields tr[data-path]'))"
                 ".filter(function (r) { return !r.hidden && r.offsetParent !== null; })"
                 ".map(function (r) { return r.getAttribute('data-path'); });")


def shot(d, name):
    if SHOTS:
        os.makedirs(SHOTS, exist_ok=True)
        d.save_screenshot(os.path.join(SHOTS, name))


def robot_page_value_is_the_robots(console):
    g, d = console, console.driver
    d.get(g.url + "/robot/arm1")
    wait_for(lambda: (cell(d, JOINT) or [""])[0] != "", 20, "the robot page's first values")
    # the map is the gateway's: the joint's REAL and scaled views
    mb = js(d, "return document.querySelector('tr[data-path=\"%s\"] td.mb').textContent;" % JOINT)
    assert "IR 200-201 30201 REAL abcd" in mb and "IR 1200 31201 INT16 \u00d710" in mb, mb
    assert js(d, "return document.getElementById('link').textContent;") == "up"
    tries = []
    for _ in range(8):
        start_ms = time.time() * 1000
        before = cli_get(g, JOINT, VELOCITY)
        # a value the page got after that read began (the gateway's own is
        # at most an RPI old): the robot's position somewhere between the
        # two reads
        wait_for(lambda: (cell(d, JOINT) or ["", 0])[1] > start_ms + 300, 20,
                 "a value newer than the first drcli read")
        text, _ = cell(d, JOINT)
        after = cli_get(g, JOINT, VELOCITY)
        page = float(text)
        lo, hi = sorted((before[JOINT], after[JOINT]))
        tries.append((before[JOINT], page, after[JOINT], before[VELOCITY], after[VELOCITY]))
        # Moving one way all along (the velocity's sign the same at both
        # ends: the joint's period is seconds, the window a fraction), the
        # position between the reads lies between theirs. A margin of
        # 50 ms of motion for the clocks and the transports.
        if before[VELOCITY] * after[VELOCITY] > 0:
            margin = 0.05 * max(abs(before[VELOCITY]), abs(after[VELOCITY])) + 1e-3
            assert lo - margin <= page <= hi + margin, \
                "page %s not within drcli's %s .. %s (+-%.3f)" % (page, lo, hi, margin)
            break
    else:
        pytest.fail("the joint turned round in every try: %s" % tries)
    # the enum's name, as the map gives it
    state = js(d, "return document.querySelector('td.v[data-value=\"io_state.robot_state\"]')"
                  ".textContent;")
    assert state == "%s (%d)" % ("OPERATING", 2), state


def robot_page_filter(console):
    g, d = console, console.driver
    if not d.current_url.endswith("/robot/arm1"):
        d.get(g.url + "/robot/arm1")
    wait_for(lambda: len(visible_paths(d)) > 300, 20, "the robot page's rows")
    total = len(visible_paths(d))
    assert total == len(api(g, "/api/v1/robots/arm1/map")["fields"])
    box = d.find_element("id", "filter")
    box.send_keys("joint_state.position")
    wait_for(lambda: len(visible_paths(d)) < total, 10, "the filter to act")
    rows = visible_paths(d)
    assert rows == ["joint_state.position[%d]" % i for i in range(1, 7)], rows
    groups = js(d, "return Array.from(document.querySelectorAll('#fields tr.group'))"
                   ".filter(function (r) { return !r.hidden; })"
                   ".map(function (r) { return r.getAttribute('data-group'); });")
    assert groups == ["joint_state"], groups
    # an address finds its field: 30201 is joint_state.position[1]'s first register
    box.clear()
    box.send_keys("30201")
    wait_for(lambda: visible_paths(d) == [JOINT], 10, "the filter by reference")
    # the trend, for the picture, with the joints' rows beside it
    box.clear()
    box.send_keys("joint_state.")
    wait_for(lambda: 0 < len(visible_paths(d)) < total, 10, "the filter to act")
    # a few seconds of trend in the picture (half a minute for the docs')
    time.sleep(28 if SHOTS else 1)
    shot(d, "console-robot.png")
    js(d, "var f = document.getElementById('filter'); f.value = '';"
          "f.dispatchEvent(new Event('input'));")
    wait_for(lambda: len(visible_paths(d)) == total, 10, "every row back")


def overview_robot(d, name):
    return js(d, "var r = document.querySelector('#robots tr[data-robot=\"' + arguments[0] + '\"]');"
                 "if (!r) return null;"
                 "return {link: r.querySelector('[data-field=link]').getAttribute('data-state'),"
                 " reason: r.querySelector('[data-field=reason]').textContent};", name)


def overview_link_down_and_up(console):
    g, d = console, console.driver
    d.get(g.url + "/")
    wait_for(lambda: (overview_robot(d, "arm1") or {}).get("link") == "up", 20, "arm1 up")
    # the robot nobody answers for: refused, in words
    wait_for(lambda: (overview_robot(d, "arm2") or {}).get("reason") == "connection refused",
             20, "arm2's reason")
    assert overview_robot(d, "arm2")["link"] != "up"
    assert api(g, "/api/v1/robots/arm2")["reason"] == "connection refused"
    assert js(d, "return document.getElementById('gw-version').textContent;") == \
        api(g, "/api/v1/status")["version"]
    # each connection of arm1 with its state and counters
    conns = js(d, "return Array.from(document.querySelectorAll("
                  "'#connections .conns[data-robot=\"arm1\"] .conn')).map(function (c) {"
                  " return c.textContent; });")
    assert len(conns) == len(api(g, "/api/v1/robots/arm1")["connections"]) == 6, conns
    assert all("connected" in c and "rx " in c for c in conns), conns
    shot(d, "console-overview.png")

    mark = len(g.log())
    g.sim.kill()
    t0 = time.monotonic()
    wait_for(lambda: overview_robot(d, "arm1")["link"] == "down" and
             overview_robot(d, "arm1")["reason"] != "", 20, "arm1 down with a reason")
    took = time.monotonic() - t0
    # the daemon's own words: the API says the same (once the page has the
    # latest: "timed out" turns into "connection refused" as drsim stays
    # away), and so did the log
    reason = wait_for(lambda: overview_robot(d, "arm1")["reason"] ==
                      api(g, "/api/v1/robots/arm1")["reason"] and
                      overview_robot(d, "arm1")["reason"], 20, "the page's reason = the API's")
    assert reason in g.log()[mark:], (reason, g.log()[mark:])
    print("overview: arm1 down (%s) %.2f s after drsim was killed" % (reason, took))

    g.sim.start(same_ports=True)
    wait_for(lambda: overview_robot(d, "arm1")["link"] == "up", 30, "arm1 up again")
    assert overview_robot(d, "arm1")["reason"] == ""
    # the log on the page has the link's events
    wait_for(lambda: "link up" in js(d, "return document.getElementById('log').textContent;"),
             20, "the link's events in the page's log")


def test_console_in_a_browser(console):
    for phase in (robot_page_value_is_the_robots, robot_page_filter, overview_link_down_and_up):
        t0 = time.monotonic()
        phase(console)
        print("%s: %.1f s" % (phase.__name__, time.monotonic() - t0))
