#!/bin/sh
# SPDX-License-Identifier: MIT
# Run the libFuzzer harnesses for a while each and record the outcome.
#   run-fuzz.sh --probe CC          exit 0 if CC links -fsanitize=fuzzer
#   run-fuzz.sh --skip RESULTS T... say loudly that fuzzing was skipped
#   run-fuzz.sh RESULTS SECONDS DIR T...
# The last form runs DIR/fuzz_T over DIR/corpus/T (grows; kept between
# runs) and the committed seeds fuzz/corpus/T, then appends
# "1 0 fuzz_T" or "0 1 fuzz_T" to RESULTS (the `make check` format, see
# tests/run-tests.sh). Crashing inputs land in DIR/artifacts/.
# FUZZ_JOBS (environment, default 2) harnesses run at a time: each is one
# process on one core for SECONDS, so two cores fuzz two harnesses in the
# time of one. Their reports are printed in the order of T.
set -u

if [ "${1:-}" = --probe ]; then
    cc=$2
    tmp=${TMPDIR:-/tmp}/drgate-fuzz-probe.$$
    printf '%s\n' '#include <stddef.h>' '#include <stdint.h>' \
        'int LLVMFuzzerTestOneInput(const uint8_t *d, size_t n);' \
        'int LLVMFuzzerTestOneInput(const uint8_t *d, size_t n) { (void)d; (void)n; return 0; }' \
        > "$tmp.c"
    if ! command -v "$cc" >/dev/null 2>&1; then
        why="$cc not found"
    elif ! "$cc" -fsanitize=fuzzer,address,undefined "$tmp.c" -o "$tmp" >/dev/null 2>&1; then
        why="$cc cannot link -fsanitize=fuzzer (libFuzzer runtime missing: on Debian 12 install libclang-rt-14-dev, only recommended by clang-14)"
    else
        why=
    fi
    rm -f "$tmp.c" "$tmp"
    [ -z "$why" ] && exit 0
    echo "$why" >&2
    exit 1
fi

if [ "${1:-}" = --skip ]; then
    results=$2; shift 2
    echo "******************************************************************"
    echo "*** FUZZING SKIPPED: no usable clang/libFuzzer (see above).     ***"
    echo "*** Install clang (Debian: clang + libclang-rt-14-dev) to run.  ***"
    echo "******************************************************************"
    if [ -n "$results" ]; then
        mkdir -p "$(dirname "$results")"
        for t in "$@"; do echo "0 0 fuzz_$t (skipped: no clang)" >> "$results"; done
    fi
    exit 0
fi

results=$1; seconds=$2; dir=$3; shift 3
jobs=${FUZZ_JOBS:-2}
[ -n "$results" ] && mkdir -p "$(dirname "$results")"
mkdir -p "$dir/artifacts"

# One harness: its report to DIR/fuzz_T.report, its result line to
# DIR/fuzz_T.result.
fuzz_one() {
    t=$1
    work=$dir/corpus/$t
    log=$dir/fuzz_$t.log
    mkdir -p "$work"
    "$dir/fuzz_$t" -max_total_time="$seconds" -timeout=10 -print_final_stats=1 \
        -artifact_prefix="$dir/artifacts/fuzz_$t-" "$work" "fuzz/corpus/$t" \
        > "$log" 2>&1
    rc=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1)
    if [ "$rc" -eq 0 ]; then
        echo "fuzz_$t: ${execs:-?} executions in ${seconds}s, ${cov:-cov ?}: no crash"
        echo "1 0 fuzz_$t" > "$dir/fuzz_$t.result"
    else
        echo "FAIL: fuzz_$t (exit $rc) after ${execs:-?} executions; log: $log"
        grep -E 'invariant broken|ERROR:|runtime error|Test unit written' "$log" | head -n 5
        echo "0 1 fuzz_$t" > "$dir/fuzz_$t.result"
    fi > "$dir/fuzz_$t.report"
}

# Batches of $jobs; a harness that dies without a result line is a failure.
status=0
set -- "$@" ""
batch=
for t in "$@"; do
    [ -n "$t" ] && { rm -f "$dir/fuzz_$t.result"; fuzz_one "$t" & batch="$batch $t"; }
    # shellcheck disable=SC2086 # a list of names
    if [ -z "$t" ] || [ $(set -- $batch; echo $#) -ge "$jobs" ]; then
        wait
        for b in $batch; do
            cat "$dir/fuzz_$b.report" 2>/dev/null
            line=$(cat "$dir/fuzz_$b.result" 2>/dev/null) || line="0 1 fuzz_$b (no result)"
            case $line in 0\ *) status=1 ;; esac
            [ -n "$results" ] && echo "$line" >> "$results"
        done
        batch=
    fi
done
exit $status
