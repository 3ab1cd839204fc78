# SPDX-License-Identifier: MIT
"""Run one interoperability test module with unittest and add its counts to
`make check`'s results file as a "passed failed label" line.

usage: pyrun.py RESULTS LABEL tests/interop/test_x.py [per-test timeout s]

Every test is bounded: after the timeout (default 120 s) SIGALRM raises in
the test, which then counts as failed, and the next test runs. Skipped tests
(a peer that is not installed) are printed loudly and counted as neither.
"""
import importlib.util
import os
import signal
import sys
import unittest


class Timeout(Exception):
    pass


def on_alarm(signum, frame):
    raise Timeout("test took longer than its time limit")


class BoundedResult(unittest.TextTestResult):
    limit = 120

    def startTest(self, test):
        signal.alarm(self.limit)
        super().startTest(test)

    def stopTest(self, test):
        signal.alarm(0)
        super().stopTest(test)


def main():
    if len(sys.argv) < 4:
        print(__doc__, file=sys.stderr)
        return 2
    results, label, path = sys.argv[1:4]
    if len(sys.argv) > 4:
        BoundedResult.limit = int(sys.argv[4])
    sys.path.insert(0, os.path.dirname(os.path.abspath(path)))
    signal.signal(signal.SIGALRM, on_alarm)
    name = os.path.splitext(os.path.basename(path))[0]
    spec = importlib.util.spec_from_file_location(name, path)
    passed = failed = 0
    try:
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        suite = unittest.defaultTestLoader.loadTestsFromModule(mod)
        runner = unittest.TextTestRunner(verbosity=2, resultclass=BoundedResult,
                                         stream=sys.stdout)
        res = runner.run(suite)
        bad = len(res.failures) + len(res.errors) + len(res.unexpectedSuccesses)
        skipped = len(res.skipped)
        passed = res.testsRun - bad - skipped
        failed = bad
        if skipped:
            print("#" * 70)
            for test, why in res.skipped:
                print("### SKIPPED %s: %s" % (test.id(), why))
            print("#" * 70)
        if res.testsRun == 0:
            failed = 1  # an empty module is a broken module
    except Exception as e:  # the module did not even load
        print("%s: %s: %s" % (label, type(e).__name__, e))
        failed = max(failed, 1)
    os.makedirs(os.path.dirname(os.path.abspath(results)), exist_ok=True)
    with open(results, "a") as f:
        f.write("%d %d %s\n" % (passed, failed, label))
    print("%s: %d passed, %d failed" % (label, passed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
