#!/bin/sh
# SPDX-License-Identifier: MIT
# Guest side of `make check-gpio-gateway` (run by tests/gpio/qemu/run.sh's
# /init, as root, on a kernel with gpio-mockup): drgatewayd with the
# [gpio] sections of /etc/drgate/drgatewayd.ini, drsim as the robot on
# 127.0.0.2, mbpoll as an independent Modbus client. The far side of every
# line is debugfs (/sys/kernel/debug/gpio-mockup/gpiochipN/LINE: reading
# gives the level, writing drives an input) and the kernel's gpio_value
# trace events (every value the daemon writes).
#
# What it checks, in order:
#   1. start-up without the robot: every output at its safe value, every
#      line held by "drgatewayd" with the right direction, one handle per
#      chip however the sections spell it
#   2. the link comes up and the outputs follow the robot
#   3. input line -> O->T bit -> robot echo -> T->O bit -> output line,
#      for bit_in/bit_out and io_control/io_state, active-low both ways,
#      a pull-up, two chips; Modbus sees the same bits (coils, discrete
#      inputs) and a coil written over Modbus comes out on a line
#   4. debounce: a glitch shorter than debounce_ms is ignored, a held
#      level counts after debounce_ms and not before
#   5. robot link loss (drsim frozen with SIGSTOP, so only the connection
#      timeout can tell; then killed): outputs at their safe values within
#      the timeout; recovery: outputs follow again, without passing through
#      a stale value from before the loss
#   6. SIGHUP: an unchanged reload writes nothing to the lines (no
#      glitch); a changed one re-requests only what changed; one whose
#      lines cannot be had (gpioset holds one) is refused, and the running
#      lines, including one it had to let go, are as before
#   7. single-writer mode: the writer's watchdog expires -> outputs at
#      their safe values until the fault is reset, then they follow again
#   8. SIGTERM: safe values written last, lines released, exit 0 in < 1 s
# Every wait is bounded. Prints "gpio_gateway: N passed, M failed"; exit
# status 0 = all passed.
set -u
pass=0
fail=0
ok() { pass=$((pass + 1)); echo "ok - $*"; }
bad() { fail=$((fail + 1)); echo "not ok - $*"; }
check() { # STATUS MESSAGE...: ok when STATUS is 0
    st=$1
    shift
    if [ "$st" = 0 ]; then ok "$@"; else bad "$@"; fi
}

CONF0=/etc/drgate/drgatewayd.ini
CONF=/tmp/gw.ini # what the daemon reads, and reads again on SIGHUP
LOG=/tmp/gw.log
MB_PORT=1502
TIMEOUT_MS=320 # RPI 20 ms x (4 << timeout_multiplier 2)
# Link loss is detected at the timeout; the slack covers the loop's timer
# granularity and a slow emulated CPU (the measured time is printed).
LOSS_LIMIT_MS=$((TIMEOUT_MS + 480))
DEBOUNCE_MS=300 # [gpio door]
mock=${GPIO_MOCKUP:-/sys/kernel/debug/gpio-mockup}
A=$mock/gpiochip0
B=$mock/gpiochip1
tr=/sys/kernel/tracing
gw=""
sim=""
holder=""

now_ms() { awk '{ printf "%d\n", $1 * 1000 }' /proc/uptime; }

# Line levels as debugfs reads them (physical): "N" on gpiochip0, "bN" on
# gpiochip1.
lvl() {
    case $1 in
    b*) read -r v < "$B/${1#b}" ;;
    *) read -r v < "$A/$1" ;;
    esac
    echo "$v"
}
levels() { for n in 0 2 4 6 b0; do printf '%s=%s ' "$n" "$(lvl "$n")"; done; }
# state_is "0=1 2=0 ...": every listed line reads its value
state_is() {
    for s in $1; do
        [ "$(lvl "${s%=*}")" = "${s#*=}" ] || return 1
    done
}
# wait_state SPEC LIMIT_MS: 0 once SPEC holds (then $took is the time it
# took, in ms), 1 when LIMIT_MS passed first.
wait_state() {
    t0=$(now_ms)
    while :; do
        if state_is "$1"; then
            took=$(($(now_ms) - t0))
            return 0
        fi
        took=$(($(now_ms) - t0))
        [ "$took" -ge "$2" ] && return 1
        sleep 0.01
    done
}
# hold_state SPEC MS: 0 when SPEC holds all the time for MS ms.
hold_state() {
    h0=$(now_ms)
    while [ $(($(now_ms) - h0)) -lt "$2" ]; do
        state_is "$1" || return 1
        sleep 0.01
    done
}
# wait_steady SPEC HOLD_MS LIMIT_MS: until SPEC has held for HOLD_MS (a
# robot resumed after a freeze may drop its stale connections once more).
wait_steady() {
    s0=$(now_ms)
    while [ $(($(now_ms) - s0)) -lt "$3" ]; do
        if wait_state "$1" $(($3 - ($(now_ms) - s0))) && hold_state "$1" "$2"; then
            took=$(($(now_ms) - s0 - $2))
            return 0
        fi
    done
    took=$(($(now_ms) - s0))
    return 1
}
drive() { echo "$2" > "$A/$1"; }

# mbpoll: read one coil (0), discrete input (1) or register (3, 4);
# write one.
mb_get() {
    mbpoll -m tcp -p $MB_PORT -0 -1 -o 2 -t "$1" -r "$2" -c 1 127.0.0.1 2>&1 |
        sed -n 's/^\[[0-9]*\]:[[:space:]]*\(-\{0,1\}[0-9]*\).*/\1/p'
}
mb_set() { mbpoll -m tcp -p $MB_PORT -0 -1 -o 2 -t "$1" -r "$2" 127.0.0.1 "$3" 2>&1 | grep -q Written; }
# wait_mb TYPE ADDR VALUE LIMIT_MS
wait_mb() {
    t0=$(now_ms)
    while :; do
        [ "$(mb_get "$1" "$2")" = "$3" ] && return 0
        [ $(($(now_ms) - t0)) -ge "$4" ] && return 1
        sleep 0.05
    done
}

# The daemon appends to $LOG (O_APPEND), so the script puts markers
# between its lines; "since MARK" is what the daemon logged after it.
mark() { echo "### $*" >> $LOG; }
since() { sed -n "/^### $1\$/,\$p" $LOG; }
# wait_log MARK PATTERN LIMIT_MS: until PATTERN (a basic regex) is logged
# after MARK
wait_log() {
    t0=$(now_ms)
    until since "$1" | grep -q "$2"; do
        took=$(($(now_ms) - t0))
        [ "$took" -ge "$3" ] && return 1
        kill -0 "$gw" 2>/dev/null || return 1
        sleep 0.02
    done
    took=$(($(now_ms) - t0))
}

# edit SECTION KEY VALUE: the config on stdin, with KEY = VALUE in [SECTION]
edit() {
    awk -v s="[$1]" -v k="$2" -v v="$3" \
        '/^\[/ { sec = $0 } sec == s && $1 == k { $0 = k " = " v } { print }'
}
# reload FILE: FILE becomes the config, SIGHUP; $reply is the daemon's
# answer ("configuration ... reloaded ..." or "reload refused ...").
nreload=0
reload() {
    nreload=$((nreload + 1))
    cp "$1" $CONF
    mark "reload $nreload"
    kill -HUP "$gw"
    wait_log "reload $nreload" 'reloaded\|reload refused' 5000
    reply=$(since "reload $nreload" | grep -e 'reloaded' -e 'reload refused' | head -n 1)
}
gen() { mb_get 3 29; } # status.config_generation
# The gpiod tools packed are the build machine's: libgpiod 1.6's (Debian
# 12) or 2's (Debian 13), which take the chip as -c CHIP and show a line's
# user after its flags as consumer="NAME" (1.6: "NAME" before them, or
# unused); gpioinfo without a chip lists every chip with both.
if command -v gpiofind >/dev/null 2>&1; then tools=1; else tools=2; fi
gpio_user() { # CHIP LINE: that line's row of gpioinfo
    if [ $tools = 1 ]; then gpioinfo "$1"; else gpioinfo -c "$1"; fi 2>&1 |
        grep -E "line +$2:"
}
line_free() { # CHIP LINE
    if [ $tools = 1 ]; then gpio_user "$1" "$2" | grep -q unused
    else ! gpio_user "$1" "$2" | grep -q 'consumer='; fi
}

start_sim() {
    drsim --address 127.0.0.2 >> /tmp/drsim.log 2>&1 &
    sim=$!
}

# Trace: the physical values the daemon writes to a line since a marker.
base0=$(sed -n 's/^gpiochip0: GPIOs \([0-9]*\)-.*/\1/p' /sys/kernel/debug/gpio)
base1=$(sed -n 's/^gpiochip1: GPIOs \([0-9]*\)-.*/\1/p' /sys/kernel/debug/gpio)
have_trace=0
if [ -n "$base0" ] && [ -n "$base1" ] && echo 1 > $tr/events/gpio/gpio_value/enable 2>/dev/null; then
    have_trace=1
fi
trace_mark() { [ $have_trace = 1 ] && : > $tr/trace && echo "$1" > $tr/trace_marker; }
# trace_sets MARKER LINE: the values written to LINE ("N" or "bN") since
# MARKER, space-separated
trace_sets() {
    case $2 in
    b*) g=$((base1 + ${2#b})) ;;
    *) g=$((base0 + $2)) ;;
    esac
    sed -n "/$1/,\$p" $tr/trace | sed -n "s/.*gpio_value: $g set \([01]\).*/\1/p" |
        tr '\n' ' ' | sed 's/ $//'
}

cleanup() {
    for p in $holder $sim $gw; do kill -KILL "$p" 2>/dev/null; done
}
trap cleanup EXIT

echo "# $(uname -r); $(gpiodetect | tr '\n' ';')"
[ "$have_trace" = 1 ] || echo "# no gpio_value trace events: the write-order checks are skipped"

# ---- 0. the configuration ------------------------------------------------------
cp $CONF0 $CONF
out=$(drgatewayd --check-config $CONF 2>&1)
check $? "--check-config: $out"

# ---- 1. start-up without the robot ----------------------------------------------
# Safe values, physical: echo 0, lamp 1, relay (active-low, safe 0) 1,
# coil 0, second-chip 0.
SAFE="0=0 2=1 4=1 6=0 b0=0"
t0=$(now_ms)
: > $LOG
drgatewayd -c $CONF >> $LOG 2>&1 &
gw=$!
i=0
while ! grep -q 'running' $LOG && kill -0 $gw 2>/dev/null && [ $i -lt 100 ]; do
    sleep 0.05
    i=$((i + 1))
done
if grep -q 'running: 1 robot(s), 9 GPIO line(s)' $LOG; then
    ok "drgatewayd running with 9 GPIO lines ($(($(now_ms) - t0)) ms)"
else
    bad "drgatewayd did not start:"
    sed 's/^/#   /' $LOG
    echo "gpio_gateway: $pass passed, $fail failed"
    exit 1
fi
state_is "$SAFE"
check $? "without the robot every output is at its safe value ($(levels))"
info=$(gpioinfo 2>&1)
n_out=$(echo "$info" | grep '"drgatewayd"' | grep -c output)
n_in=$(echo "$info" | grep '"drgatewayd"' | grep -c input)
[ "$n_out" = 5 ] && [ "$n_in" = 4 ]
check $? "gpioinfo: 5 outputs and 4 inputs used by \"drgatewayd\" (saw $n_out, $n_in)"
echo "$info" | grep -E 'gpio-mockup-A-7' | grep -q 'input *active-low'
check $? "gpioinfo: the guard line is an active-low input"
grep -q 'gpio: 9 line(s) on 2 chip(s)' $LOG
check $? "one handle per chip, named gpiochip0, /dev/gpiochip0, 0 or by label ($(grep 'gpio: 9' $LOG))"

# ---- 2. the robot appears -------------------------------------------------------
mark sim1
start_sim
wait_log sim1 'link up' 8000
check $? "link up ${took} ms after drsim started"
# bit_out[1] = 0 takes the lamp off its safe value 1.
wait_state "0=0 2=0 4=1 6=0 b0=0" 2000
check $? "outputs follow the robot: the lamp leaves its safe value ($(levels); ${took} ms)"

# ---- 3. inputs to the robot and back to outputs ----------------------------------
drive 3 1
wait_state "2=1" 2000
check $? "sensor line 1 -> bit_in[1] -> robot -> bit_out[1] -> lamp line 1 (${took} ms)"
drive 3 0
wait_state "2=0" 2000
check $? "sensor line 0 -> lamp line 0 (${took} ms)"

drive 5 1
wait_state "4=0 b0=1" 2000
check $? "button -> io_control.cb_do[1] -> robot -> io_state.cb_do[1] -> relay (active-low: pin 0) and gpiochip1 line 0 (${took} ms)"
wait_mb 1 116 1 2000
check $? "Modbus discrete input 116 (io_state.cb_do[1]) reads 1"
[ "$(mb_get 0 100)" = 1 ]
check $? "Modbus coil 100 (io_control.cb_do[1]) reads back the button's 1"

# The guard: active-low with a pull-up, so it reads 0 until pulled low.
[ "$(mb_get 0 203)" = 0 ]
check $? "guard (pull-up, active-low) drives bit_in[3] = 0 (coil 203)"
drive 7 0
wait_mb 1 403 1 2000
check $? "guard pin pulled low -> bit_in[3] = 1 -> robot echo on discrete input 403"
drive 7 1
# The bit is the guard input's: a Modbus write that would change it is
# refused (exception 0x02) and the bit keeps the input's value.
wait_mb 0 203 0 2000
if mb_set 0 203 1; then r=1; else [ "$(mb_get 0 203)" = 0 ]; r=$?; fi
check $r "Modbus write of coil 203 (bit_in[3], driven by the guard input) is refused"

mb_set 0 202 1
check $? "Modbus writes coil 202 (bit_in[2]) = 1"
wait_state "6=1" 2000
check $? "coil bit_in[2] -> robot -> bit_out[2] -> coil line 1 (${took} ms)"

# ---- 4. debounce ------------------------------------------------------------------
# A pulse of a few ms (two writes in a row) on the 300 ms door input.
drive 1 1
drive 1 0
hold_state "0=0" $((DEBOUNCE_MS * 2))
check $? "a glitch on the debounced door input is ignored (echo line stayed 0 for $((DEBOUNCE_MS * 2)) ms)"
[ "$(mb_get 0 200)" = 0 ]
check $? "after the glitch bit_in[0] is still 0 (coil 200)"
# A held level: not before the debounce period, soon after it.
drive 1 1
wait_state "0=1" $((DEBOUNCE_MS + 2000))
st=$?
[ $st = 0 ] && [ "$took" -ge "$DEBOUNCE_MS" ]
check $? "the held door level reaches the echo line after ${took} ms (>= ${DEBOUNCE_MS} ms debounce)"
wait_mb 1 400 1 1000
check $? "Modbus discrete input 400 (bit_out[0]) reads the echo 1"

# ---- 5. robot link loss and recovery ----------------------------------------------
# Now every output is off its safe value: echo 1, lamp 0, relay pin 0,
# coil 1, second chip 1.
FOLLOW="0=1 2=0 4=0 6=1 b0=1"
state_is "$FOLLOW"
check $? "every output is off its safe value before the link loss ($(levels))"

# a) drsim frozen: TCP stays open, only the connection timeout can tell.
mark stop
kill -STOP "$sim"
wait_state "$SAFE" $((LOSS_LIMIT_MS + 3000))
st=$?
[ $st = 0 ] && [ "$took" -le $LOSS_LIMIT_MS ]
check $? "drsim frozen (SIGSTOP): every output at its safe value after ${took} ms (timeout ${TIMEOUT_MS} ms, limit ${LOSS_LIMIT_MS} ms; $(levels))"
since stop | grep -q 'link down'
check $? "the log reports the link down: $(since stop | grep 'link down' | head -n 1)"
[ "$(mb_get 3 1)" != 2 ]
check $? "the status block's link state is no longer 2 (up)"
hold_state "$SAFE" 500
check $? "outputs stay safe while the robot is gone"
mark cont
kill -CONT "$sim"
wait_log cont 'link up' 10000
check $? "drsim resumed (SIGCONT): link up again (${took} ms)"
wait_steady "$FOLLOW" 1000 10000
check $? "outputs follow the robot again, steadily for 1 s ($(levels); after ${took} ms; link downs meanwhile: $(since cont | grep -c 'link down'))"

# b) drsim killed, then restarted: a fresh robot, bit_out all 0 until it
# echoes the gateway's bit_in again.
mark kill
kill -KILL "$sim"
wait "$sim" 2>/dev/null
sim=""
wait_state "$SAFE" $((LOSS_LIMIT_MS + 3000))
st=$?
[ $st = 0 ] && [ "$took" -le $LOSS_LIMIT_MS ]
check $? "drsim killed: every output at its safe value after ${took} ms ($(levels))"
trace_mark restart
mark restart
start_sim
wait_log restart 'link up' 10000
check $? "drsim restarted: link up again (${took} ms)"
wait_steady "$FOLLOW" 500 5000
check $? "outputs follow the new robot: held inputs and the Modbus coil come back through it ($(levels); ${took} ms)"
if [ $have_trace = 1 ]; then
    # The loss left the echo line at 0. The image still says 1 from before;
    # the new robot says 0 until it echoes: the line must go 0 -> 1 once,
    # not 1 from the old image, then 0, then 1. Only a drop of the new
    # link itself may write a 0 (then at most one per drop).
    s=$(trace_sets restart 0)
    drops=$(since restart | grep -c 'link down')
    zeros=$(echo "$s" | tr ' ' '\n' | grep -c 0)
    [ "${s%% *}" = 1 ] && [ "$zeros" -le "$drops" ]
    check $? "on recovery the echo line was written '$s' (link drops meanwhile: $drops), no stale value from before the loss"
fi

# ---- 6. SIGHUP -----------------------------------------------------------------------
trace_mark hup-same
reload $CONF0
echo "$reply" | grep -q 'reloaded (generation 1)'
check $? "SIGHUP with the same file: $reply"
since "reload $nreload" | grep -q '9 kept as they were, 0 requested anew'
check $? "every line kept: $(since "reload $nreload" | grep 'kept as')"
if [ $have_trace = 1 ]; then
    w=""
    for n in 0 2 4 6 b0; do w="$w$(trace_sets hup-same $n)"; done
    [ -z "$w" ]
    check $? "nothing written to the outputs by an unchanged reload (trace: '$w')"
fi
hold_state "$FOLLOW" 300
check $? "outputs still follow after the reload ($(levels))"

# C1: the lamp's safe value 1 -> 0, the second chip's output 0 -> 1.
edit 'gpio lamp' safe_value 0 < $CONF0 | edit 'gpio second-chip' line 1 > /tmp/c1.ini
reload /tmp/c1.ini
echo "$reply" | grep -q 'reloaded (generation 2)'
check $? "SIGHUP with the lamp and the second chip changed: $reply"
since "reload $nreload" | grep -q '7 kept as they were, 2 requested anew'
check $? "two lines requested anew: $(since "reload $nreload" | grep 'kept as')"
wait_state "0=1 2=0 4=0 6=1 b1=1" 2000
check $? "the moved output follows on gpiochip1 line 1 ($(levels)b1=$(lvl b1))"
line_free gpiochip1 0
check $? "gpiochip1 line 0 is released: $(gpio_user gpiochip1 0)"

# C2: the first file (so the lamp's line must be let go for its old safe
# value, and the second chip's output moves back to line 0) plus a line
# gpioset holds: refused; the lamp is requested again as in C1, follows
# again, and line 0 of gpiochip1 is let go again.
drive 3 1 # bit_out[1] = 1: the lamp at 1, which a release would lose
wait_state "2=1" 2000
if [ $tools = 1 ]; then gpioset --mode=signal gpiochip1 2=1 & else gpioset -c gpiochip1 2=1 & fi
holder=$!
i=0
until gpio_user gpiochip1 2 | grep -q gpioset || [ $i -ge 50 ]; do
    sleep 0.05
    i=$((i + 1))
done
{
    cat $CONF0
    printf '\n[gpio extra]\nchip = gpiochip1\nline = 2\ndirection = output\nfield = bit_out[5]\n'
} > /tmp/c2.ini
g0=$(gen)
reload /tmp/c2.ini
echo "$reply" | grep -q 'reload refused.*gpio extra.*used by "gpioset"'
check $? "SIGHUP with a line gpioset holds is refused: $reply"
[ "$(gen)" = "$g0" ]
check $? "the configuration generation stays $g0"
gpio_user gpiochip0 2 | grep '"drgatewayd"' | grep -q output
check $? "the lamp's line, let go for its new settings, is held again: $(gpio_user gpiochip0 2)"
wait_state "0=1 2=1 4=0 6=1 b1=1" 2000
check $? "the running lines follow as before ($(levels)b1=$(lvl b1); ${took} ms)"
line_free gpiochip1 0
check $? "gpiochip1 line 0, requested for the refused file, is free again"
kill -TERM $holder
wait $holder
holder=""
drive 3 0
wait_state "2=0" 2000

# Back to the first file (the lamp's safe value is 1 again).
reload $CONF0
echo "$reply" | grep -q 'reloaded (generation 3)'
check $? "SIGHUP back to the first file: $reply"
wait_state "$FOLLOW" 2000
check $? "outputs follow ($(levels))"
line_free gpiochip1 1
check $? "gpiochip1 line 1 is released"

# ---- 7. single-writer mode --------------------------------------------------------
awk '{ print } /^\[modbus\]/ { print "single_writer = yes"; print "writer_watchdog_ms = 1500" }' \
    $CONF0 > /tmp/c3.ini
reload /tmp/c3.ini
echo "$reply" | grep -q reloaded
check $? "SIGHUP into single-writer mode: $reply"
# A writer that writes the watchdog register once and goes away.
mark writer
mb_set 4 0 1
check $? "a Modbus client writes the watchdog register (holding register 0) and leaves"
wait_state "$SAFE" 5000
check $? "the writer's watchdog expired: every output at its safe value after ${took} ms ($(levels))"
since writer | grep -q 'watchdog expired'
check $? "the log says so: $(since writer | grep 'watchdog expired')"
[ "$(mb_get 3 26)" = 1 ]
check $? "status.write_fault (input register 26) is latched"
hold_state "$SAFE" 500
check $? "the outputs stay safe while the fault is latched, with the robot up"
# The fallback zeroed the O->T image: the coil bit_in[2] is 0 now; the
# inputs put their own bits back.
FOLLOW2="0=1 2=0 4=0 6=0 b0=1"
mb_set 4 1 1 # the fault reset (this client owns the writes now, then leaves)
wait_state "$FOLLOW2" 1200
check $? "fault reset (holding register 1): outputs follow again ($(levels); ${took} ms)"
# Out of single-writer mode; a fault latched meanwhile is reset by hand.
reload $CONF0
echo "$reply" | grep -q reloaded
check $? "SIGHUP out of single-writer mode: $reply"
mb_set 4 1 1
mb_set 0 202 1
wait_state "$FOLLOW" 2000
check $? "the coil written again, every output follows ($(levels))"

# ---- 8. SIGTERM ----------------------------------------------------------------------
state_is "$FOLLOW"
check $? "outputs off their safe values before SIGTERM ($(levels))"
trace_mark sigterm
t0=$(now_ms)
kill -TERM "$gw"
i=0
while kill -0 "$gw" 2>/dev/null && [ $i -lt 200 ]; do
    sleep 0.01
    i=$((i + 1))
done
if kill -0 "$gw" 2>/dev/null; then
    bad "drgatewayd still running 2 s after SIGTERM"
    kill -KILL "$gw"
    wait "$gw"
else
    wait "$gw"
    rc=$?
    ms=$(($(now_ms) - t0))
    [ $rc = 0 ] && [ $ms -lt 1000 ]
    check $? "SIGTERM: drgatewayd exited $rc after $ms ms (want 0 within 1 s)"
fi
gw=""
if [ $have_trace = 1 ]; then
    # Physical safe values; the relay is active-low (safe 0 is pin 1).
    got=""
    for s in $SAFE; do
        n=${s%=*}
        last=$(trace_sets sigterm "$n" | awk '{ print $NF }')
        got="$got $n=$last"
    done
    [ "$got" = " $SAFE" ]
    check $? "SIGTERM: the last write to every output was its safe value (trace:$got)"
fi
n_used=$(gpioinfo 2>&1 | grep -c '"drgatewayd"')
[ "$n_used" = 0 ]
check $? "the lines are released ($n_used still held)"
tail -n 1 $LOG | grep -q stopped
check $? "the log ends with 'stopped'"

if [ $fail != 0 ]; then
    echo "# drgatewayd's log:"
    sed 's/^/#   /' $LOG
fi
echo "gpio_gateway: $pass passed, $fail failed"
[ $fail = 0 ]
