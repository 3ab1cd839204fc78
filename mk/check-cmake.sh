#!/bin/sh
# SPDX-License-Identifier: MIT
# check-cmake: libdrgate as a CMake component, built the ways its users
# build it (docs/firmware.md, "CMake"; README "Building and installing"):
#   - add_subdirectory: tests/cmake/consumer with lib/ as a subdirectory and
#     -DDR_CLIENT_MAX_CONNS=4 set once: its dr_decode prints two images as
#     `drcli decode` does, byte for byte; the bound reached the library and
#     the program alike; the codec target links alone; the archives hold
#     the Makefile's codec and client sources;
#   - find_package: the same project against a staged `make install`
#     (lib/cmake/drgateConfig.cmake.in), linked with libdrgate.so (its
#     symbols bound to DRGATE_ versions) and with libdrgate.a
#     (drgate_USE_STATIC_LIBS); a version of another major and a bound the
#     installed library was not built with are refused at configure time;
#   - cross for a Cortex-M4: examples/firmware-cm4 with the toolchain file
#     lib/cmake/arm-none-eabi-cortex-m4.cmake: the archives leave undefined
#     only what check-firmware allows (mk/cm4-symbols.sh), and the linked
#     image has no heap, no stdio and no system call stubs;
#   - lib/CMakeLists.txt's version is the Makefile's.
# Build trees under BUILD/cmake (kept: a second run rebuilds only what
# changed). Warm: 3 s of wall time on an idle 2-core machine, 12 s beside
# a package build (1 s of CPU); cold 8 to 45 s (the library compiled
# three ways).
#
# usage: check-cmake.sh RESULTS BUILD VERSION "CODEC_SRC" "FW_SRC"
#   CODEC_SRC, FW_SRC: the Makefile's LIB_CODEC_SRC and LIB_FW_SRC
#   MAKE, CC from make; CM4_ALLOW: what the client may call (check-firmware's)
set -u
cd "$(dirname "$0")/.."
res=$1 b=$2 version=$3 codec_src=$4 fw_src=$5
label="libdrgate's CMake package: add_subdirectory, find_package, Cortex-M4 (mk/check-cmake.sh)"
. tests/skip.sh
skip_name=check-cmake skip_results=$res skip_label=$label
command -v cmake >/dev/null || skip "no cmake (make test-deps)"
. mk/check-lib.sh
top=$(pwd)
w=$top/$b/cmake
mkdir -p "$w"
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
drcli=$top/$b/drcli
log=$w/last.log

# run WHAT COMMAND...: COMMAND's output into $log; on failure, its end.
run() {
    what=$1; shift
    if "$@" > "$log" 2>&1; then return 0; fi
    tail -15 "$log" | sed 's/^/    | /'; bad "$what failed: $*"; return 1
}
# objects NAMES...: the sources' basenames as CMake names their objects
objects() { for s in "$@"; do basename "$s" | sed 's/$/.o/'; done | sort; }

cmake_version=$(sed -n 's/^project(drgate VERSION \([0-9.]*\) .*/\1/p' lib/CMakeLists.txt)
[ "$cmake_version" = "$version" ] && ok "lib/CMakeLists.txt says version $version, as the Makefile" ||
    bad "lib/CMakeLists.txt says version '$cmake_version', the Makefile $version"

# The images and what drcli makes of them (tests/cli's golden cases).
"$drcli" encode io_state cb_di=5 cb_do[16]=1 aio_type.ai1=1 ai[0]=0.1 ao[1]=31.5 tool_di=0x21 \
    version.major=2 version.minor=11 version.patch=7 robot_state=OPERATING servo_on=1 \
    power_button_pressed=1 > "$t/io_state.img" &&
"$drcli" encode joint_state position[1]=31.5 position[6]=-90 velocity[2]=0.1 \
    motor_temperature[3]=36.6 external_torque[6]=-1e-7 > "$t/joint_state.img" &&
"$drcli" decode io_state "$t/io_state.img" > "$t/io_state.want" &&
"$drcli" decode joint_state "$t/joint_state.img" > "$t/joint_state.want" ||
    { bad "drcli could not make the test images ($drcli)"; check_done; }

# same_as_drcli HOW DIR [ENV...]: DIR's dr_decode prints what drcli does.
same_as_drcli() {
    how=$1 dir=$2; shift 2
    for a in io_state joint_state; do
        if env "$@" "$dir/dr_decode" $a "$t/$a.img" > "$t/$a.got" 2>&1 &&
                cmp -s "$t/$a.want" "$t/$a.got"; then
            ok "$how: dr_decode $a prints what drcli decode does ($(wc -l < "$t/$a.got") lines)"
        else
            diff "$t/$a.want" "$t/$a.got" | head -10 | sed 's/^/    | /'
            bad "$how: dr_decode $a differs from drcli decode"
        fi
    done
}

# ---- add_subdirectory ----------------------------------------------------
d=$w/subdir
if run "cmake (add_subdirectory)" cmake -S tests/cmake/consumer -B "$d" -DDRGATE_SOURCE_DIR="$top/lib" \
        -DDRGATE_WERROR=ON -DDR_CLIENT_MAX_CONNS=4 &&
        run "build (add_subdirectory)" cmake --build "$d" -j2; then
    same_as_drcli add_subdirectory "$d"
    "$d/dr_codec" > "$t/codec" 2>&1 && ok "add_subdirectory: drgate::codec alone: $(cat "$t/codec")" ||
        bad "add_subdirectory: dr_codec (drgate::codec alone) failed: $(cat "$t/codec")"
    bounds=$("$d/dr_decode" --bounds)
    need=$(echo "$bounds" | sed -n 's/.* library=\([0-9]*\)$/\1/p')
    have=$(echo "$bounds" | sed -n 's/.* storage=\([0-9]*\) .*/\1/p')
    # The storage a default build needs (the one the Makefile builds).
    cat > "$t/size.c" <<'EOF'
#include <stdio.h>
#include "drgate/client.h"
int main(void) { printf("%zu\n", dr_client_size()); return 0; }
EOF
    full=$("${CC:-cc}" -std=c99 -Ilib/include -o "$t/size" "$t/size.c" "$top/$b/libdrgate.a" && "$t/size")
    case $bounds in
        DR_CLIENT_MAX_CONNS=4\ *)
            if [ -n "$need" ] && [ "$need" -le "$have" ] && [ "$need" -lt "${full:-0}" ]; then
                ok "add_subdirectory: -DDR_CLIENT_MAX_CONNS=4 reached the program and the library ($bounds; 16 connections: $full)"
            else bad "add_subdirectory: the library was not built with the program's bounds ($bounds; 16 connections: $full)"; fi ;;
        *) bad "add_subdirectory: the program did not get -DDR_CLIENT_MAX_CONNS=4 ($bounds)" ;;
    esac
    # shellcheck disable=SC2086
    want_codec=$(objects $codec_src)
    # shellcheck disable=SC2086
    want_client=$(objects $(for s in $fw_src; do case " $codec_src " in *" $s "*) ;; *) echo "$s" ;; esac; done) \
                          lib/transport_posix.c lib/client_posix.c)
    [ "$(ar t "$d/drgate/libdrgate_codec.a" | sort)" = "$want_codec" ] &&
        ok "libdrgate_codec.a holds the Makefile's codec: $(echo $want_codec)" ||
        bad "libdrgate_codec.a holds $(ar t "$d/drgate/libdrgate_codec.a" | tr '\n' ' '), the Makefile's codec is $(echo $want_codec)"
    [ "$(ar t "$d/drgate/libdrgate_client.a" | sort)" = "$want_client" ] &&
        ok "libdrgate_client.a holds the Makefile's client and the POSIX transport ($(echo "$want_client" | wc -l) objects)" ||
        bad "libdrgate_client.a holds $(ar t "$d/drgate/libdrgate_client.a" | tr '\n' ' '), expected $(echo $want_client)"
fi

# ---- find_package against a staged install --------------------------------
stage=$w/stage
rm -rf "$stage"
if run "make install into $stage" ${MAKE:-make} --no-print-directory install PREFIX=/usr DESTDIR="$stage"; then
    ok "make install PREFIX=/usr DESTDIR=...: $(cd "$stage" && ls usr/lib/cmake/drgate | tr '\n' ' ')"
    for kind in shared static; do
        d=$w/installed-$kind
        st=OFF; [ $kind = static ] && st=ON
        run "cmake (find_package, $kind)" cmake -S tests/cmake/consumer -B "$d" \
            -DCMAKE_PREFIX_PATH="$stage/usr" -Ddrgate_USE_STATIC_LIBS=$st &&
            run "build (find_package, $kind)" cmake --build "$d" -j2 || continue
        same_as_drcli "find_package, $kind" "$d" LD_LIBRARY_PATH="$stage/usr/lib"
        needed=$(readelf -d "$d/dr_decode" | sed -n 's/.*(NEEDED).*\[\(libdrgate[^]]*\)\]/\1/p')
        if [ $kind = shared ]; then
            nver=$(readelf --dyn-syms -W "$d/dr_decode" | grep -c ' dr_[a-z0-9_]*@DRGATE_2\.0')
            [ "$needed" = libdrgate.so.2 ] && [ "$nver" -ge 5 ] &&
                ok "find_package, shared: dr_decode needs libdrgate.so.2, its $nver dr_ symbols bound to DRGATE_2.0" ||
                bad "find_package, shared: NEEDED '$needed', $nver symbols @DRGATE_2.0"
        else
            [ -z "$needed" ] && ok "find_package, static: dr_decode needs no libdrgate.so" ||
                bad "find_package, static: dr_decode needs $needed"
        fi
    done
    if cmake -S tests/cmake/consumer -B "$w/refuse-version" -DCMAKE_PREFIX_PATH="$stage/usr" \
            -DDRGATE_WANT_VERSION=3.0 > "$t/v3" 2>&1; then
        bad "find_package(drgate 3.0) accepted the installed $version"
    else
        grep -q 'version: 2.0.0' "$t/v3" && ok "find_package(drgate 3.0) refused: the installed $version is another major" ||
            { sed 's/^/    | /' "$t/v3" | tail -8; bad "find_package(drgate 3.0) failed, but not for the version"; }
    fi
    if cmake -S tests/cmake/consumer -B "$w/refuse-bound" -DCMAKE_PREFIX_PATH="$stage/usr" \
            -DDR_CLIENT_MAX_CONNS=4 > "$t/b4" 2>&1; then
        bad "find_package accepted DR_CLIENT_MAX_CONNS=4 against a library built with 16"
    else
        grep -q 'DR_CLIENT_MAX_CONNS is 4, the installed library was built with 16' "$t/b4" &&
            ok "find_package refuses DR_CLIENT_MAX_CONNS=4: the installed library was built with 16" ||
            { sed 's/^/    | /' "$t/b4" | tail -8; bad "find_package with DR_CLIENT_MAX_CONNS=4 failed, but not for the bound"; }
    fi
fi

# ---- Cortex-M4 -------------------------------------------------------------
CROSS=arm-none-eabi-
. mk/cm4-symbols.sh
d=$w/cm4
if ! command -v ${CROSS}gcc >/dev/null; then
    if [ -n "${CI:-}" ]; then bad "no ${CROSS}gcc (make test-deps)"
    else echo "  (Cortex-M4 part SKIPPED: no ${CROSS}gcc; make test-deps)"; fi
elif run "cmake (Cortex-M4)" cmake -S examples/firmware-cm4 -B "$d" -DCMAKE_BUILD_TYPE=MinSizeRel \
        -DDRGATE_WERROR=ON && run "build (Cortex-M4)" cmake --build "$d" -j2; then
    codec_a=$d/drgate/libdrgate_codec.a client_a=$d/drgate/libdrgate_client.a
    # shellcheck disable=SC2086
    fw_objs=$(objects $fw_src)
    members=$({ ${CROSS}ar t "$codec_a"; ${CROSS}ar t "$client_a"; } 2>&1 | sort)
    [ "$members" = "$(echo "$fw_objs" | sed 's/\.o$/.obj/')" ] &&
        ok "Cortex-M4: the archives hold the sources of check-firmware, no POSIX object ($(echo "$members" | wc -l) objects)" ||
        bad "Cortex-M4: the archives hold $(echo $members), check-firmware builds $(echo $fw_objs)"
    badsyms=$(CM4_ALLOW= cm4_disallowed "$t" "$codec_a")
    [ -z "$badsyms" ] && ok "Cortex-M4: libdrgate_codec.a calls nothing but <string.h> and libgcc" ||
        bad "Cortex-M4: libdrgate_codec.a needs: $(echo $badsyms)"
    badsyms=$(cm4_disallowed "$t" "$codec_a" "$client_a")
    [ -z "$badsyms" ] && ok "Cortex-M4: the codec and client archives call nothing check-firmware refuses" ||
        bad "Cortex-M4: the archives need: $(echo $badsyms)"
    elf=$d/firmware.elf
    heap=$(${CROSS}nm "$elf" | awk '{ print $NF }' |
           grep -xE 'malloc|free|calloc|realloc|_malloc_r|_sbrk|_sbrk_r|_write|_read|_open|_close|_fstat|printf|socket|clock_gettime' |
           tr '\n' ' ')
    [ -z "$heap" ] && [ -z "$(${CROSS}nm -u "$elf")" ] &&
        ok "Cortex-M4: firmware.elf links with no heap, stdio or system call ($(${CROSS}size "$elf" | awk 'NR == 2 { print "text " $1 ", data " $2 ", bss " $3 }'))" ||
        bad "Cortex-M4: firmware.elf has $heap"
fi
check_done
