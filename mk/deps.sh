#!/bin/sh
# SPDX-License-Identifier: MIT
# Install what a set of targets needs on Debian bookworm, and only what is
# missing, without upgrading anything already installed.
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
#        deps.sh --dry-run SET  say what SET would install here; installs
#                            nothing (exit 0)
#
# Nothing is upgraded: apt-get install --no-upgrade on the missing packages
# only, and a -dev package whose runtime library is installed is asked for
# at the runtime's version (libsystemd-dev=<libsystemd0's>), so apt does not
# upgrade libsystemd0, systemd and libudev1 to match a newer -dev. If apt
# would still upgrade something, deps.sh names it and stops. Before it
# installs, it prints every package apt will install and the download size,
# and in a terminal asks to go on (DEPS_YES=1 does not ask; CI has no
# terminal).
set -eu
cd "$(dirname "$0")/.."

# What `make` (all) and `make demo` need. No test tool here: check-dep-split
# (mk/check-dep-split.sh, in make check) fails if one appears.
DEMO_PKGS="build-essential pkg-config libjansson-dev libmodbus-dev libgpiod-dev \
 libinih-dev libsystemd-dev libmosquitto-dev libmicrohttpd-dev libnanopb-dev mbpoll"
# What make check adds: unit tests, cross and big-endian builds, firmware,
# sanitizers, static analysis, coverage, captures, peers, the Debian
# packages (check-deb: debhelper, lintian, mmdebstrap; check-arm64: the
# arm64 cross compiler).
TEST_PKGS="libcmocka-dev gpiod \
 clang libclang-rt-14-dev gcc-arm-none-eabi libnewlib-arm-none-eabi \
 gcc-s390x-linux-gnu libc6-dev-s390x-cross qemu-user \
 tshark socat python3-venv iproute2 valgrind cppcheck clang-tidy gcovr \
 liblwip-dev mosquitto openssl \
 debhelper lintian mmdebstrap gcc-aarch64-linux-gnu libc6-dev-arm64-cross \
 chromium chromium-driver prometheus nanopb"
# Need `dpkg --add-architecture`: the big-endian test runtime (check-be),
# and the packages' arm64 build dependencies (check-arm64: dpkg-buildpackage
# -a arm64; pkgconf:arm64 is aarch64-linux-gnu-pkg-config).
CROSS_PKGS="libcmocka-dev:s390x libinih-dev:s390x \
 pkgconf:arm64 libjansson-dev:arm64 libmodbus-dev:arm64 libgpiod-dev:arm64 \
 libinih-dev:arm64 libsystemd-dev:arm64 libmosquitto-dev:arm64 \
 libmicrohttpd-dev:arm64 libnanopb-dev:arm64"

# DEPS_ADMINDIR=DIR (a dpkg status in DIR/status, e.g. mk/minimal-root.sh's):
# --dry-run plans as on the machine DIR describes (check-dep-split).
ADMIN=${DEPS_ADMINDIR:-/var/lib/dpkg}
APT_STATUS="-o Dir::State::status=$ADMIN/status"

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
    # shellcheck disable=SC2046
    apt-cache show --no-all-versions $(printf '%s\n' "$@" | sed 's/:.*//') 2>/dev/null |
        awk -F': ' '$1 == "Package" { p = $2; s = $2 }
                    $1 == "Source" { s = $2; sub(/ .*/, "", s) }
                    $0 == "" && p != "" { print p, s; p = "" }
                    END { if (p != "") print p, s }' > "$tmp/src"
    dpkg-query --admindir="$ADMIN" -W -f='${source:Package} ${Version} ${Status}\n' 2>/dev/null |
        awk '/ok installed/ { print $1, $2 }' | sort -u > "$tmp/have"
    for p in "$@"; do
        src=$(awk -v p="${p%%:*}" '$1 == p { print $2; exit }' "$tmp/src")
        have=$(awk -v s="${src:-$p}" '$1 == s { print $2; exit }' "$tmp/have")
        if [ -n "$have" ] && apt-cache madison "${p%%:*}" 2>/dev/null |
                awk -F'|' '{ gsub(/ /, "", $2); print $2 }' | grep -qxF "$have"; then
            echo "$p=$have"
        else
            echo "$p"
        fi
    done
}

missing_of() { # SET
    for p in $(list_set "$1"); do installed "$p" || printf ' %s' "$p"; done
}

# apt's plan for the packages in $args: "Inst" lines; upgrades carry the
# installed version in brackets ("Inst systemd [252.30-1] (252.39-1 ...)").
plan() { apt-get $APT_STATUS -s -q install --no-upgrade --no-install-recommends "$@" 2>/dev/null | grep '^Inst '; }

set_arg=
case "${1:-}" in
    --list) list_set "${2:?--list SET}"; exit 0 ;;
    --pin) shift; pins "$@"; exit 0 ;;
    --dry-run) set_arg=${2:?--dry-run SET}; dry=1 ;;
    demo|test) [ -z "${DEPS_ADMINDIR:-}" ] ||
        { echo "deps: DEPS_ADMINDIR is for --dry-run only" >&2; exit 2; }
        set_arg=$1; dry= ;;
    *) echo "usage: deps.sh demo|test | --list SET | --dry-run SET" >&2; exit 2 ;;
esac

# install_missing WHAT OPTIONAL PKG...: install the missing PKGs (see the
# header). OPTIONAL=yes: if they would upgrade something, say so and go on
# without them (the check that needs them skips) instead of stopping.
updated=
install_missing() {
    what=$1 optional=$2; shift 2
    missing=" $*"
    # shellcheck disable=SC2086
    args=$(pins $missing | tr '\n' ' ')
    say "missing for '$what':$missing"
    if [ -n "$dry" ]; then
        # shellcheck disable=SC2086
        plan $args | sed 's/^/deps: would: /' || true
        return 0
    fi
    if [ "$(id -u)" != 0 ]; then
        echo "deps: run as root, or: sudo apt-get install --no-upgrade --no-install-recommends$args" >&2
        exit 1
    fi
    for arch in s390x arm64; do
        case "$missing" in *:$arch*)
            dpkg --print-foreign-architectures | grep -qx $arch ||
                { say "adding dpkg architecture $arch (test runtime and cross builds)"; dpkg --add-architecture $arch; updated=; } ;;
        esac
    done
    export DEBIAN_FRONTEND=noninteractive
    [ -n "$updated" ] || { apt-get update -qq; updated=1; }
    # shellcheck disable=SC2086
    p=$(plan $args) || true
    up=$(printf '%s\n' "$p" | awk '$3 ~ /^\[/ { print $2 }' | tr '\n' ' ')
    if [ -n "$up" ]; then
        echo "deps: installing$args would upgrade installed packages: $up" >&2
        if [ "$optional" = yes ]; then
            echo "deps: not done (the checks that need them will say SKIPPED); install them yourself if you accept that" >&2
            return 0
        fi
        echo "deps: not done; install them yourself if you accept that" >&2
        exit 1
    fi
    say "apt-get will install $(printf '%s\n' "$p" | grep -c .) packages:"
    printf '%s\n' "$p" | awk '{ printf "  %s %s\n", $2, $3 }' | tr -d '()'
    # shellcheck disable=SC2086
    apt-get install -q --print-uris -y --no-upgrade --no-install-recommends $args 2>/dev/null |
        awk '/^Need to get/ { print "deps: " $0 }'
    # In a terminal, the user accepts the list first (DEPS_YES=1: do not ask).
    if [ -t 0 ] && [ -t 1 ] && [ -z "${DEPS_YES:-}" ]; then
        printf 'deps: install them? [Y/n] '
        read -r answer || answer=n
        case "$answer" in [nN]*) echo "deps: nothing installed" >&2; exit 1 ;; esac
    fi
    # tshark asks whether non-root users may capture; the default (no) is fine.
    case "$missing" in *tshark*)
        echo "wireshark-common wireshark-common/install-setuid boolean false" | debconf-set-selections ;;
    esac
    # shellcheck disable=SC2086
    apt-get install -y -qq --no-upgrade --no-install-recommends $args >/dev/null
    say "installed$missing"
}

missing=$(missing_of "$set_arg")
# The arm64 build dependencies (multiarch: each must be at the version of
# its installed amd64 sibling, which an out-of-date machine does not have
# in the archive any more) are optional: without them check-arm64 skips.
main=$(printf '%s\n' $missing | grep . | grep -v ':arm64$' | tr '\n' ' ')
arm64=$(printf '%s\n' $missing | grep ':arm64$' | tr '\n' ' ')
[ -n "$missing" ] || say "the $set_arg packages are installed already: nothing to install"
# shellcheck disable=SC2086
[ -z "$main" ] || install_missing "$set_arg" no $main
# shellcheck disable=SC2086
[ -z "$arm64" ] || install_missing "$set_arg (arm64 build dependencies)" yes $arm64

[ "$set_arg" = test ] || exit 0

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
