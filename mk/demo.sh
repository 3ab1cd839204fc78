#!/bin/sh
# SPDX-License-Identifier: MIT
# make demo: the gateway against the simulated robot, on this machine,
# without root. drsim plays the robot on 127.0.0.2 (EtherNet/IP TCP 44818,
# Class 1 UDP 2222); drgatewayd connects to it with six Class 1
# connections (its own UDP socket on 127.0.0.1:2222) and serves Modbus TCP
# on 127.0.0.1:1502; mbpoll, an independent Modbus client, reads and writes.
# Every command it shows is the one it runs, as printed: a user can paste
# it (while the demo runs, or with drsim and drgatewayd started as shown).
# usage: demo.sh BUILD_DIR
# DEMO_THEN=COMMAND runs COMMAND (sh -c) at the end, while drsim and the
# gateway still run (mk/check-demo.sh replays the printed commands there).
set -eu
cd "$(dirname "$0")/.."
b=${1:-build}
for p in drsim drgatewayd drcli; do
    [ -x "$b/$p" ] || { echo "demo: $b/$p not built (run make)" >&2; exit 1; }
done
command -v mbpoll >/dev/null || { echo "demo: mbpoll missing (make deps installs it)" >&2; exit 1; }

tmp=$(mktemp -d)
cleanup() {
    [ -n "${gw:-}" ] && kill "$gw" 2>/dev/null && wait "$gw" 2>/dev/null
    [ -n "${sim:-}" ] && kill "$sim" 2>/dev/null && wait "$sim" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT INT TERM

if [ -t 1 ]; then bold=$(printf '\033[1m') off=$(printf '\033[0m'); else bold= off=; fi
step() { printf '\n%s== %s%s\n' "$bold" "$*" "$off"; }
show() { printf '$ %s\n' "$*"; }
# The client's fixed part: Modbus TCP on the gateway's port, addresses from
# 0 (-0: the map's numbering), one poll (-1).
MB="mbpoll -m tcp -p 1502 -0 -1"
# mb ARGS: a read; the command shown is the command run
mb() { cmd="$MB $* 127.0.0.1"; show "$cmd"; $cmd | sed -n '/^\[/p'; }
# mbw ARGS -- VALUES: a write (mbpoll wants the values after the host)
mbw() {
    args=; while [ "$1" != -- ]; do args="$args $1"; shift; done; shift
    cmd="$MB$args 127.0.0.1 $*"
    show "$cmd"
    $cmd 2>&1 | grep -E 'Written|failed|rror'
}
# Address of a field in the map the gateway prints (never hard-coded here).
addr() { "$b/drgatewayd" --print-map | awk -v n="$1" '$4 == n { split($2, a, "-"); print a[1]; exit }'; }

# In the build directory, so that the command shown can be pasted.
ini=$b/demo.ini
cat > "$ini" <<INI
[modbus]
listen = 127.0.0.1
port = 1502

[robot demo]
host = 127.0.0.2
local_address = 127.0.0.1
unit_id = 1
rpi_ms = 10
INI

step "Start the simulated robot and the gateway"
show "$b/drsim --address 127.0.0.2 &"
"$b/drsim" --address 127.0.0.2 >"$tmp/drsim.log" 2>&1 &
sim=$!
show "$b/drgatewayd -c $ini &     # six Class 1 connections, RPI 10 ms"
"$b/drgatewayd" -c "$ini" >"$tmp/gw.log" 2>&1 &
gw=$!
i=0
until grep -qs "link up" "$tmp/gw.log"; do
    i=$((i + 1))
    if [ $i -gt 50 ] || ! kill -0 "$gw" 2>/dev/null; then
        echo "demo: the gateway did not connect; its log:" >&2
        cat "$tmp/gw.log" >&2
        exit 1
    fi
    sleep 0.1
done
sed 's/^/  /' "$tmp/gw.log"
sleep 3 # let the robot reach OPERATING and start moving

step "Status block (input registers 0-5): layout, link up, fresh, age ms, heartbeat, RPI ms"
mb -t 3 -r 0 -c 6
step "Word-order test registers (input registers 35-36: 123456.0 as REAL, abcd)"
mb -t 3:hex -r 35 -c 2
pos=$(addr 'joint_state.position[1]')
step "Joint positions 1-6 in degrees (REAL, input registers $pos..)"
mb -t 3:float -B -r "$pos" -c 6
spos=$(addr 'joint_state.position[1]' | awk '{print $1 + 1000}')
step "The same as INT16 x10 (input registers $spos..), for PLCs without REAL"
mb -t 3 -r "$spos" -c 6
ver=$(addr 'io_state.version.major')
step "Controller version and robot_state (input registers $ver..; 2 = OPERATING)"
mb -t 3 -r "$ver" -c 4
iin=$(addr 'int_in[0]') iout=$(addr 'int_out[0]')
step "A PLC writes int_in[0] = 4242 (holding registers $iin-$((iin + 1)), DINT)..."
mbw -t 4:int -B -r "$iin" -- 4242
sleep 0.3
step "...and the robot echoes it to int_out[0] (input registers $iout-$((iout + 1)))"
mb -t 3:int -B -r "$iout" -c 1
fin=$(addr 'float_in[0]')
step "Writing NaN to a REAL the robot consumes is refused (exception 0x03)"
mbw -t 4:hex -r "$fin" -- 0x7FC0 0x0000 || true

if [ -n "${DEMO_THEN:-}" ]; then sh -c "$DEMO_THEN"; fi

printf '\nMore: docs/register-map.md (every address), drgatewayd --print-map,\n'
printf 'drcli -H 127.0.0.2 dump (talks to drsim directly); all tests: make check\n'
