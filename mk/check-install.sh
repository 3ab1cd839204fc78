#!/bin/sh
# SPDX-License-Identifier: MIT
# check-install: `make install PREFIX=/usr` into a staging DESTDIR, then
#   - the manual pages, the unit and drgate.pc name no /usr/local path and
#     no "drgate sources": their paths follow the prefix;
#   - every path the manual pages name under /usr (FILES, the docs they
#     point at) is installed; ExecStart= is /usr/bin/drgatewayd;
#   - the Wireshark dissector is in Wireshark's global Lua plugin folder;
#   - `make uninstall` removes every file it installed.
# About 2 s once built. usage: check-install.sh [RESULTS]   (MAKE from make)
set -u
cd "$(dirname "$0")/.."
res=${1:-}
label="make install follows the prefix (mk/check-install.sh)"
mk=${MAKE:-make}
d=$(mktemp -d)
trap 'rm -rf "$d"' EXIT
. mk/check-lib.sh

if $mk --no-print-directory install PREFIX=/usr DESTDIR="$d" > "$d.log" 2>&1; then
    ok "make install PREFIX=/usr DESTDIR=..."
else
    bad "make install failed: $(tail -5 "$d.log")"
fi
rm -f "$d.log"
man=$(find "$d/usr/share/man" -type f 2>/dev/null)
[ -n "$man" ] && ok "manual pages installed: $(echo "$man" | wc -l)" || bad "no manual page installed"
# shellcheck disable=SC2086
loc=$(grep -l '/usr/local' $man "$d/usr/lib/systemd/system/drgatewayd.service" \
      "$d/usr/lib/pkgconfig/drgate.pc" 2>/dev/null | sed "s|^$d||" | tr '\n' ' ')
[ -z "$loc" ] && ok "no /usr/local in the manual pages, the unit, drgate.pc" || bad "/usr/local in: $loc"
# shellcheck disable=SC2086
src=$(grep -l 'drgate sources\|[^/]docs/' $man 2>/dev/null | sed "s|^$d||" | tr '\n' ' ')
[ -z "$src" ] && ok "the manual pages point at installed docs, not at the sources" ||
    bad "a manual page points at the sources: $src"
# shellcheck disable=SC2086
paths=$(grep -ho '/usr/[A-Za-z0-9_./-]*[A-Za-z0-9_/-]' $man | sort -u)
n=0
for p in $paths; do
    case $p in /usr/bin/*|/usr/lib/*|/usr/share/*) ;; *) continue ;; esac
    n=$((n + 1))
    [ -e "$d$p" ] || bad "named by a manual page, not installed: $p"
done
[ "$n" -ge 5 ] && ok "$n paths named by the manual pages checked" ||
    bad "only $n installed paths named by the manual pages (want FILES and the docs)"
grep -qx 'ExecStart=/usr/bin/drgatewayd -c /etc/drgate/drgatewayd.ini' \
    "$d/usr/lib/systemd/system/drgatewayd.service" 2>/dev/null &&
    ok "ExecStart=/usr/bin/drgatewayd" || bad "the unit's ExecStart= is not /usr/bin/drgatewayd"

ma=$(${CC:-cc} -print-multiarch 2>/dev/null)
lua=/usr/lib/${ma:+$ma/}wireshark/plugins/drgate.lua
[ -f "$d$lua" ] && ok "the Wireshark dissector in Wireshark's Lua plugin folder: $lua" ||
    bad "no $lua (the Wireshark dissector)"

$mk --no-print-directory uninstall PREFIX=/usr DESTDIR="$d" > /dev/null 2>&1
left=$(find "$d" -type f -o -type l | sed "s|^$d||" | tr '\n' ' ')
[ -z "$left" ] && ok "make uninstall removes every file" || bad "left after uninstall: $left"

check_done
