#!/bin/sh
# SPDX-License-Identifier: MIT
# check-demo: the commands make demo prints can be pasted as they are.
# Runs mk/demo.sh; at its end, while its drsim and gateway still run
# (DEMO_THEN), every "$ mbpoll ..." line of its output so far is run again
# exactly as printed, and must get an answer from the gateway: registers
# ("[N]: value"), "Written", or a Modbus exception (the demo's NaN write);
# never a usage error of mbpoll's. The programs and the configuration the
# "$ build/drsim", "$ build/drgatewayd -c FILE" lines name must exist.
# Uses the demo's fixed addresses (127.0.0.1:1502, 127.0.0.2); ~5 s.
# usage: check-demo.sh BUILD_DIR [RESULTS]
#        check-demo.sh --replay OUTPUT REPORT   (the DEMO_THEN part)
set -u
cd "$(dirname "$0")/.."

if [ "${1:-}" = --replay ]; then
    out=$2 rep=$3
    sed -n 's/^\$ \(mbpoll .*\)$/\1/p' "$out" | while IFS= read -r cmd; do
        got=$(sh -c "$cmd" 2>&1)
        if printf '%s\n' "$got" | grep -qE '^\[[0-9]+\]:|^Written [0-9]+ references|failed: Illegal data (value|address)'; then
            echo "ok $cmd" >> "$rep"
        else
            echo "FAIL $cmd => $(printf '%s' "$got" | tail -2 | tr '\n' ' ')" >> "$rep"
        fi
    done
    exit 0
fi

b=${1:-build} res=${2:-}
label="make demo prints commands that run as pasted (mk/check-demo.sh)"
command -v mbpoll >/dev/null || exec sh tests/skip.sh check-demo "mbpoll missing (make deps)" "$res" "$label"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
. mk/check-lib.sh

: > "$tmp/report"
if DEMO_THEN="sh mk/check-demo.sh --replay $tmp/out $tmp/report" \
        sh mk/demo.sh "$b" > "$tmp/out" 2>&1; then
    ok "make demo ran (exit 0)"
else
    bad "mk/demo.sh failed: $(tail -5 "$tmp/out")"
fi
n=$(grep -c '^ok ' "$tmp/report")
grep '^ok ' "$tmp/report" | sed 's/^ok /  ran as printed: /'
grep '^FAIL ' "$tmp/report" | while IFS= read -r l; do echo "  FAIL: ${l#FAIL }"; done
nf=$(grep -c '^FAIL ' "$tmp/report")
[ "$nf" -eq 0 ] || fail=$((fail + nf))
[ "$n" -ge 8 ] && ok "$n printed mbpoll commands answered by the demo's gateway" ||
    bad "only $n printed mbpoll commands answered (want the demo's 8 or more)"
for p in $(sed -n 's/^\$ \([^ ]*\/dr[a-z]*\) .*/\1/p' "$tmp/out"); do
    [ -x "$p" ] && ok "printed program $p exists" || bad "printed program $p does not exist"
done
ini=$(sed -n 's/^\$ .*drgatewayd -c \([^ ]*\) .*/\1/p' "$tmp/out")
[ -n "$ini" ] && [ -f "$ini" ] && ok "printed configuration $ini exists" ||
    bad "printed configuration '$ini' does not exist"

check_done
