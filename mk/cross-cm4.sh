#!/bin/sh
# SPDX-License-Identifier: MIT
# The codec must build for a Cortex-M4 without an OS: compile the codec
# sources with arm-none-eabi-gcc (newlib), report .text/.data/.bss, and
# refuse any reference outside <string.h> and the compiler's own helpers
# (no malloc, no stdio). The sizes are recorded in docs/codec.md; growing
# more than 10% past the recorded total .text fails.
#
# usage: cross-cm4.sh RESULTS SOURCE...       check; add a line to RESULTS
#        cross-cm4.sh --write-docs SOURCE...  record the sizes in docs/codec.md
# WARN (from the Makefile) holds the warning flags; CM4_BUILD the object dir.
#
# The same check serves the whole firmware library (make check-firmware:
# every lib/ source but the POSIX ones) with CM4_NAME=firmware, the figures
# in CM4_DOC=docs/firmware.md, CM4_ALLOW more C-library calls (the text
# conversions of lib/text.c), CM4_SUBTOTAL the objects of a subtotal row
# (the codec's) and CM4_WHAT the name of what is built.
set -eu
cd "$(dirname "$0")/.."

CROSS=${CM4_CROSS:-arm-none-eabi-}
CFLAGS_CM4="-mcpu=cortex-m4 -mthumb -Os"
WARN=${WARN:--std=c99 -Wall -Wextra -Wpedantic -Werror}
name=${CM4_NAME:-cm4}
what=${CM4_WHAT:-codec}
out=${CM4_BUILD:-build/$name}
doc=${CM4_DOC:-docs/codec.md}
begin="<!-- BEGIN $name footprint (make docs): do not edit -->"
end="<!-- END $name footprint -->"
# What the code may call: mk/cm4-symbols.sh (CM4_ALLOW adds to it).
. mk/cm4-symbols.sh

write_docs=0
if [ "${1:-}" = "--write-docs" ]; then write_docs=1; results=; else results=${1:?usage}; fi
shift
[ $# -gt 0 ] || { echo "usage: $0 RESULTS|--write-docs SOURCE..." >&2; exit 2; }

result() { # passed failed
    [ -z "$results" ] || { mkdir -p "$(dirname "$results")"; echo "$1 $2 $name" >>"$results"; }
}

if ! command -v "${CROSS}gcc" >/dev/null 2>&1; then
    . tests/skip.sh
    skip_name="$name (Cortex-M4 build)" skip_results=$results skip_label=$name
    skip "${CROSS}gcc not found (install gcc-arm-none-eabi libnewlib-arm-none-eabi: make test-deps)"
fi

mkdir -p "$out"
# newlib's own headers first: the toolchain's freestanding <stdint.h> would
# otherwise hide the 64-bit PRI macros of newlib's <inttypes.h>.
newlib_inc=$(dirname "$(dirname "$("${CROSS}gcc" -print-file-name=libc.a)")")/include
objs=
for src in "$@"; do
    obj=$out/$(basename "$src" .c).o
    # shellcheck disable=SC2086 # flag lists are meant to split
    if ! "${CROSS}gcc" $CFLAGS_CM4 $WARN -isystem "$newlib_inc" -Ilib/include -c "$src" -o "$obj"; then
        echo "$name: FAIL: $src does not build for the Cortex-M4" >&2
        result 0 1; exit 1
    fi
    objs="$objs $obj"
done

# Undefined symbols that none of the objects defines must be allowed ones.
# shellcheck disable=SC2086
bad=$(cm4_disallowed "$out" $objs)
if [ -n "$bad" ]; then
    echo "$name: FAIL: the $what references symbols a bare-metal build must not need:" >&2
    echo "$bad" | sed 's/^/    /' >&2
    result 0 1; exit 1
fi

# Berkeley sizes: .text includes read-only data (the field table, texts).
# shellcheck disable=SC2086
"${CROSS}size" $objs | awk 'NR > 1 { sub(".*/", "", $6); print $6, $1, $2, $3 }' >"$out/sizes"
table() {
    echo "| object | .text | .data | .bss |"
    echo "|---|---:|---:|---:|"
    awk '{ printf "| %s | %d | %d | %d |\n", $1, $2, $3, $4; t += $2; d += $3; b += $4 }
         END { printf "| **total** | **%d** | **%d** | **%d** |\n", t, d, b }' "$out/sizes"
    if [ -n "${CM4_SUBTOTAL:-}" ]; then
        awk -v objs=" $CM4_SUBTOTAL " 'index(objs, " " $1 " ") { t += $2; d += $3; b += $4 }
             END { printf "| of which the codec | %d | %d | %d |\n", t, d, b }' "$out/sizes"
    fi
    echo
    echo "\`$("${CROSS}gcc" --version | head -n 1)\`, \`$CFLAGS_CM4\`."
}
total=$(awk '{ t += $2 } END { print t }' "$out/sizes")
echo "$name: $what for Cortex-M4 ($CFLAGS_CM4), no OS, no malloc:"
table | sed 's/^/    /'

if [ "$write_docs" = 1 ]; then
    tmp=$(mktemp)
    table >"$tmp.table"
    awk -v begin="$begin" -v end="$end" -v gen="$tmp.table" '
        $0 == begin { print; print ""; while ((getline line < gen) > 0) print line
                      skip = 1; next }
        $0 == end   { print ""; skip = 0 }
        !skip       { print }' "$doc" >"$tmp"
    if cmp -s "$tmp" "$doc"; then echo "$name: $doc is up to date"
    else cp "$tmp" "$doc"; echo "$name: recorded the footprint in $doc"; fi
    rm -f "$tmp" "$tmp.table"
    exit 0
fi

# The recorded total .text: the bold figure in the footprint block.
recorded=$(awk -v begin="$begin" -v end="$end" '
    $0 == begin { on = 1 } $0 == end { on = 0 }
    on && /\*\*total\*\*/ { gsub(/[*| ]+/, " "); split($0, f, " "); print f[2] }' "$doc")
if [ -z "$recorded" ]; then
    echo "$name: FAIL: no footprint recorded in $doc (run make docs)" >&2
    result 0 1; exit 1
fi
limit=$((recorded + recorded / 10))
if [ "$total" -gt "$limit" ]; then
    echo "$name: FAIL: .text is $total bytes, more than 10% above the $recorded recorded in $doc" >&2
    echo "$name: if the growth is wanted, record it with make docs" >&2
    result 0 1; exit 1
fi
if [ "$total" != "$recorded" ]; then
    echo "$name: note: .text is $total bytes, $doc records $recorded (make docs updates it)"
fi
echo "$name: ok"
result 1 0
