#!/bin/sh
# SPDX-License-Identifier: MIT
# The daemon's system calls, counted (docs/performance.md, "Robots per
# core", "What each change bought"): N drsims on 127.0.16.2 onwards, a
# drgatewayd on 127.0.16.1 with one [robot] per drsim, all on one local
# Class 1 port, no Modbus load; after 3 s, its wake-ups over 5 s, then
# `strace -c -f` on the daemon for 5 s. Counts, not timings: valid on a
# busy machine (the wake-ups less so: a daemon kept off the CPU finds more
# events per wake-up).
#
# usage: bench/gw_syscalls.sh DRGATEWAYD DRSIM N RPI_MS [ROBOT_LINE]
# ROBOT_LINE: one more line for every [robot], e.g. "o2t_timing = strict".
# needs strace; prints strace's table and how many links came up.
set -eu
GW=$1 SIM=$2 N=$3 RPI=$4 EXTRA=${5:-}
D=$(mktemp -d "${TMPDIR:-/tmp}/gw-syscalls.XXXXXX")
SIMS=""
cleanup() {
    [ -n "${G:-}" ] && kill "$G" 2>/dev/null || true
    for p in $SIMS; do kill "$p" 2>/dev/null || true; done
    wait 2>/dev/null || true
    rm -rf "$D"
}
trap cleanup EXIT INT TERM
printf '[daemon]\nlog_level = info\n\n[modbus]\nlisten = 127.0.16.1\nport = 15502\n' > "$D/gw.ini"
i=1
while [ "$i" -le "$N" ]; do
    a=127.0.16.$((i + 1))
    "$SIM" --address "$a" --tcp-port 44818 --udp-port 2222 --seed "$i" > "$D/sim$i.log" 2>&1 &
    SIMS="$SIMS $!"
    printf '\n[robot r%02d]\nhost = %s\nlocal_address = 127.0.16.1\nlocal_udp_port = 2300\nunit_id = %d\nrpi_ms = %d\n%s\n' \
        "$i" "$a" "$i" "$RPI" "$EXTRA" >> "$D/gw.ini"
    i=$((i + 1))
done
sleep 0.5
"$GW" -c "$D/gw.ini" > "$D/gw.log" 2>&1 &
G=$!
sleep 3
echo "links up: $(grep -c 'link up' "$D/gw.log") of $N"
# Wake-ups without strace (which slows the daemon and so changes how many
# events each wake-up finds): voluntary context switches over 5 s.
cs() { awk '/^voluntary_ctxt_switches/ {print $2}' "/proc/$G/status"; }
c0=$(cs); sleep 5; c1=$(cs)
echo "wake-ups (voluntary context switches) in 5 s without strace: $((c1 - c0))"
timeout -s INT 5 strace -c -f -p "$G" -o "$D/strace.txt" 2>/dev/null || true
sleep 0.2
cat "$D/strace.txt"
