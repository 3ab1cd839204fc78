#!/bin/sh
# SPDX-License-Identifier: MIT
# Guest side of `make check-gpio-qemu` (run by tests/gpio/qemu/run.sh's
# /init): gateway/gpio/gpio.h through gpio_selftest, then the daemon-like
# lifetime of a line seen from outside: held output readable in debugfs
# and shown as used by gpioinfo, safe value written on SIGTERM.
# Every wait is bounded. Exit status 0 = all passed.
set -u
pass=0
fail=0
ok() { pass=$((pass + 1)); echo "ok - $*"; }
bad() { fail=$((fail + 1)); echo "not ok - $*"; }
dbg=${GPIO_MOCKUP:-/sys/kernel/debug/gpio-mockup}/gpiochip0

# The gpiod tools packed are the build machine's: libgpiod 1.6's (Debian
# 12) or 2's (Debian 13), whose gpioinfo takes the chip as -c CHIP and
# shows a line's user as consumer="NAME" (1.6: "NAME", or unused), and
# which have no gpiofind (gpioinfo NAME prints "CHIP OFFSET<tab>...").
if command -v gpiofind >/dev/null 2>&1; then tools=1; else tools=2; fi
line_info() { # CHIP LINE: that line's row of gpioinfo
    if [ $tools = 1 ]; then gpioinfo "$1"; else gpioinfo -c "$1"; fi 2>&1 |
        grep -E "line +$2:"
}
line_free() { # CHIP LINE
    if [ $tools = 1 ]; then line_info "$1" "$2" | grep -q unused
    else ! line_info "$1" "$2" | grep -q 'consumer='; fi
}
find_line() { # NAME: "CHIP OFFSET"
    if [ $tools = 1 ]; then gpiofind "$1"; else gpioinfo "$1" | cut -f 1; fi
}

echo "# $(uname -r); chips:"
gpiodetect | sed 's/^/#   /'

# 1. The interface, from C.
if timeout 60 gpio_selftest; then ok "gpio_selftest"; else bad "gpio_selftest (exit $?)"; fi

# 2. A held output, seen from outside, released on SIGTERM.
line=7
out=/tmp/hold.out
gpio_selftest --hold $line > $out 2>&1 &
pid=$!
i=0
while ! grep -q holding $out && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
if grep -q holding $out; then ok "holder requested line $line"; else bad "holder did not start: $(cat $out)"; fi
v=$(cat "$dbg/$line")
[ "$v" = 1 ] && ok "debugfs reads the held output as 1" || bad "debugfs reads $v, want 1"
info=$(line_info gpiochip0 $line)
if echo "$info" | grep -q '"gpio-selftest"' && echo "$info" | grep -q output; then
    ok "gpioinfo shows the line used by gpio-selftest as output"
else
    bad "gpioinfo: $info"
fi
# gpio_value traces physical values: look at the last one after a marker.
tr=/sys/kernel/tracing
base=$(sed -n 's/^gpiochip0: GPIOs \([0-9]*\)-.*/\1/p' /sys/kernel/debug/gpio)
echo 1 > $tr/events/gpio/gpio_value/enable && : > $tr/trace && echo hold-release > $tr/trace_marker
kill -TERM $pid
i=0
while kill -0 $pid 2>/dev/null && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
if kill -0 $pid 2>/dev/null; then
    bad "holder still running 10 s after SIGTERM"; kill -KILL $pid
else
    wait $pid; rc=$?
    [ $rc = 0 ] && ok "holder exited 0 on SIGTERM" || bad "holder exited $rc: $(cat $out)"
fi
last=$(sed -n '/hold-release/,$p' $tr/trace | sed -n "s/.*gpio_value: $((base + line)) set \([01]\).*/\1/p" | tail -n 1)
[ "$last" = 0 ] && ok "the safe value 0 was the last write before release" ||
    bad "last write after SIGTERM was '${last}', want 0"
if line_free gpiochip0 $line; then
    ok "the line is free again"
else
    bad "line still in use: $(line_info gpiochip0 $line)"
fi

# 3. The gpiod tools agree with the interface about names and errors.
[ "$(find_line gpio-mockup-B-2)" = "gpiochip1 2" ] && ok "gpio-mockup-B-2 is gpiochip1 2" ||
    bad "gpio-mockup-B-2: $(find_line gpio-mockup-B-2 2>&1)"

echo "selftest.sh: $pass passed, $fail failed"
[ $fail = 0 ]
