#!/bin/sh
# SPDX-License-Identifier: MIT
# Runs the steps of `make check` (or `make check-quick`) one after the
# other, each as `$MAKE STEP`, and notes how long each took. Every step
# runs even if an earlier one failed; a step that fails without recording
# its own result is recorded as one failure, so the summary line (and the
# exit status) can never miss it.
#
# usage: MAKE=make [BG_STEPS="STEP..."] check-steps.sh RESULTS TIMES STEP...
#   BG_STEPS  steps that run beside the others, started first and waited
#            for at the end (their output shown then): long steps that
#            mostly wait on the network and dpkg in roots of their own
#            (check-fresh), at a lower priority (nice) so that the
#            foreground steps keep the CPU they need
#   RESULTS  "passed failed label" lines (tests/run-tests.sh)
#   TIMES    one "STEP WALL_S CPU_S" line per step: wall-clock seconds, and
#            the user + system seconds of every process the step waited
#            for (a loaded machine shows as wall >> cpu)
# --summary RESULTS TIMES  prints the time per step, then the closing line
#            "check: N passed, M failed"; exit 1 if anything failed.
set -u

if [ "${1:-}" = "--summary" ]; then
    results=$2; times=$3
    if [ -s "$times" ]; then
        echo "check: time per step (wall s, user+sys s of its processes):"
        # (a background step's wall time overlaps the others': the total
        # is the longer of it and the others' sum)
        awk '{printf "  %-24s %5d %5d\n", $1, $2, $3; c += $3
              if ($1 !~ /\(bg\)$/) w += $2; else if ($2 > bg) bg = $2}
             END {printf "  %-24s %5d %5d\n", "total", (bg > w ? bg : w), c}' "$times"
    fi
    touch "$results"
    awk '{p += $1; f += $2} END {printf "check: %d passed, %d failed\n", p, f; exit (f > 0)}' \
        "$results"
    exit $?
fi

results=$1; times=$2; shift 2
make=${MAKE:-make}
mkdir -p "$(dirname "$results")" "$(dirname "$times")"
tf=$(mktemp) || exit 1
trap 'rm -f "$tf"' EXIT

# The shell's `times` (a builtin: it must run in this shell, not in a
# $(...) subshell) prints the children's user and system time on its
# second line, as 1m2.5s 0m0.3s; cpu_s reads that.
cpu_s() {
    awk 'NR == 2 {
        s = 0
        for (i = 1; i <= 2; i++) { split($i, a, /[ms]/); s += a[1] * 60 + a[2] }
        printf "%.1f\n", s }' "$tf"
}

status=0
# The background steps: each `$make STEP` into a log of its own, its start
# time beside it.
bgdir=$(mktemp -d) || exit 1
trap 'rm -f "$tf"; rm -rf "$bgdir"' EXIT
for step in ${BG_STEPS:-}; do
    echo "check: ---- $step (in the background; its output comes at the end)"
    date +%s > "$bgdir/$step.t0"
    nice -n 10 $make --no-print-directory "$step" > "$bgdir/$step.log" 2>&1 &
    echo $! > "$bgdir/$step.pid"
done
for step in "$@"; do
    t0=$(date +%s); times > "$tf"; c0=$(cpu_s)
    echo "check: ---- $step"
    if ! $make --no-print-directory "$step"; then
        status=1
        echo "0 1 $step (make $step failed)" >> "$results"
    fi
    t1=$(date +%s); times > "$tf"; c1=$(cpu_s)
    echo "$step $((t1 - t0)) $(awk -v a="$c0" -v b="$c1" 'BEGIN {printf "%d", b - a + 0.5}')" \
        >> "$times"
done
for step in ${BG_STEPS:-}; do
    times > "$tf"; c0=$(cpu_s)
    pid=$(cat "$bgdir/$step.pid")
    echo "check: ---- $step (the background step's output)"
    wait "$pid"; st=$?
    cat "$bgdir/$step.log"
    if [ "$st" != 0 ]; then
        status=1
        echo "0 1 $step (make $step failed)" >> "$results"
    fi
    t1=$(date +%s); times > "$tf"; c1=$(cpu_s)
    echo "$step(bg) $((t1 - $(cat "$bgdir/$step.t0"))) $(awk -v a="$c0" -v b="$c1" 'BEGIN {printf "%d", b - a + 0.5}')" \
        >> "$times"
done
exit $status
