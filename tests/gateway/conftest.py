# SPDX-License-Identifier: MIT
"""pytest set-up for tests/gateway: a time limit per test, processes that
never outlive the run, and the "passed failed label" line `make check`
sums up (GW_RESULTS, see tests/run-tests.sh; several files separated by
':' each get the line: make coverage's run of the suite counts both in the
coverage build's results and in make check's).

Under pytest-xdist (`-n 2`), the controller clears the old logs before the
workers start, and reads the sanitizer reports and writes the results line
after they are done; each worker only stops its own processes."""
import os
import signal

import pytest

import gwlib

LIMIT = int(float(os.environ.get("GW_PER_TEST_TIMEOUT", "180")) * gwlib.SCALE)
LABEL = os.environ.get("GW_LABEL", "drgatewayd end to end (pytest tests/gateway)")


class TimeLimit(Exception):
    pass


@pytest.fixture(autouse=True)
def _time_limit():
    """Every test is bounded: SIGALRM fails it and the run goes on."""
    def on_alarm(signum, frame):
        raise TimeLimit("test took longer than %d s" % LIMIT)
    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(LIMIT)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.fixture(scope="session")
def regmap():
    return gwlib.RegMap()


SANITIZER_MARKS = ("ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:",
                   "SUMMARY: UndefinedBehaviorSanitizer")


def is_worker(config):
    return hasattr(config, "workerinput")


def pytest_sessionstart(session):
    # logs of an earlier run would be scanned below as if they were new
    if is_worker(session.config) or not gwlib.LOGROOT.is_dir():
        return
    for p in gwlib.LOGROOT.rglob("*"):
        if p.suffix in (".log", ".ini", ".notify") and p.is_file():
            p.unlink()


def sanitizer_reports():
    """Processes built with ASan/UBSan report into their logs; each log with
    a report is one failure (the process may have exited 0 after a UBSan
    report that did not abort)."""
    bad = []
    if gwlib.LOGROOT.is_dir():
        for p in sorted(gwlib.LOGROOT.rglob("*.log")):
            text = gwlib.read_text(p)
            if any(m in text for m in SANITIZER_MARKS):
                bad.append(p)
    return bad


def pytest_sessionfinish(session, exitstatus):
    gwlib.kill_all()
    if is_worker(session.config):
        return
    bad = sanitizer_reports()
    for p in bad:
        print("\n### sanitizer report in %s:\n%s" % (p, gwlib.read_text(p)[-4000:]))
    results = os.environ.get("GW_RESULTS")
    if not results:
        if bad:
            session.exitstatus = 1
        return
    rep = session.config.pluginmanager.get_plugin("terminalreporter")
    stats = rep.stats if rep is not None else {}
    passed = len([r for r in stats.get("passed", []) if r.when == "call"])
    failed = len(stats.get("failed", [])) + len(stats.get("error", [])) + len(bad)
    if bad:
        session.exitstatus = 1
    if failed == 0 and exitstatus not in (0, 5):
        failed = 1  # an internal error or an interrupted run
    if passed + failed == 0:
        failed = 1  # no test ran: that is a failure too
    for path in results.split(":"):
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        with open(path, "a") as f:
            f.write("%d %d %s\n" % (passed, failed, LABEL))


def pytest_configure(config):
    config.addinivalue_line("markers", "gw(**kw): settings of the test's own gateway")
