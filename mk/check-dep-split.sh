#!/bin/sh
# SPDX-License-Identifier: MIT
# check-dep-split: `make deps` (what make demo needs) installs no test tool.
#   1. the lists: the demo set (mk/deps.sh --list demo) shares nothing with
#      the test-only set and names none of the test tools below;
#   2. a dry run of the demo set on this machine plans none of the test set
#      and no dpkg architecture;
#   3. a dry run against a fresh minimal bookworm (mk/minimal-root.sh) plans
#      none of the test tools, nothing for s390x or arm64 and no upgrade.
# usage: check-dep-split.sh [RESULTS]
set -u
cd "$(dirname "$0")/.."
res=${1:-}
label="make deps installs no test tool (mk/check-dep-split.sh)"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
. mk/check-lib.sh

# Test tools by name, whatever the lists say (a test tool moved into the
# demo set is caught here even if it also left the test-only set).
TOOLS='^(clang|clang-tidy|libclang-rt-.*|cppcheck|valgrind|gcovr|tshark|wireshark.*|qemu-.*|gcc-arm-none-eabi|libnewlib-arm-none-eabi|gcc-s390x-linux-gnu|.*-s390x-cross|libcmocka-dev|socat|mosquitto|liblwip-dev|python3-venv|gpiod|debhelper|lintian|mmdebstrap|gcc-aarch64-linux-gnu|.*-arm64-cross|chromium|chromium-driver|prometheus|nanopb|nodejs|npm)$'

sh mk/deps.sh --list demo > "$tmp/demo"
sh mk/deps.sh --list test-only | sort -u > "$tmp/test"
[ -s "$tmp/demo" ] && [ -s "$tmp/test" ] || { bad "empty package lists"; }
both=$(sort -u "$tmp/demo" | comm -12 - "$tmp/test" | tr '\n' ' ')
[ -z "$both" ] && ok "demo and test-only lists are disjoint" || bad "in both lists: $both"
tools=$(grep -E "$TOOLS" "$tmp/demo" | tr '\n' ' ')
[ -z "$tools" ] && ok "the demo list names no test tool" || bad "test tools in the demo list: $tools"
grep -q ':' "$tmp/demo" && bad "a foreign-architecture package in the demo list" ||
    ok "no foreign architecture in the demo list"

# plan FILE: the names apt would install, one a line
names() { sed -n 's/^deps: would: Inst \([^ ]*\).*/\1/p' "$1" | sed 's/:.*//'; }
check_plan() { # FILE WHERE
    hit=$(names "$1" | grep -E "$TOOLS" | tr '\n' ' ')
    hit2=$(names "$1" | sort -u | comm -12 - "$tmp/test" | tr '\n' ' ')
    [ -z "$hit$hit2" ] && ok "$2: plans no test package ($(names "$1" | wc -l) packages)" ||
        bad "$2: would install test packages: $hit $hit2"
    grep -qi 's390x\|arm64\|architecture' "$1" && bad "$2: would touch s390x, arm64 / the dpkg architectures" ||
        ok "$2: no foreign architecture"
    up=$(grep '^deps: would: Inst [^ ]* \[' "$1" | cut -d' ' -f4 | tr '\n' ' ')
    [ -z "$up" ] && ok "$2: upgrades nothing installed" || bad "$2: would upgrade $up"
}
if sh mk/deps.sh --dry-run demo > "$tmp/here" 2>&1; then
    check_plan "$tmp/here" "demo deps on this machine"
else
    bad "deps.sh --dry-run demo failed: $(cat "$tmp/here")"
fi
if ! apt-cache show --no-all-versions build-essential >/dev/null 2>&1; then
    echo "  (no apt package lists here (apt-get update): the fresh-bookworm dry run is skipped)"
elif command -v apt-get >/dev/null && [ -r /var/lib/dpkg/status ] && sh mk/minimal-root.sh "$tmp/root" 2>/dev/null; then
    if DEPS_ADMINDIR=$tmp/root sh mk/deps.sh --dry-run demo > "$tmp/fresh" 2>&1 &&
            grep -q '^deps: would: Inst ' "$tmp/fresh"; then
        check_plan "$tmp/fresh" "demo deps on a fresh bookworm"
        # A user other than root gets the command to run as root; pasted,
        # apt takes it (it read "--no-install-recommendsbuild-essential").
        if command -v setpriv >/dev/null; then
            chmod 755 "$tmp" "$tmp/root"; chmod 644 "$tmp/root/status"
            hint=$(cd / && setpriv --reuid=65534 --regid=65534 --clear-groups \
                   env DEPS_ADMINDIR="$tmp/root" sh "$OLDPWD/mk/deps.sh" demo 2>&1 >/dev/null)
            pk=$(echo "$hint" | sed -n "s/.*apt-get install --no-install-recommends \([^']*\)'.*/\1/p")
            # shellcheck disable=SC2086
            if [ -n "$pk" ] && apt-get -s -q -o Dir::State::status="$tmp/root/status" \
                    install --no-install-recommends $pk >/dev/null 2>&1; then
                ok "not root: the hint's apt-get command is one apt takes ($(echo $pk | wc -w) packages)"
            else
                bad "not root: the hint is not a command apt takes: $hint"
            fi
        fi
    else
        bad "dry run against a minimal bookworm planned nothing: $(tail -3 "$tmp/fresh")"
    fi
else
    echo "  (no apt/dpkg here: the fresh-bookworm dry run is skipped)"
fi

check_done
