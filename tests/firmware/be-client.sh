#!/bin/sh
# SPDX-License-Identifier: MIT
# The client (not only the codec) on a big-endian CPU: test_be_client,
# built for s390x, runs under qemu-user against a native drsim on
# loopback. Both ends on one machine: drsim on 127.0.0.2 with its own
# TCP and UDP ports, the client's Class 1 socket on 127.0.0.1 at another
# port, announced in the Forward Open (see enip-facts.md, "Two ends on one
# machine").
#
# usage: be-client.sh RUNNER TEST_BE_CLIENT DRSIM RESULTS
set -u
runner=$1 bin=$2 drsim=$3 results=$4
label=be_client

. "$(dirname "$0")/../skip.sh"
skip_name=check-be-client skip_results=$results skip_label=$label
command -v "${runner%% *}" >/dev/null 2>&1 || skip "no ${runner%% *} (qemu-user)"

# Ports of our own, away from 44818/2222 and from other tests' picks.
base=$((31000 + ($$ % 2000) * 3))
tcp=$base sim_udp=$((base + 1)) cli_udp=$((base + 2))
"$drsim" -a 127.0.0.2 -p "$tcp" -u "$sim_udp" &
sim_pid=$!
trap 'kill $sim_pid 2>/dev/null; wait $sim_pid 2>/dev/null' EXIT
i=0
until ss -ltn 2>/dev/null | grep -q "127.0.0.2:$tcp"; do
    i=$((i + 1))
    if [ $i -gt 50 ] || ! kill -0 "$sim_pid" 2>/dev/null; then
        echo "be-client: FAIL drsim did not start on 127.0.0.2:$tcp" >&2
        echo "0 1 $label (drsim did not start)" >>"$results"
        exit 1
    fi
    sleep 0.1
done

out=$(mktemp)
# shellcheck disable=SC2086 # the runner is a command with arguments
timeout 120 $runner "$bin" 127.0.0.2 "$tcp" 127.0.0.1 "$cli_udp" >"$out" 2>&1
rc=$?
cat "$out"
passed=$(grep -c ': ok ' "$out")
failed=$(grep -c ': FAIL' "$out")
grep -q 'this CPU is big-endian' "$out" || { echo "be-client: FAIL not run big-endian"; failed=$((failed + 1)); }
rm -f "$out"
if [ "$rc" != 0 ] && [ "$failed" = 0 ]; then failed=1; echo "be-client: FAIL exit status $rc"; fi
echo "$passed $failed $label" >>"$results"
[ "$failed" = 0 ]
