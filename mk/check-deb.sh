#!/bin/sh
# SPDX-License-Identifier: MIT
# make check-deb (in make check): builds the packages (mk/deb.sh), lintian
# on them (no error, no warning), then installs them in a clean Debian root
# of this machine's release (bookworm, trixie: /etc/os-release) made with
# mmdebstrap (--variant=apt, with what the packages' Depends name): dpkg -i the four, the files are there, the service is not
# enabled, the system user drgate is in dialout, `drgatewayd --check-config` refuses the commented conffile (78,
# "no robot section") and takes one with a robot, `drcli list` runs; then
# dpkg --purge, and nothing of them is left (the root's file list equals
# the one before the install, dpkg's own records aside).
# Needs root, debhelper, lintian, mmdebstrap (make test-deps) and the
# network (deb.debian.org); SKIPPED with a banner where one is missing.
# About 40 s.
# usage: check-deb.sh BUILD_DIR [RESULTS]
set -u
cd "$(dirname "$0")/.."
. tests/skip.sh
b=${1:-build} res=${2:-}
skip_name=check-deb skip_results=$res
suite=$(. /etc/os-release && echo "$VERSION_CODENAME")
label="Debian packages: lintian, install, run and purge in a clean $suite root (mk/check-deb.sh)"
skip_label=$label
[ "$(id -u)" = 0 ] || skip "not root (chroot)"
for t in dpkg-buildpackage:dpkg-dev dh:debhelper lintian:lintian mmdebstrap:mmdebstrap; do
    command -v "${t%%:*}" >/dev/null || skip "no ${t%%:*} (make test-deps, or apt-get install ${t#*:})"
done
sh mk/debian-reachable.sh || skip "no network to the Debian archive (deb.debian.org)"
. mk/check-lib.sh

mkdir -p "$b"
if DEB_LINTIAN=no sh mk/deb.sh "$b" > "$b/deb.log" 2>&1; then
    ok "make deb: $(cd "$b/deb" && ls drgate*.deb libdrgate*.deb | grep -vc dbgsym) packages built"
else
    tail -20 "$b/deb.log"; bad "make deb failed (log: $b/deb.log)"; check_done
fi
if (cd "$b/deb" && lintian --fail-on error,warning --tag-display-limit 0 ./*.changes) > "$b/lintian.log" 2>&1; then
    ok "lintian: no error, no warning"
else
    cat "$b/lintian.log"; bad "lintian reports errors or warnings"
fi
root=$(mktemp -d /tmp/drgate-deb-root.XXXXXX)
trap 'rm -rf "$root"' EXIT
inroot() { chroot "$root" "$@"; }
files() { (cd "$root" && find . -xdev \( -path ./var/lib/dpkg -o -path ./var/log -o -path ./var/cache \
          -o -path ./tmp -o -path ./debs -o -path ./var/lib/systemd -o -path ./run \) -prune -o -print |
          grep -v '^\./etc/[a-z]*-$' | sort); }
# (the user's files: shadow's backups /etc/passwd- ..., adduser's lock in /run)

# What the packages depend on, by name (libgpiod2 on bookworm, libgpiod3
# on trixie): their own Depends, less themselves and adduser's alternatives.
deps=$(for f in "$b"/deb/drgate_*.deb "$b"/deb/drgate-sim_*.deb "$b"/deb/libdrgate2_*.deb; do
           dpkg-deb -f "$f" Depends; done | tr ',' '\n' | sed 's/|.*//; s/(.*//; s/ //g' |
       grep -v '^libdrgate' | grep . | sort -u | tr '\n' ',' | sed 's/,$//')
if ! mmdebstrap --quiet --variant=apt --include="$deps" \
        "$suite" "$root" > "$root.log" 2>&1; then
    bad "mmdebstrap failed: $(tail -3 "$root.log")"
else
    files > "$root.before"
    ma=$(dpkg-architecture -qDEB_HOST_MULTIARCH)
    mkdir -p "$root/debs"
    cp "$b"/deb/drgate_*.deb "$b"/deb/drgate-sim_*.deb "$b"/deb/libdrgate2_*.deb \
       "$b"/deb/libdrgate-dev_*.deb "$root/debs/"
    if inroot sh -c 'dpkg -i /debs/*.deb' > "$root.log" 2>&1; then ok "dpkg -i drgate drgate-sim libdrgate2 libdrgate-dev"
    else bad "dpkg -i: $(tail -5 "$root.log")"; fi
    for f in /usr/bin/drgatewayd /usr/bin/drcli /usr/bin/drsim /etc/drgate/drgatewayd.ini \
             /usr/lib/systemd/system/drgatewayd.service /usr/share/doc/drgate/deployment.md \
             /usr/share/man/man8/drgatewayd.8.gz /usr/share/drgate/examples/minimal.ini \
             /usr/share/drgate/drsim.eds \
             /usr/include/drgate/codec.h "/usr/lib/$ma/libdrgate.so.2" \
             "/usr/lib/$ma/cmake/drgate/drgateConfig.cmake"; do
        [ -e "$root$f" ] || missing="${missing:-} $f"
    done
    [ -z "${missing:-}" ] && ok "the packages' files are in place" || bad "not installed:$missing"
    u=$(inroot id -nG drgate 2>&1)
    case " $u " in *" dialout "*) ok "system user drgate, groups: $u" ;;
        *) bad "no system user drgate in dialout: $u" ;; esac
    grep -qx 'User=drgate' "$root/usr/lib/systemd/system/drgatewayd.service.d/drgate-user.conf" 2>/dev/null &&
        ok "the unit's drop-in runs the service as drgate" || bad "no User=drgate drop-in"
    [ -z "$(find "$root/etc/systemd/system" -name 'drgatewayd*' 2>/dev/null)" ] &&
        ok "the service is not enabled after install" || bad "the service was enabled"
    out=$(inroot drgatewayd --check-config /etc/drgate/drgatewayd.ini 2>&1); st=$?
    [ $st -eq 78 ] && echo "$out" | grep -q 'no robot section' &&
        ok "--check-config refuses the commented conffile: $out" || bad "--check-config: $st $out"
    printf '[robot arm1]\nhost = 192.168.137.100\n' > "$root/tmp/one.ini"
    out=$(inroot drgatewayd --check-config /tmp/one.ini 2>&1) &&
        ok "--check-config takes a robot: $out" || bad "--check-config: $out"
    n=$(inroot drcli list 2>/dev/null | grep -c .)
    [ "$n" -gt 10 ] && ok "drcli list runs ($n lines)" || bad "drcli list: $n lines"
    if inroot dpkg --purge drgate drgate-sim libdrgate-dev libdrgate2 > "$root.log" 2>&1; then
        ok "dpkg --purge"
    else bad "dpkg --purge: $(tail -5 "$root.log")"; fi
    inroot getent passwd drgate >/dev/null && bad "the user drgate is left after purge" ||
        ok "purge removes the user drgate"
    rm -rf "$root/debs" "$root/tmp/one.ini"
    left=$(files | comm -13 "$root.before" - | tr '\n' ' ')
    [ -z "$left" ] && ok "nothing left after purge" || bad "left after purge: $left"
fi
rm -f "$root.log" "$root.before"
check_done
