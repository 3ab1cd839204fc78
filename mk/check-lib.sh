# SPDX-License-Identifier: MIT
# Sourced by the mk/check-*.sh steps of make check: a count of checks
# passed and failed, one line each, and the summary line that make check
# counts. Set `label` and `res` (the results file; empty: none) before
# check_done.
pass=0 fail=0
ok() { pass=$((pass + 1)); echo "  ok: $*"; }
bad() { fail=$((fail + 1)); echo "  FAIL: $*"; }
# The summary, its line in the results file, and exit: 0 if nothing failed.
check_done() {
    echo "$label: $pass passed, $fail failed"
    [ -z "$res" ] || echo "$pass $fail $label" >> "$res"
    [ "$fail" -eq 0 ]; exit
}
