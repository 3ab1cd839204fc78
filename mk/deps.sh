#!/bin/sh
# SPDX-License-Identifier: MIT
# Install what a set of targets needs on Debian (12 bookworm, 13 trixie),
# and only what is missing.
#
# usage: deps.sh demo        build and run (make deps, make demo): the C
#                            toolchain, the -dev libraries the programs
#                            link, mbpoll for the demo's Modbus client
#        deps.sh test        demo + the test toolchain (make test-deps, which
#                            make check runs): cross compilers, s390x
#                            runtime and arm64 -dev libraries (adds the
#                            dpkg architectures), qemu, sanitizers, tshark,
#                            debhelper, lintian, mmdebstrap, ..., and the Python test
#                            peers into .venv (tests/requirements.txt)
#        deps.sh --list SET  print the packages of SET (demo, test-only,
#                            test), one a line; installs nothing
#        deps.sh --pin PKG...  print each PKG as it would be asked for
#        deps.sh --dry-run SET  say what SET would install and upgrade here;
#                            changes nothing (exit 0)
#
# The policy (docs/deployment.md "Dependencies"):
# - Only missing packages are asked for. apt installs what they depend on,
#   and upgrades an installed package only where a new one needs it (a
#   -dev package wants its library at the same version, lintian a newer
#   perl): that is how Debian works, and refusing it would leave a machine
#   installed a while ago with nothing. No blanket upgrade ever: a -dev
#   package whose runtime library is installed is asked for at the
#   runtime's version (libsystemd-dev=<libsystemd0's>) so that nothing is
#   upgraded that can stay.
# - Before anything changes, deps.sh prints every package apt will install
#   and every one it will upgrade (from which version to which), and the
#   download size. The plan is made without touching the machine: foreign
#   architectures (s390x, arm64 for the test set) are planned in a private
#   apt state under a temporary folder; the only thing done before the
#   answer is `apt-get update` of the machine's own package lists, which
#   apt would need anyway to say what it installs.
# - Then it goes on only when accepted: the answer y at the prompt in a
#   terminal, or DEPS_YES=1, or CI=true (a CI job has no terminal). Without
#   a terminal and without either, it stops after the list (exit 1). Only
#   after the answer are dpkg architectures added and packages installed.
set -eu
cd "$(dirname "$0")/.."

# What `make` (all) and `make demo` need. No test tool here: check-dep-split
# (mk/check-dep-split.sh, in make check) fails if one appears.
DEMO_PKGS="build-essential pkg-config libjansson-dev libgpiod-dev \
 libinih-dev libsystemd-dev libmosquitto-dev libmicrohttpd-dev libnanopb-dev mbpoll"
# Debian 13 (trixie) packages open62541 1.4: there the daemon is built with
# its OPC UA side (docs/opcua.md); Debian 12 has no package of it and builds
# the daemon without (docs/deployment.md "Supported releases").
codename=$(sed -n 's/^VERSION_CODENAME=//p' /etc/os-release 2>/dev/null || true)
case $codename in
    ""|bookworm) ;;
    *) DEMO_PKGS="$DEMO_PKGS libopen62541-1.4-dev" ;;
esac
# What make check adds: unit tests, cross and big-endian builds, firmware,
# sanitizers, static analysis, coverage, captures, peers, the Debian
# packages (check-deb: debhelper, lintian, mmdebstrap; check-arm64: the
# arm64 cross compiler), the fresh roots (check-fresh: mmdebstrap, zstd),
# the library as a CMake component and its ABI (check-cmake: cmake;
# check-abi: abigail-tools), libmodbus for the Modbus fuzzer and benchmark.
# Names that both bookworm and trixie have (libclang-rt-dev: the runtime
# of the release's default clang).
TEST_PKGS="libcmocka-dev libmodbus-dev gpiod \
 clang libclang-rt-dev gcc-arm-none-eabi libnewlib-arm-none-eabi \
 gcc-s390x-linux-gnu libc6-dev-s390x-cross qemu-user \
 tshark socat python3-venv iproute2 valgrind cppcheck clang-tidy gcovr \
 liblwip-dev mosquitto openssl \
 debhelper lintian mmdebstrap zstd gcc-aarch64-linux-gnu libc6-dev-arm64-cross \
 chromium chromium-driver prometheus nanopb nodejs cmake abigail-tools"
# Need `dpkg --add-architecture`: the big-endian test runtime (check-be),
# and the packages' arm64 build dependencies (check-arm64: dpkg-buildpackage
# -a arm64; pkgconf:arm64 is aarch64-linux-gnu-pkg-config).
CROSS_PKGS="libcmocka-dev:s390x libinih-dev:s390x \
 pkgconf:arm64 libjansson-dev:arm64 libgpiod-dev:arm64 \
 libinih-dev:arm64 libsystemd-dev:arm64 libmosquitto-dev:arm64 \
 libmicrohttpd-dev:arm64 libnanopb-dev:arm64"
case $codename in
    ""|bookworm) ;;
    *) CROSS_PKGS="$CROSS_PKGS libopen62541-1.4-dev:arm64" ;;
esac

# DEPS_ADMINDIR=DIR (a dpkg status in DIR/status, e.g. mk/minimal-root.sh's):
# --dry-run plans as on the machine DIR describes, and a user other than
# root gets the hint for that machine (check-dep-split tests both).
ADMIN=${DEPS_ADMINDIR:-/var/lib/dpkg}
APT_OPTS="-o Dir::State::status=$ADMIN/status"

say() { echo "deps: $*"; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

list_set() { # SET
    case "$1" in
        demo) echo $DEMO_PKGS ;;
        test-only) echo $TEST_PKGS $CROSS_PKGS ;;
        test) echo $DEMO_PKGS $TEST_PKGS $CROSS_PKGS ;;
        *) echo "deps: unknown set '$1' (demo, test-only, test)" >&2; exit 2 ;;
    esac | tr ' ' '\n' | sed '/^$/d'
}

installed() { dpkg-query --admindir="$ADMIN" -W -f='${Status}' "$1" 2>/dev/null | grep -q 'ok installed'; }

# The version to ask for: a package built from the same source as an
# installed one (libsystemd-dev and libsystemd0) is pinned at the installed
# one's version when apt has it, so nothing installed needs an upgrade.
pins() { # PKG...
    # "package source" of each PKG (one apt-cache call for all of them)
    # shellcheck disable=SC2046,SC2086
    apt-cache $APT_OPTS show --no-all-versions $(printf '%s\n' "$@" | sed 's/:.*//') 2>/dev/null |
        awk -F': ' '$1 == "Package" { p = $2; s = $2 }
                    $1 == "Source" { s = $2; sub(/ .*/, "", s) }
                    $0 == "" && p != "" { print p, s; p = "" }
                    END { if (p != "") print p, s }' > "$tmp/src"
    dpkg-query --admindir="$ADMIN" -W -f='${source:Package} ${Version} ${Status}\n' 2>/dev/null |
        awk '/ok installed/ { print $1, $2 }' | sort -u > "$tmp/have"
    # "package version" of every version the archive has (one call)
    # shellcheck disable=SC2046,SC2086
    apt-cache $APT_OPTS madison $(printf '%s\n' "$@" | sed 's/:.*//') 2>/dev/null |
        awk -F'|' '{ gsub(/ /, ""); print $1, $2 }' > "$tmp/archive"
    for p in "$@"; do
        src=$(awk -v p="${p%%:*}" '$1 == p { print $2; exit }' "$tmp/src")
        have=$(awk -v s="${src:-$p}" '$1 == s { print $2; exit }' "$tmp/have")
        if [ -n "$have" ] && grep -qxF "${p%%:*} $have" "$tmp/archive"; then
            echo "$p=$have"
        else
            echo "$p"
        fi
    done
}

missing_of() { # SET
    for p in $(list_set "$1"); do installed "$p" || printf ' %s' "$p"; done
    # npm (the Sparkplug tests' Eclipse Tahu host): Debian's package, unless
    # the Node.js installed brings its own (NodeSource's conflicts with it)
    case "$1" in test*)
        installed npm || { installed nodejs && command -v npm >/dev/null; } || printf ' npm' ;;
    esac
}

# The foreign architectures the packages name (s390x, arm64) that dpkg does
# not have yet.
new_archs() { # PKG...
    printf '%s\n' "$@" | sed -n 's/^[^:]*:\([a-z0-9]*\)$/\1/p' | sort -u |
        while read -r a; do
            dpkg --print-foreign-architectures 2>/dev/null | grep -qx "$a" || echo "$a"
        done
}

# A private apt state for planning with the architectures in $archs, which
# dpkg does not have yet: the machine's sources, lists fetched into $tmp;
# nothing of the machine changes (the lists, dpkg's architectures).
# A foreign architecture whose lists cannot be had is left out (see
# update_failed): its name goes to $dropped, and $archs keeps the others.
private_state() {
    base_opts=$APT_OPTS dropped=
    while [ -n "$archs" ]; do
        rm -rf "$tmp/lists" "$tmp/cache"
        mkdir -p "$tmp/lists/partial" "$tmp/cache/archives/partial"
        chmod 755 "$tmp" # apt's download user reads and writes the lists there
        APT_OPTS="$base_opts -o Dir::State::Lists=$tmp/lists -o Dir::Cache=$tmp/cache"
        APT_OPTS="$APT_OPTS -o APT::Architectures::=$(dpkg --print-architecture)"
        for a in $(dpkg --print-foreign-architectures) $archs; do
            APT_OPTS="$APT_OPTS -o APT::Architectures::=$a"
        done
        say "planning with architecture(s) $archs in a private apt state (nothing added yet)"
        # shellcheck disable=SC2086
        apt-get $APT_OPTS update -qq >/dev/null 2>"$tmp/update.err" && return 0
        # A mirror caught mid-sync serves a foreign index that does not
        # match its Release file (seen for trixie-security's and
        # trixie-updates' s390x lists here), and apt then ignores that
        # whole suite, security updates included, for every architecture:
        # arm64 libraries could no longer match their amd64 siblings.
        # Leave that architecture out this time; the checks that need it
        # say SKIPPED (a failure under CI).
        bad=$(for a in $archs; do grep -q "binary-$a/" "$tmp/update.err" && echo "$a"; done | tr '\n' ' ')
        if [ -z "$bad" ]; then update_failed "$tmp/update.err"; return 0; fi
        grep '^E: Failed' "$tmp/update.err" | sed 's/^/  /' >&2
        say "the archive's package lists for $bad cannot be had now (above: a mirror mid-sync?): leaving out the packages for $bad this time; the checks that need them will say SKIPPED"
        dropped="$dropped $bad"
        archs=$(for a in $archs; do case " $bad " in *" $a "*) ;; *) echo "$a" ;; esac; done | tr '\n' ' ')
    done
    APT_OPTS=$base_opts # no foreign architecture left: the machine's own lists
    [ -n "$dry" ] || apt-get update -qq 2>"$tmp/update.err" || update_failed "$tmp/update.err"
}

# A mirror caught mid-sync serves an index that does not match its Release
# file (seen for trixie-security's s390x Packages): apt ignores that list.
# Planning goes on with what apt has; if a package then cannot be found,
# the plan says which.
update_failed() { # ERRORS
    grep -v '^W: ' "$1" | sed 's/^/  /' >&2
    say "apt-get update could not fetch every package list (above): going on with those it has"
}

# apt's plan for the packages in $@: its "Inst" lines; an upgrade carries the
# installed version in brackets ("Inst perl [5.36.0-7] (5.36.0-7+deb12u3 ...)").
plan() { # shellcheck disable=SC2086
    apt-get $APT_OPTS -s -q install --no-upgrade --no-install-recommends "$@" 2>"$tmp/plan.err" |
        grep '^Inst ' || { cat "$tmp/plan.err" >&2; return 1; }
}

# show_plan FILE: what apt will install and what it will upgrade, by name.
show_plan() {
    n_new=$(awk '$3 !~ /^\[/' "$1" | grep -c . || true)
    n_up=$(awk '$3 ~ /^\[/' "$1" | grep -c . || true)
    say "apt-get will install $n_new new packages:"
    awk '$3 !~ /^\[/ { v = $3; gsub(/[()]/, "", v); printf "  %s %s\n", $2, v }' "$1"
    if [ "$n_up" -gt 0 ]; then
        say "and upgrade $n_up installed packages, which the new ones need at a newer version:"
        awk '$3 ~ /^\[/ { o = $3; n = $4; gsub(/[][()]/, "", o); gsub(/[()]/, "", n)
                          printf "  %s %s -> %s\n", $2, o, n }' "$1"
    fi
}

accepted() {
    [ "${DEPS_YES:-}" = 1 ] && { say "accepted by DEPS_YES=1"; return 0; }
    if [ -t 0 ] && [ -t 1 ]; then
        printf 'deps: go on? [Y/n] '
        read -r answer || answer=n
        case "$answer" in [nN]*) return 1 ;; *) return 0 ;; esac
    fi
    [ "${CI:-}" = true ] && { say "accepted by CI=true"; return 0; }
    say "no terminal to ask: run again with DEPS_YES=1 to accept this list"
    return 1
}

# install_missing WHAT PKG...: plan, show, ask, then install (see the header).
install_missing() {
    what=$1; shift
    say "missing for '$what': $*"
    archs=$(new_archs "$@" | tr '\n' ' ')
    if [ -z "$dry" ] && [ "$(id -u)" != 0 ]; then
        pre=
        for a in $archs; do pre="${pre}dpkg --add-architecture $a && "; done
        echo "deps: run as root, or: sudo sh -c '${pre}apt-get update && apt-get install --no-install-recommends $*'" >&2
        exit 1
    fi
    if [ -n "$archs" ]; then
        private_state
        if [ -n "$dropped" ]; then
            # shellcheck disable=SC2046
            set -- $(for p in "$@"; do
                         case " $dropped " in *" ${p##*:} "*) ;; *) echo "$p" ;; esac; done)
        fi
    elif [ -z "$dry" ]; then
        apt-get update -qq 2>"$tmp/update.err" || update_failed "$tmp/update.err"
    fi
    args=$(pins "$@" | tr '\n' ' ')
    # shellcheck disable=SC2086
    if ! plan $args > "$tmp/plan" 2>/dev/null; then
        # A pinned version that cannot be had beside the rest (an arm64
        # library at the version of its older amd64 sibling that the
        # archive no longer has): let apt choose, upgrading what it needs.
        args="$*"
        # shellcheck disable=SC2086
        plan $args > "$tmp/plan" || { say "apt cannot plan this install (above)"; exit 1; }
    fi
    show_plan "$tmp/plan"
    # (apt's own lines too, for scripts: mk/check-dep-split.sh reads them)
    [ -z "$dry" ] || sed 's/^/deps: would: /' "$tmp/plan"
    # shellcheck disable=SC2086
    apt-get $APT_OPTS install -q --print-uris -y --no-upgrade --no-install-recommends $args 2>/dev/null |
        awk '/^Need to get/ { print "deps: " $0 }'
    [ -z "$dry" ] || return 0
    accepted || { say "nothing installed" >&2; exit 1; }
    for a in $archs; do
        say "adding dpkg architecture $a"; dpkg --add-architecture "$a"
    done
    [ -z "$archs" ] || apt-get update -qq 2>"$tmp/update.err" || update_failed "$tmp/update.err"
    export DEBIAN_FRONTEND=noninteractive
    # tshark asks whether non-root users may capture; the default (no) is fine.
    case " $* " in *" tshark "*)
        echo "wireshark-common wireshark-common/install-setuid boolean false" | debconf-set-selections ;;
    esac
    # shellcheck disable=SC2086
    apt-get install -y -q --no-upgrade --no-install-recommends $args > "$tmp/install.log" 2>&1 || {
        tail -20 "$tmp/install.log" >&2; say "apt-get install failed (above)"; exit 1; }
    say "installed: $*"
}

set_arg=
case "${1:-}" in
    --list) list_set "${2:?--list SET}"; exit 0 ;;
    --pin) shift; pins "$@"; exit 0 ;;
    --dry-run) set_arg=${2:?--dry-run SET}; dry=1 ;;
    demo|test) [ -z "${DEPS_ADMINDIR:-}" ] || [ "$(id -u)" != 0 ] ||
        { echo "deps: DEPS_ADMINDIR is for --dry-run (or a user's hint) only" >&2; exit 2; }
        set_arg=$1; dry= ;;
    *) echo "usage: deps.sh demo|test | --list SET | --dry-run SET" >&2; exit 2 ;;
esac

missing=$(missing_of "$set_arg")
if [ -n "$missing" ]; then
    # shellcheck disable=SC2086
    install_missing "$set_arg" $missing
else
    say "the $set_arg packages are installed already: nothing to install"
fi

[ "$set_arg" = test ] || exit 0

# Eclipse Tahu's JavaScript Sparkplug packages (tests/gateway/test_sparkplug_tck.py),
# and axe-core (the console's accessibility check, tests/gateway/
# test_console_commissioning.py), each pinned by its package-lock.json,
# into tests/DIR/node_modules.
for d in tahu axe; do
    lock=tests/$d/package-lock.json
    nstamp=tests/$d/node_modules/.lock.stamp
    if [ -f "$lock" ] && ! cmp -s "$lock" "$nstamp" 2>/dev/null; then
        say "npm ci in tests/$d (pinned by its package-lock.json)"
        if [ -z "$dry" ]; then
            (cd tests/$d && npm ci --no-audit --no-fund --ignore-scripts --loglevel=error) ||
                { say "npm ci in tests/$d failed (above)"; exit 1; }
            cp "$lock" "$nstamp"
        fi
    fi
done

# Python test peers, pinned, in a venv under the repository.
req=tests/requirements.txt
stamp=.venv/.requirements.stamp
if [ -f "$req" ]; then
    if [ ! -x .venv/bin/python ]; then
        say "creating .venv for the Python test peers"
        [ -n "$dry" ] || python3 -m venv .venv
    fi
    if ! cmp -s "$req" "$stamp" 2>/dev/null; then
        say "pip install -r $req into .venv"
        if [ -z "$dry" ]; then
            .venv/bin/pip install -q --disable-pip-version-check -r "$req"
            cp "$req" "$stamp"
        fi
    fi
fi
