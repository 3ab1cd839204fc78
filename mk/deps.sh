#!/bin/sh
# SPDX-License-Identifier: MIT
# Install what `make check` needs on Debian bookworm, and only what is
# missing: system packages through apt-get (as root), Python test peers into
# .venv from tests/requirements.txt (versions pinned there).
set -eu
cd "$(dirname "$0")/.."

PKGS="build-essential pkg-config libcmocka-dev libjansson-dev \
 libmodbus-dev libgpiod-dev gpiod libinih-dev libsystemd-dev \
 clang libclang-rt-14-dev gcc-arm-none-eabi libnewlib-arm-none-eabi \
 gcc-s390x-linux-gnu libc6-dev-s390x-cross qemu-user \
 tshark mbpoll socat python3-venv iproute2 valgrind cppcheck clang-tidy gcovr \
 liblwip-dev libmosquitto-dev mosquitto openssl"
CROSS_PKGS="libcmocka-dev:s390x libinih-dev:s390x"

missing=""
for p in $PKGS $CROSS_PKGS; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'ok installed'; then
        missing="$missing $p"
    fi
done

if [ -n "$missing" ]; then
    echo "deps: missing Debian packages:$missing"
    if [ "$(id -u)" != 0 ]; then
        echo "deps: run as root, or: sudo apt-get install$missing" >&2
        exit 1
    fi
    case "$missing" in *:s390x*)
        dpkg --print-foreign-architectures | grep -qx s390x ||
            { echo "deps: adding dpkg architecture s390x (big-endian test runtime)"; dpkg --add-architecture s390x; } ;;
    esac
    echo "deps: apt-get install$missing"
    export DEBIAN_FRONTEND=noninteractive
    # tshark asks whether non-root users may capture; the default (no) is fine.
    echo "wireshark-common wireshark-common/install-setuid boolean false" | debconf-set-selections
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends $missing >/dev/null
    echo "deps: installed$missing"
fi

# Python test peers, pinned, in a venv under the repository.
req=tests/requirements.txt
stamp=.venv/.requirements.stamp
if [ -f "$req" ]; then
    if [ ! -x .venv/bin/python ]; then
        echo "deps: creating .venv for the Python test peers"
        python3 -m venv .venv
    fi
    if ! cmp -s "$req" "$stamp" 2>/dev/null; then
        echo "deps: pip install -r $req into .venv"
        .venv/bin/pip install -q --disable-pip-version-check -r "$req"
        cp "$req" "$stamp"
    fi
fi
