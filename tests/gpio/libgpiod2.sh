#!/bin/sh
# SPDX-License-Identifier: MIT
# Builds libgpiod 2 (static) from the C sources that the gpiod Python
# bindings' sdist on PyPI bundles (lib/*.c, include/gpiod.h), so the v2
# backend can be compiled and tested on Debian bookworm, which ships only
# libgpiod 1.6.
#
# usage: libgpiod2.sh CACHE PIP_SPEC OUTDIR CC
#   -> OUTDIR/libgpiod.a, OUTDIR/include/gpiod.h
# Exit 0 when they are ready; 1 (with the reason) when they cannot be had,
# which the caller reports as a skip.
set -eu
cache=$1 spec=$2 out=$3 cc=$4
name=${spec%%==*}
ver=${spec#*==}
stamp=$out/.spec

if [ -f "$out/libgpiod.a" ] && [ "$(cat "$stamp" 2>/dev/null)" = "$spec" ]; then
    exit 0
fi
mkdir -p "$cache/pypi"
sdist=$cache/pypi/$name-$ver.tar.gz
if [ ! -f "$sdist" ]; then
    pip=""
    for p in "python3 -m pip" pip3 .venv/bin/pip; do
        if $p --version >/dev/null 2>&1; then pip=$p; break; fi
    done
    [ -n "$pip" ] || { echo "libgpiod2: no pip to fetch the $spec sdist"; exit 1; }
    echo "libgpiod2: fetching the $spec sdist (libgpiod 2 C sources) from PyPI"
    tmp=$(mktemp -d)
    if ! $pip download -q --disable-pip-version-check --no-deps \
            --no-binary :all: -d "$tmp" "$spec" >"$tmp/log" 2>&1; then
        tail -n 5 "$tmp/log"
        rm -rf "$tmp"
        echo "libgpiod2: pip download $spec failed"
        exit 1
    fi
    mv "$tmp/$name-$ver.tar.gz" "$sdist" 2>/dev/null ||
        { echo "libgpiod2: pip saved no $name-$ver.tar.gz"; rm -rf "$tmp"; exit 1; }
    rm -rf "$tmp"
fi

rm -rf "$out"
mkdir -p "$out/src" "$out/include" "$out/obj"
tar -xzf "$sdist" -C "$out/src" --strip-components=1 \
    --wildcards "$name-$ver/lib/*" "$name-$ver/include/*" \
    "$name-$ver/libgpiod-version.txt" 2>/dev/null || true
if [ ! -f "$out/src/include/gpiod.h" ] || ! ls "$out/src/lib/"*.c >/dev/null 2>&1; then
    echo "libgpiod2: $spec sdist carries no libgpiod C sources"
    exit 1
fi
api=$(cat "$out/src/libgpiod-version.txt" 2>/dev/null || echo 2)
echo "libgpiod2: building libgpiod $api from $spec"
for c in "$out/src/lib/"*.c; do
    o=$out/obj/$(basename "$c" .c).o
    # Their code, their dialect: GNU C, no -Werror.
    $cc -O2 -g -fPIC -D_GNU_SOURCE -DGPIOD_API_VERSION_STR="\"$api\"" \
        -I"$out/src/include" -I"$out/src/lib" -c "$c" -o "$o" ||
        { echo "libgpiod2: $c does not build"; exit 1; }
done
ar rcs "$out/libgpiod.a" "$out/obj/"*.o
cp "$out/src/include/gpiod.h" "$out/include/"
echo "$spec" > "$stamp"
