#!/bin/sh
# SPDX-License-Identifier: MIT
# Our client on a real lwIP stack (Debian's liblwip, Linux user-space
# port) against drsim on the Linux kernel's stack, joined by a TAP device
# in a network namespace of its own:
#
#   namespace drgate-lwip-PID:  drsim on 10.212.0.1 (kernel) --TAP-- lwIP 10.212.0.2
#
# lwIP is a separate IP stack, so both ends own their UDP 2222. Needs root,
# /dev/net/tun and ip(8); without them the test says SKIPPED.
#
# usage: lwip.sh TEST_LWIP DRSIM RESULTS SECONDS
set -u
bin=$1 drsim=$2 results=$3 secs=${4:-5}
label=lwip

. "$(dirname "$0")/../skip.sh"
skip_name=check-lwip skip_results=$results skip_label=$label
[ "$(id -u)" = 0 ] || skip "not root (network namespaces and TAP devices need it)"
[ -c /dev/net/tun ] || skip "no /dev/net/tun"
command -v ip >/dev/null 2>&1 || skip "no ip command (iproute2)"

ns=drgate-lwip-$$
tap=drtap$$
kaddr=10.212.0.1 laddr=10.212.0.2
sim_pid=
cleanup() {
    [ -z "$sim_pid" ] || kill "$sim_pid" 2>/dev/null
    [ -z "$sim_pid" ] || wait "$sim_pid" 2>/dev/null
    ip netns del "$ns" 2>/dev/null
}
trap cleanup EXIT
trap 'exit 1' INT TERM

in_ns() { ip netns exec "$ns" "$@"; }
ip netns add "$ns" || skip "cannot create a network namespace"
in_ns ip link set lo up
in_ns ip tuntap add dev "$tap" mode tap || skip "cannot create a TAP device"
in_ns ip addr add "$kaddr/24" dev "$tap"
in_ns ip link set "$tap" up

# Not through in_ns: $! must be drsim itself (ip netns exec execs it),
# so that the cleanup stops it.
ip netns exec "$ns" "$drsim" -a "$kaddr" &
sim_pid=$!
# drsim is up when its TCP port listens (bounded).
i=0
until in_ns ss -ltn 2>/dev/null | grep -q "$kaddr:44818"; do
    i=$((i + 1))
    if [ $i -gt 50 ] || ! kill -0 "$sim_pid" 2>/dev/null; then
        echo "lwip: FAIL drsim did not start" >&2
        echo "0 1 $label (drsim did not start)" >>"$results"
        exit 1
    fi
    sleep 0.1
done

out=$(mktemp)
in_ns env PRECONFIGURED_TAPIF="$tap" timeout 120 "$bin" "$laddr" 255.255.255.0 "$kaddr" "$secs" \
    >"$out" 2>&1
rc=$?
cat "$out"
passed=$(grep -c ': ok ' "$out")
failed=$(grep -c ': FAIL' "$out")
rm -f "$out"
if [ "$rc" != 0 ] && [ "$failed" = 0 ]; then failed=1; echo "lwip: FAIL exit status $rc"; fi
echo "$passed $failed $label" >>"$results"
[ "$failed" = 0 ]
