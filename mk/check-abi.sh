#!/bin/sh
# SPDX-License-Identifier: MIT
# check-abi: libdrgate.so against the ABI of its last release, committed in
# lib/abi/ (docs/api-changes.md, "ABI"). Fails when
#   - abidiff (libabigail, Debian abigail-tools) finds a change to a
#     function or variable the baseline exports, or to a type they reach
#     that the public headers define (lib/include/drgate/; the library's
#     private structures, which callers only point at, are left out), or a
#     removed symbol;
#   - a symbol was added to a version node the baseline already has (a
#     released node never changes: new symbols go into a new node of
#     lib/libdrgate.map);
#   - the library needs more storage than a program built against the
#     baseline's headers reserves (dr_client_size() > the baseline's
#     DR_CLIENT_STORAGE_SIZE, the same for the UDP port): such a program's
#     dr_client_init would be refused;
#   - a function the public headers declare is not exported, or a symbol
#     is exported without a version or outside the dr_ names;
#   - the soname differs from the baseline's: after a soname bump (the ABI
#     may break then) the baseline of the new soname is written with
#     `make abi-baseline`, and committed.
# The baseline is of one architecture (lib/abi/storage.txt says which);
# elsewhere the step says SKIPPED.
#
# usage: check-abi.sh RESULTS LIB_SO     check (make check-abi)
#        check-abi.sh --write LIB_SO      write the baseline (make abi-baseline)
# CC: the compiler of the library (for the storage probe).
set -u
cd "$(dirname "$0")/.."
hdr=lib/include/drgate
base=lib/abi/libdrgate.abi
store=lib/abi/storage.txt
cc=${CC:-cc}
write=0
if [ "${1:-}" = --write ]; then write=1; res=; else res=${1:-}; fi
so=${2:?usage: check-abi.sh RESULTS|--write LIB_SO}
label="libdrgate.so's ABI against lib/abi/ (mk/check-abi.sh)"

. tests/skip.sh
skip_name=check-abi skip_results=$res skip_label=$label
command -v abidiff >/dev/null && command -v abidw >/dev/null ||
    skip "no abidiff/abidw (Debian abigail-tools: make test-deps)"
[ -f "$so" ] || { echo "check-abi: no $so (make lib)" >&2; exit 2; }

t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT

# The sizes the library needs and the ones its headers reserve, from a
# program linked against it.
cat > "$t/probe.c" <<'EOF'
#include <stdio.h>
#include "drgate/client.h"
int main(void)
{
    printf("client %zu %zu\nudp_port %zu %zu\n", dr_client_size(),
           (size_t)DR_CLIENT_STORAGE_SIZE, dr_udp_port_size(), (size_t)DR_UDP_PORT_STORAGE_SIZE);
    return 0;
}
EOF
if ! "$cc" -std=c99 -I"$hdr/.." -o "$t/probe" "$t/probe.c" "$so" ||
        ! LD_LIBRARY_PATH=$(dirname "$so") "$t/probe" > "$t/sizes"; then
    echo "check-abi: the storage probe did not build or run against $so" >&2; exit 2
fi
machine=$("$cc" -dumpmachine)
soname=$(readelf -d "$so" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')
readelf -S "$so" | grep -q '\.debug_info' ||
    { echo "check-abi: $so has no debug information (CFLAGS without -g): abidw needs it" >&2; exit 2; }

if [ "$write" = 1 ]; then
    mkdir -p lib/abi
    abidw --headers-dir "$hdr" --drop-private-types --no-corpus-path --no-comp-dir-path \
        --out-file "$base" "$so" || exit 1
    {
        echo "# The ABI baseline's architecture and what its headers reserve (mk/check-abi.sh)."
        echo "machine $machine"
        echo "soname $soname"
        awk '{ print $1, $3 }' "$t/sizes"
    } > "$store"
    echo "check-abi: wrote $base and $store ($soname, $machine): commit them"
    exit 0
fi

. mk/check-lib.sh
[ -f "$base" ] && [ -f "$store" ] || { bad "no baseline in lib/abi/ (make abi-baseline)"; check_done; }
bmachine=$(awk '$1 == "machine" { print $2 }' "$store")
[ "$machine" = "$bmachine" ] || skip "the baseline is of $bmachine, this build of $machine"
bsoname=$(awk '$1 == "soname" { print $2 }' "$store")
if [ "$soname" != "$bsoname" ]; then
    bad "soname $soname, the baseline's $bsoname: write the new soname's baseline (make abi-baseline) and commit it"
    check_done
fi
ok "soname $soname, as the baseline's"

# Changes to what the baseline has (added symbols are looked at below).
abidiff --no-added-syms --hd2 "$hdr" "$base" "$so" > "$t/diff"; st=$?
if [ $((st & 3)) -ne 0 ]; then
    sed 's/^/    /' "$t/diff"; bad "abidiff failed (exit $st)"
elif [ $((st & 12)) -ne 0 ]; then
    sed 's/^/    /' "$t/diff"
    bad "abidiff: the ABI changed against $base (exit $st) without a soname bump"
else
    ok "abidiff: no change to the $(grep -c '<elf-symbol ' "$base") symbols of $base or the public types they reach"
fi

# Symbols added since: never in a node the baseline has.
# "name node" of the baseline's symbols (node "-": none)
awk -F"'" '/<elf-symbol / { v = "-"
        for (i = 1; i < NF; i++) { if ($i ~ /<elf-symbol name=$/) n = $(i + 1)
                                   if ($i ~ /[[:space:]]version=$/) v = $(i + 1) }
        print n, v }' "$base" | sort -u > "$t/old"
# (not the version nodes' own absolute symbols, type A)
nm -D --defined-only "$so" | awk '$2 != "A" { print $3 }' > "$t/now.raw"
sed 's/@@\{0,1\}/ /' "$t/now.raw" | sort -u > "$t/now"
awk '{ print $2 }' "$t/old" | sort -u > "$t/nodes"
added=$(join -v 1 "$t/now" "$t/old")
n_added=0 n_bad=0
for s in $(echo "$added" | awk 'NF { print $1 "@" $2 }'); do
    n_added=$((n_added + 1))
    node=${s#*@}
    if grep -qxF "$node" "$t/nodes"; then
        n_bad=$((n_bad + 1))
        bad "${s%@*} added to $node, a node of the released ABI: give it a new node in lib/libdrgate.map"
    fi
done
[ "$n_bad" = 0 ] && ok "$n_added symbol(s) added since the baseline, none in a released node"

# Nothing exported but versioned dr_ symbols.
stray=$(awk '$1 !~ /^dr_[a-z0-9_]+@@?DRGATE_[0-9.]+$/' "$t/now.raw" | tr '\n' ' ')
[ -z "$stray" ] && ok "every exported symbol is a dr_ name in a DRGATE_ node" ||
    bad "exported without a version or outside dr_: $stray"

# Every function the public headers declare is exported (a missing one
# links against the static library but not against the shared one).
for h in "$hdr"/*.h; do echo "#include \"drgate/$(basename "$h")\""; done > "$t/all.c"
"$cc" -std=c99 -I"$hdr/.." -aux-info "$t/aux" -fsyntax-only "$t/all.c" || { bad "the public headers do not compile"; check_done; }
grep "$hdr/" "$t/aux" | grep -v '\*/ static ' |
    sed -n 's/.*[ *]\(dr_[a-z0-9_]*\) (.*/\1/p' | sort -u > "$t/declared"
awk '{ print $1 }' "$t/now" | sort -u > "$t/exported"
missing=$(comm -23 "$t/declared" "$t/exported" | tr '\n' ' ')
[ -z "$missing" ] && ok "the $(wc -l < "$t/declared") functions the public headers declare are exported" ||
    bad "declared in $hdr/ but not exported (lib/libdrgate.map): $missing"

# Storage: what a program built against the baseline reserves must still
# be enough.
while read -r what need have; do
    reserved=$(awk -v w="$what" '$1 == w { print $2 }' "$store")
    if [ -z "$reserved" ]; then bad "$store has no $what storage size"
    elif [ "$need" -le "$reserved" ]; then
        ok "$what: the library needs $need bytes, a program built against the baseline reserves $reserved (these headers: $have)"
    else
        bad "$what: the library needs $need bytes, more than the $reserved a program built against the baseline reserves: dr_${what}_init would refuse it (a soname bump, or fewer bytes)"
    fi
done < "$t/sizes"
check_done
