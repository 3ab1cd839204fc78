#!/bin/sh
# SPDX-License-Identifier: MIT
# Run CMocka test programs, show their output, and add their counts to a
# results file ("passed failed label" per line) for `make check`'s summary.
# usage: run-tests.sh RESULTS "RUNNER PREFIX" test...
results=$1; runner=$2; shift 2
mkdir -p "$(dirname "$results")"
status=0
for t in "$@"; do
    out=$($runner "$t" 2>&1); rc=$?
    printf '%s\n' "$out"
    passed=$(printf '%s\n' "$out" | sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' | tail -n 1)
    failed=$(printf '%s\n' "$out" | sed -n 's/^\[  FAILED  \] \([0-9]*\) test.*/\1/p' | tail -n 1)
    passed=${passed:-0}; failed=${failed:-0}
    # A crash or a non-zero exit with no FAILED line still counts as a failure.
    if [ "$rc" -ne 0 ] && [ "$failed" -eq 0 ]; then failed=1; fi
    if [ "$rc" -ne 0 ]; then status=1; echo "FAIL: $t (exit $rc)"; fi
    echo "$passed $failed ${runner:+[$runner] }$(basename "$t")" >> "$results"
done
exit $status
