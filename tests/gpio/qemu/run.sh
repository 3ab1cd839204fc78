#!/bin/sh
# SPDX-License-Identifier: MIT
# Runs a test on a real kernel GPIO chip: boots Debian's own kernel under
# qemu with gpio-mockup (built out of tree from Debian's linux-source) and
# a tiny initramfs holding busybox, the gpiod tools, the given programs
# with their shared libraries, and a test script that /init runs.
#
# usage: run.sh [options] --script TEST.sh [--bin PROGRAM]...
#   --bin PATH         pack PATH as /bin/NAME, with the libraries ldd lists
#   --file SRC[:DEST]  pack a data file (DEST defaults to /data/NAME)
#   --script PATH      the test; /init runs it with sh, in /, and its exit
#                      status is the result (0 = pass)
#   --mockup ARGS      gpio-mockup parameters (default: two chips,
#                      gpiochip0 with 8 lines and gpiochip1 with 4, named)
#   --cache DIR        where the kernel and module are kept between runs
#                      (default ${XDG_CACHE_HOME:-~/.cache}/drgate)
#   --timeout SEC      whole-run limit for qemu (default 120)
#   --results FILE     append "1 0 LABEL" or "0 1 LABEL" for make check
#   --label NAME       the label for --results (default gpio_qemu)
#   --log FILE         keep the serial log there
#   --interactive      a shell on the guest's console instead of the test
#
# Exit: 0 pass, 1 fail, 2 usage or harness error, 77 skipped because qemu
# or the kernel cannot be had here (with --results: a loud message and 0).
# QEMU=/path/to/qemu-system-x86_64 picks another qemu (and installs none).
#
# Inside the guest: PATH=/bin:/usr/bin, proc, sysfs, devtmpfs, debugfs
# (/sys/kernel/debug/gpio-mockup/gpiochipN/LINE drives inputs and reads
# outputs), tracefs, tmpfs /tmp, and loopback up, so a gateway and a
# simulator packed with --bin can talk over 127.0.0.1.
#
# Only Debian packages are used: qemu-system-x86, busybox-static, cpio,
# gpiod, and (downloaded, not installed) linux-image/headers/kbuild/source
# for the ABI linux-image-amd64 depends on today.
set -eu

cache=${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/drgate
timeout=120
script=""
results=""
label=gpio_qemu
log=""
interactive=0
mockup="gpio_mockup_ranges=-1,8,-1,4 gpio_mockup_named_lines=1"
bins=""
files=""

usage() {
    sed -n '5,20s/^# \{0,1\}//p' "$0" >&2
    exit 2
}

while [ $# -gt 0 ]; do
    case $1 in
    --bin) bins="$bins
$2"; shift 2 ;;
    --file) files="$files
$2"; shift 2 ;;
    --script) script=$2; shift 2 ;;
    --mockup) mockup=$2; shift 2 ;;
    --cache) cache=$2; shift 2 ;;
    --timeout) timeout=$2; shift 2 ;;
    --results) results=$2; shift 2 ;;
    --label) label=$2; shift 2 ;;
    --log) log=$2; shift 2 ;;
    --interactive) interactive=1; shift ;;
    -h|--help) usage ;;
    *) echo "run.sh: unknown option $1" >&2; usage ;;
    esac
done
[ -n "$script" ] && [ -f "$script" ] || { echo "run.sh: --script FILE is required" >&2; exit 2; }

say() { printf 'gpio-qemu: %s\n' "$*"; }

# skip REASON: no CI rule here (a machine without qemu or a kernel to
# download skips); 77 without --results, as automake's harness reads it
. "$(dirname "$0")/../../skip.sh"
skip_name="$label (qemu test on a real kernel GPIO chip)"
skip_status=77
[ -z "$results" ] || skip_status=0

record() { # passed failed
    [ -n "$results" ] || return 0
    mkdir -p "$(dirname "$results")"
    echo "$1 $2 $label" >> "$results"
}

now() { date +%s; }
t_start=$(now)

# ---- tools ------------------------------------------------------------------
missing=""
if [ -n "${QEMU:-}" ]; then
    command -v "$QEMU" >/dev/null 2>&1 || skip "QEMU=$QEMU is not there"
else
    QEMU=qemu-system-x86_64
    command -v "$QEMU" >/dev/null 2>&1 || missing="$missing qemu-system-x86"
fi
# The guest has no libc of its own: busybox must be the static build.
LC_ALL=C ldd /bin/busybox 2>&1 | grep -q 'not a dynamic' || missing="$missing busybox-static"
command -v cpio >/dev/null 2>&1 || missing="$missing cpio"
command -v gpiodetect >/dev/null 2>&1 || missing="$missing gpiod"
command -v make >/dev/null 2>&1 || missing="$missing make"
if [ -n "$missing" ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        say "installing$missing"
        export DEBIAN_FRONTEND=noninteractive
        # $missing is a list of package names: split it.
        # shellcheck disable=SC2086
        { apt-get update -qq && apt-get install -y -qq --no-install-recommends $missing; } >/dev/null 2>&1 ||
            skip "cannot install$missing"
    else
        skip "missing$missing (apt-get install$missing as root)"
    fi
fi

# ---- kernel and gpio-mockup, cached per kernel ABI --------------------------
kernel_abi() {
    LC_ALL=C apt-cache depends linux-image-amd64 2>/dev/null |
        sed -n 's/^ *Depends: linux-image-\([0-9].*-amd64\)$/\1/p' | head -n 1
}

# Builds gpio-mockup.ko for $kv into $1 from Debian's packages. Debian's
# kernel lacks CONFIG_IRQ_SIM, which gpio-mockup needs: irq_sim.c is
# compiled into the module (not exported there, and irq_to_desc is not
# exported to modules in 6.1, hence generic_handle_irq).
build_kernel() {
    out=$1
    kv=$2
    abi=${kv%-amd64}
    series=$(echo "$kv" | sed 's/^\([0-9]*\.[0-9]*\).*/\1/')
    work=$(mktemp -d "$cache/build.XXXXXX")
    say "first run for kernel $kv: downloading Debian's kernel packages (~224 MB)"
    (cd "$work" && apt-get download -q "linux-image-$kv" "linux-headers-$kv" \
        "linux-headers-$abi-common" "linux-kbuild-$series" "linux-source-$series" \
        >/dev/null 2>&1) || { rm -rf "$work"; return 1; }
    root=$work/root
    mkdir -p "$root" "$work/mod"
    for deb in "$work"/linux-image-*.deb "$work"/linux-headers-*.deb "$work"/linux-kbuild-*.deb; do
        dpkg -x "$deb" "$root" || { rm -rf "$work"; return 1; }
    done
    # The headers' Makefile includes the common part by absolute path.
    sed -i "s|include /usr/src/|include $root/usr/src/|" "$root/usr/src/linux-headers-$kv/Makefile"
    src=linux-source-$series
    dpkg-deb --fsys-tarfile "$work"/linux-source-*.deb |
        tar -xO "./usr/src/$src.tar.xz" |
        tar -xJ -C "$work" "$src/drivers/gpio/gpio-mockup.c" \
            "$src/drivers/gpio/gpiolib.h" "$src/kernel/irq/irq_sim.c"
    # Two objects in one module: the main file must not share its name.
    cp "$work/$src/drivers/gpio/gpio-mockup.c" "$work/mod/gpio-mockup-main.c"
    cp "$work/$src/drivers/gpio/gpiolib.h" "$work/mod/"
    sed -e '/^EXPORT_SYMBOL_GPL/d' \
        -e 's/handle_simple_irq(irq_to_desc(irqnum))/generic_handle_irq(irqnum)/' \
        "$work/$src/kernel/irq/irq_sim.c" > "$work/mod/irq_sim.c"
    grep -q 'generic_handle_irq(irqnum)' "$work/mod/irq_sim.c" ||
        { say "irq_sim.c changed upstream: cannot patch it"; rm -rf "$work"; return 1; }
    printf 'obj-m := gpio-mockup.o\ngpio-mockup-y := gpio-mockup-main.o irq_sim.o\n' > "$work/mod/Kbuild"
    # Debian builds with gcc-12; where only "gcc" exists, use that.
    cc=""
    command -v gcc-12 >/dev/null 2>&1 || cc="CC=gcc"
    # No BTF for the test module: 6.12 (Debian 13) asks for it, which
    # needs pahole and the kernel's vmlinux; a module loads without it.
    make -s -C "$root/usr/src/linux-headers-$kv" M="$work/mod" $cc \
        CONFIG_DEBUG_INFO_BTF_MODULES= modules > "$work/build.log" 2>&1 ||
        { cat "$work/build.log"; rm -rf "$work"; return 1; }
    # Called as a condition, so set -e is off here: check each step, and
    # publish the cache entry in one rename once it is complete.
    rm -rf "$out.tmp"
    if mkdir -p "$out.tmp" &&
        cp "$root/boot/vmlinuz-$kv" "$out.tmp/vmlinuz" &&
        cp "$root/boot/config-$kv" "$out.tmp/config" &&
        cp "$work/mod/gpio-mockup.ko" "$out.tmp/" &&
        rm -rf "$out" && mv "$out.tmp" "$out"; then
        rm -rf "$work"
        return 0
    fi
    rm -rf "$work" "$out.tmp"
    return 1
}

mkdir -p "$cache/kernel"
kv=$(kernel_abi)
if [ -z "$kv" ] && [ "$(id -u)" = 0 ]; then
    apt-get update -qq >/dev/null 2>&1 || true
    kv=$(kernel_abi)
fi
if [ -z "$kv" ]; then
    # Offline: the newest kernel cached before will do.
    kv=$(for d in "$cache"/kernel/*-amd64; do
             [ -f "$d/gpio-mockup.ko" ] && basename "$d"
         done | sort -V | tail -n 1)
    [ -n "$kv" ] || skip "no Debian kernel: apt-cache knows no linux-image-amd64 and nothing is cached"
    say "apt-cache knows no kernel; using cached $kv"
fi
kdir=$cache/kernel/$kv
if [ ! -f "$kdir/gpio-mockup.ko" ]; then
    # One builder at a time; the others wait and then use its result.
    exec 9> "$cache/kernel/.lock"
    command -v flock >/dev/null 2>&1 && flock -w 900 9
    if [ ! -f "$kdir/gpio-mockup.ko" ]; then
        t0=$(now)
        if ! build_kernel "$kdir" "$kv"; then
            # Stale package lists name packages the mirror no longer has.
            if [ "$(id -u)" = 0 ]; then apt-get update -qq >/dev/null 2>&1 || true; fi
            kv=$(kernel_abi)
            kdir=$cache/kernel/$kv
            if [ -z "$kv" ] ||
                { [ ! -f "$kdir/gpio-mockup.ko" ] && ! build_kernel "$kdir" "$kv"; }; then
                skip "could not download or build kernel ${kv:-?} with gpio-mockup"
            fi
        fi
        say "kernel $kv and gpio-mockup.ko cached in $kdir ($(( $(now) - t0 )) s)"
    fi
    exec 9>&-
fi

# ---- initramfs ----------------------------------------------------------------
stage=$(mktemp -d)
run=$(mktemp -d)
cleanup() { rm -rf "$stage" "$run"; }
trap cleanup EXIT INT TERM

mkdir -p "$stage/bin" "$stage/usr/bin" "$stage/lib/modules" "$stage/data" \
    "$stage/proc" "$stage/sys" "$stage/dev" "$stage/tmp" "$stage/run" "$stage/etc"
cp /bin/busybox "$stage/bin/busybox"
cp "$kdir/gpio-mockup.ko" "$stage/lib/modules/"
cp "$script" "$stage/test.sh"
echo "root:x:0:0:root:/:/bin/sh" > "$stage/etc/passwd"
echo "root:x:0:" > "$stage/etc/group"

# Copies an ELF and every library ldd finds for it to the same paths.
pack_libs() {
    LC_ALL=C ldd "$1" 2>/dev/null |
        awk '{ for (i = 1; i <= NF; i++) if ($i ~ /^\//) print $i }' |
        while read -r lib; do
            [ -e "$stage$lib" ] && continue
            mkdir -p "$stage$(dirname "$lib")"
            cp -L "$lib" "$stage$lib"
        done
}

for tool in gpiodetect gpioinfo gpioget gpioset gpiomon gpiofind; do
    p=$(command -v "$tool" 2>/dev/null) || continue
    cp "$p" "$stage/usr/bin/"
    pack_libs "$p"
done
echo "$bins" | while read -r b; do
    [ -n "$b" ] || continue
    [ -f "$b" ] || { echo "run.sh: --bin $b: no such file" >&2; exit 2; }
    cp "$b" "$stage/bin/"
    pack_libs "$b"
done
echo "$files" | while read -r f; do
    [ -n "$f" ] || continue
    src=${f%%:*}
    dest=/data/$(basename "$src")
    case $f in *:*) dest=${f#*:} ;; esac
    mkdir -p "$stage$(dirname "$dest")"
    cp "$src" "$stage$dest"
done

# The guest stops the test first, so a hang still reports through /init.
margin=$((timeout / 3 < 20 ? timeout / 3 : 20))
guest_timeout=$((timeout - margin))
if [ "$interactive" = 1 ]; then
    payload='echo "DRGATE-GUEST-UP: the test is /test.sh; poweroff -f leaves"; setsid cttyhack sh; rc=0'
else
    payload="timeout $guest_timeout sh /test.sh; rc=\$?"
fi
cat > "$stage/init" <<EOF
#!/bin/busybox sh
/bin/busybox mount -t proc proc /proc
/bin/busybox --install -s /bin
export PATH=/bin:/usr/bin HOME=/ GPIO_MOCKUP=/sys/kernel/debug/gpio-mockup
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
mount -t debugfs debugfs /sys/kernel/debug
mount -t tracefs tracefs /sys/kernel/tracing 2>/dev/null
mount -t tmpfs tmp /tmp
mount -t tmpfs run /run
ip link set lo up 2>/dev/null || ifconfig lo 127.0.0.1 up
if ! insmod /lib/modules/gpio-mockup.ko $mockup; then
    echo "init: insmod gpio-mockup failed"
fi
echo "DRGATE-GUEST-UP"
cd /
$payload
echo "DRGATE-RESULT rc=\$rc"
sync
poweroff -f
EOF
chmod 755 "$stage/init" "$stage/test.sh"
(cd "$stage" && find . | cpio -o -H newc --quiet | gzip -1) > "$run/initrd.gz"

# ---- boot ---------------------------------------------------------------------
# kvm only where the CPU offers it: /dev/kvm alone is not enough here.
accel=tcg
if grep -qE '\b(vmx|svm)\b' /proc/cpuinfo 2>/dev/null && [ -w /dev/kvm ]; then
    accel=kvm
fi
serial=${log:-$run/serial.log}
mkdir -p "$(dirname "$serial")"
: > "$serial"
t_boot=$(now)
if [ "$interactive" = 1 ]; then
    "$QEMU" -accel "$accel" -m 512 -smp 1 -nodefaults \
        -no-user-config -kernel "$kdir/vmlinuz" -initrd "$run/initrd.gz" \
        -append "console=ttyS0 panic=-1 quiet" -display none \
        -serial mon:stdio -no-reboot
    exit $?
fi
say "booting kernel $kv ($accel) with $(basename "$script")"
set +e
timeout --kill-after=5 "$timeout" "$QEMU" -accel "$accel" -m 512 \
    -smp 1 -nodefaults -no-user-config -kernel "$kdir/vmlinuz" \
    -initrd "$run/initrd.gz" -append "console=ttyS0 panic=-1 quiet" \
    -display none -monitor none -serial "file:$serial" -no-reboot \
    > "$run/qemu.out" 2>&1
qrc=$?
set -e

tr -d '\r' < "$serial" | sed -n '/^DRGATE-GUEST-UP/,$p' |
    grep -v -e '^DRGATE-GUEST-UP' -e 'reboot: Power down'
rc=$(tr -d '\r' < "$serial" | sed -n 's/^DRGATE-RESULT rc=\([0-9]*\).*/\1/p' | tail -n 1)
elapsed="boot+test $(( $(now) - t_boot )) s, total $(( $(now) - t_start )) s"
if [ -z "$rc" ]; then
    if ! grep -q DRGATE-GUEST-UP "$serial"; then
        # qemu itself did not get to /init: this machine cannot run it.
        if [ "$qrc" -ne 0 ] && [ "$qrc" -ne 124 ] && [ "$qrc" -ne 137 ]; then
            cat "$run/qemu.out" >&2
            skip "qemu-system-x86_64 failed to start (exit $qrc)"
        fi
        tail -n 30 "$serial" | tr -d '\r' >&2
    fi
    say "FAIL: no result from the guest (qemu exit $qrc; timeout ${timeout}s?; $elapsed)"
    record 0 1
    exit 1
fi
if [ "$rc" = 0 ]; then
    say "PASS ($elapsed)"
    record 1 0
    exit 0
fi
case $rc in
124|143) say "FAIL: test script timed out after ${guest_timeout}s in the guest ($elapsed)" ;;
*) say "FAIL: test script exited $rc ($elapsed)" ;;
esac
record 0 1
exit 1
