#!/bin/sh
# SPDX-License-Identifier: MIT
# make check-arm64 (in make check): the Debian packages cross-built for
# arm64 (mk/deb.sh with DEB_HOST_ARCH=arm64: dpkg-buildpackage -a arm64,
# against the arm64 -dev libraries of multiarch), then an arm64 root made
# by mmdebstrap --variant=extract from the four arm64 .debs and what their
# Depends name (so the packages' own dependencies are what the programs
# find), and the programs run from it under qemu-user (qemu-aarch64 -L ROOT,
# as check-be runs s390x; no binfmt needed): drgatewayd --version,
# drgatewayd --check-config on the packaged conffile, drcli decode
# against the golden transcript of check-cli, drcli list.
# The root is of the machine's own release (/etc/os-release).
# Needs root, the arm64 cross compiler and build dependencies (make
# test-deps), qemu-aarch64, mmdebstrap and deb.debian.org; SKIPPED with a
# banner where one is missing.
# usage: check-arm64.sh BUILD_DIR [RESULTS]
set -u
cd "$(dirname "$0")/.."
. tests/skip.sh
b=${1:-build} res=${2:-}
skip_name=check-arm64 skip_results=$res
label="Debian packages cross-built for arm64, run under qemu-aarch64 in an arm64 root (mk/check-arm64.sh)"
skip_label=$label
[ "$(id -u)" = 0 ] || skip "not root (mmdebstrap)"
for t in dpkg-buildpackage:dpkg-dev dh:debhelper aarch64-linux-gnu-gcc:gcc-aarch64-linux-gnu \
         qemu-aarch64:qemu-user mmdebstrap:mmdebstrap; do
    command -v "${t%%:*}" >/dev/null || skip "no ${t%%:*} (make test-deps, or apt-get install ${t#*:})"
done
# (-P nocheck: the cross build runs no test; pkg.drgate.noopcua without
# open62541, as mk/deb.sh builds it)
profiles=nocheck
pkg-config --exists open62541 2>/dev/null || profiles=nocheck,pkg.drgate.noopcua
if ! unmet=$(dpkg-checkbuilddeps -a arm64 -P "$profiles" debian/control 2>&1); then
    skip "arm64 build dependencies missing (make test-deps installs them):$(echo "$unmet" | sed "s/.*dependencies://")"
fi
sh mk/debian-reachable.sh || skip "no network to the Debian archive (deb.debian.org)"
. mk/check-lib.sh
# The root is of this machine's release (bookworm, trixie), as the
# packages were built against it.
suite=$(. /etc/os-release && echo "$VERSION_CODENAME")

mkdir -p "$b"
d=$(cd "$b" && pwd)/deb-arm64
if DEB_HOST_ARCH=arm64 DEB_LINTIAN=no sh mk/deb.sh "$b" > "$b/deb-arm64.log" 2>&1; then
    ok "dpkg-buildpackage -a arm64: $(cd "$d" && ls ./*_arm64.deb | grep -vc dbgsym) packages"
else
    tail -20 "$b/deb-arm64.log"; bad "the arm64 build failed (log: $b/deb-arm64.log)"; check_done
fi
debs=  # one --include= each (mmdebstrap splits no list of paths)
for p in drgate drgate-sim libdrgate2 libdrgate-dev; do
    f=$(ls "$d/${p}_"*_arm64.deb 2>/dev/null)
    a=$(dpkg-deb -f "$f" Architecture 2>/dev/null)
    [ "$a" = arm64 ] || { bad "$p: no arm64 package ($f: '$a')"; continue; }
    debs="$debs --include=$f"
done
m=$(dpkg-deb --fsys-tarfile "$d"/drgate_*_arm64.deb | tar xOf - ./usr/bin/drgatewayd | od -An -tx1 -j18 -N2 | tr -d ' ')
[ "$m" = b700 ] && ok "drgatewayd is an AArch64 ELF (e_machine 0xb7)" || bad "drgatewayd's e_machine: $m"

root=$(mktemp -d /tmp/drgate-arm64-root.XXXXXX)
trap 'rm -rf "$root" "$root.log"' EXIT
# (The .debs copied into the root at their own path, where mmdebstrap looks
# for them; its file-mirror-automount hook bind-mounts them instead and, in
# the extract variant, leaves the mounts behind.)
if ! mmdebstrap --quiet --variant=extract --architectures=arm64 $debs \
        --setup-hook="mkdir -p \"\$1$d\" && cp $d/*_arm64.deb \"\$1$d/\"" \
        "$suite" "$root" > "$root.log" 2>&1; then
    bad "mmdebstrap (arm64, the four packages and their Depends) failed: $(tail -3 "$root.log")"; check_done
fi
rm -rf "${root:?}$d"
ok "arm64 root from the packages and their Depends ($(du -sm "$root" | cut -f1) MB)"
q() { qemu-aarch64 -L "$root" "$root$@"; }
out=$(q /usr/bin/drgatewayd --version 2>&1)
[ "$out" = "drgatewayd $(sed -n 's/^VERSION *:= *//p' Makefile)" ] &&
    ok "qemu-aarch64: $out" || bad "drgatewayd --version: $out"
out=$(cd "$root" && qemu-aarch64 -L "$root" "$root/usr/bin/drgatewayd" --check-config \
      etc/drgate/drgatewayd.ini 2>&1); st=$?
[ $st -eq 78 ] && echo "$out" | grep -q 'no robot section' &&
    ok "drgatewayd --check-config refuses the commented conffile (78)" || bad "--check-config: $st $out"
g=tests/cli/golden/decode_hex.txt
out=$(printf "04 00 02 02\n00 00 20 40 cd cc cc bd\n" | q /usr/bin/drcli decode --hex io_control 2>&1)
# (the transcript: the command, its output, "-- exit 0 --")
if [ "$out" = "$(tail -n +2 "$g" | sed '$d')" ]; then
    ok "drcli decode --hex io_control: as $g ($(echo "$out" | grep -c .) lines)"
else
    bad "drcli decode differs from $g:"; echo "$out" | diff -u "$g" - | head -20
fi
n=$(q /usr/bin/drcli list 2>/dev/null | grep -c .)
[ "$n" -gt 10 ] && ok "drcli list ($n lines)" || bad "drcli list: $n lines"
check_done
