#!/bin/sh
# SPDX-License-Identifier: MIT
# make demo: decoded robot data, end to end through drcli. Until the
# simulated robot and the gateway exist, the robot's side is played by
# `drcli encode`, which builds the exact bytes a controller would send;
# `drcli decode` then reads them back the way the gateway will.
# usage: demo.sh BUILD_DIR
set -eu
cd "$(dirname "$0")/.."
drcli=${1:-build}/drcli
[ -x "$drcli" ] || { echo "demo: $drcli not built (run make)" >&2; exit 1; }
hexfile=$(mktemp)
trap 'rm -f "$hexfile"' EXIT

if [ -t 1 ]; then bold=$(printf '\033[1m') off=$(printf '\033[0m'); else bold= off=; fi
step() { printf '\n%s== %s%s\n' "$bold" "$*" "$off"; }
show() { printf '$ %s\n' "$*"; }

step "The robot reports its I/O and state (io_state, 36 bytes on the wire)"
show "drcli encode --hex io_state cb_di=0x0005 ai[0]=4.25 version.major=3 robot_state=OPERATING servo_on=1 | tee demo.hex"
"$drcli" encode --hex io_state cb_di=0x0005 ai[0]=4.25 version.major=3 \
    robot_state=OPERATING servo_on=1 | tee "$hexfile"

step "The gateway's view of those bytes (fields that are not zero)"
show "drcli decode --hex io_state demo.hex | grep -Ev ' = 0( \(0x0+\))?\$'"
"$drcli" decode --hex io_state "$hexfile" | grep -Ev ' = 0( \(0x0+\))?$'

step "Joint positions (joint_state, 144 bytes), as JSON for other programs"
show "drcli encode joint_state position[1]=12.5 ... | drcli decode --json joint_state"
"$drcli" encode joint_state position[1]=12.5 position[2]=-45 position[3]=90.25 \
    position[4]=0.1 position[5]=30 position[6]=-179.5 |
    "$drcli" decode --json joint_state | grep 'position'

step "A command the robot must never get is refused, with the reason"
show "drcli encode io_control ao[0]=nan"
"$drcli" encode io_control ao[0]=nan 2>&1 || echo "(exit status $?)"

printf '\nMore: %s --help, docs/assemblies.md; all tests: make check\n' "$drcli"
