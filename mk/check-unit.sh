#!/bin/sh
# SPDX-License-Identifier: MIT
# check-gateway-unit: gateway/drgatewayd.service
#   1. as systemd-analyze verify reads it (ExecStart= pointed at the built
#      daemon, since verify wants it to exist), alone and with the Debian
#      package's drop-in (debian/drop-in/): any complaint is a failure;
#   2. its device sandbox: DevicePolicy=closed and DeviceAllow= exactly the
#      GPIO chips and the serial ports [modbus_rtu] opens (ttyS, ttyUSB,
#      ttyACM, ttyAMA), read-write, and nothing else; the group dialout
#      that owns those ports.
# usage: check-unit.sh DAEMON RESULTS
set -u
cd "$(dirname "$0")/.."
gw=$1 res=$2
unit=gateway/drgatewayd.service
label="drgatewayd.service (systemd-analyze verify, devices)"
. mk/check-lib.sh

if command -v systemd-analyze >/dev/null 2>&1; then
    d=$(mktemp -d)
    sed -e "s|/usr/local/bin/drgatewayd|$gw|" "$unit" > "$d/drgatewayd.service"
    out=$(systemd-analyze verify --man=no "$d/drgatewayd.service" 2>&1); st=$?
    if [ $st -eq 0 ] && [ -z "$out" ]; then ok "systemd-analyze verify: clean"
    else bad "systemd-analyze verify (status $st): $out"; fi
    # with the Debian package's drop-in (User=drgate), read from the unit path
    mkdir "$d/drgatewayd.service.d"
    cp debian/drop-in/*.conf "$d/drgatewayd.service.d/"
    out=$(SYSTEMD_UNIT_PATH="$d:" systemd-analyze verify --man=no "$d/drgatewayd.service" 2>&1); st=$?
    if [ $st -eq 0 ] && [ -z "$out" ]; then ok "systemd-analyze verify with debian/drop-in: clean"
    else bad "systemd-analyze verify with debian/drop-in (status $st): $out"; fi
    rm -rf "$d"
else
    sh tests/skip.sh check-gateway-unit "no systemd-analyze on this machine: verify skipped"
fi

# The settings as systemd reads them: the last DevicePolicy=, every DeviceAllow=.
pol=$(sed -n 's/^DevicePolicy=//p' "$unit" | tail -1)
[ "$pol" = closed ] && ok "DevicePolicy=closed" || bad "DevicePolicy=$pol, want closed"
got=$(sed -n 's/^DeviceAllow=//p' "$unit" | sort | tr '\n' ';')
want=$(printf '%s\n' 'char-gpiochip rw' 'char-ttyS rw' 'char-ttyUSB rw' 'char-ttyACM rw' \
       'char-ttyAMA rw' | sort | tr '\n' ';')
[ "$got" = "$want" ] && ok "DeviceAllow: GPIO chips and serial ports, nothing else" ||
    bad "DeviceAllow: got '$got', want '$want'"
grep -qx 'SupplementaryGroups=dialout' "$unit" && ok "SupplementaryGroups=dialout" ||
    bad "no SupplementaryGroups=dialout (the serial ports' group)"

check_done
