#!/bin/sh
# SPDX-License-Identifier: MIT
# Write the summary of one `make bench` run into docs/performance.md, between
# its markers: the machine, then each benchmark's figures and goals as the
# benchmark printed them (every figure there is a ratio measured side by
# side in the same run). The sections below the summary explain the methods.
# usage: bench-report.sh OUTDIR DOC
set -eu
out=$1 doc=$2
begin='<!-- make bench summary: begin (written by make bench) -->'
end='<!-- make bench summary: end -->'
tmp=$(mktemp)
trap 'rm -f "$tmp" "$tmp.doc"' EXIT

cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n 1)
{
    echo "$begin"
    echo "## Latest run"
    echo
    echo "$(date -u '+%Y-%m-%d %H:%M UTC'): $(uname -srm), $(nproc) CPU(s) ($cpu),"
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) when it ended."
    echo "What each benchmark printed about its goals:"
    for f in "$out"/*.txt; do
        [ -f "$f" ] || continue
        name=$(basename "$f" .txt)
        echo
        echo "### $name"
        echo
        echo '```'
        # the lines that carry a goal, and the ones that name what is measured
        grep -E 'goal|x memcpy|ratio|met|MISSED' "$f" | grep -v '^make' | head -n 40 || true
        echo '```'
    done
    echo "$end"
} > "$tmp"

if grep -qF "$begin" "$doc"; then
    awk -v b="$begin" -v e="$end" -v f="$tmp" '
        $0 == b { while ((getline l < f) > 0) print l; skip = 1; next }
        $0 == e { skip = 0; next }
        !skip { print }' "$doc" > "$tmp.doc"
else
    # first time: after the introduction, before the first section
    awk -v f="$tmp" '
        /^## / && !done { while ((getline l < f) > 0) print l; print ""; done = 1 }
        { print }' "$doc" > "$tmp.doc"
fi
cat "$tmp.doc" > "$doc"
echo "bench: summary written to $doc"
