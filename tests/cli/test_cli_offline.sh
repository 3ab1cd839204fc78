#!/bin/sh
# SPDX-License-Identifier: MIT
# End-to-end test of drcli's offline commands (list, decode, encode):
# each case runs one shell command and compares its transcript (stdout,
# stderr, exit status) with tests/cli/golden/NAME.txt; then a Python check
# decodes images independently from `drcli list --json` and compares every
# value with `drcli decode --json`, including shortest round-trip REALs.
#
# usage: test_cli_offline.sh DRCLI RESULTS [LABEL]
#        test_cli_offline.sh --update DRCLI     (rewrite the golden files;
#                                                review them with git diff)
set -u
export LC_ALL=C  # error texts from strerror are in the golden files
update=0
if [ "${1:-}" = "--update" ]; then update=1; shift; fi
DRCLI=${1:?usage: test_cli_offline.sh [--update] DRCLI [RESULTS [LABEL]]}
results=${2:-}
label=${3:-cli}
case $DRCLI in /*) ;; *) DRCLI=$(pwd)/$DRCLI ;; esac
here=$(cd "$(dirname "$0")" && pwd)
golden=$here/golden
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export DRCLI
passed=0 failed=0

# t NAME COMMAND: COMMAND is shell text calling "$DRCLI"; it runs in an
# empty scratch directory.
t() {
    name=$1 cmd=$2
    out=$tmp/$name.txt
    shown=$(printf '%s\n' "$cmd" | sed 's/"\$DRCLI"/drcli/g')
    (
        cd "$tmp/work" || exit 99
        printf '$ %s\n' "$shown"
        sh -c "$cmd" >"$tmp/stdout" 2>"$tmp/stderr" </dev/null
        rc=$?
        cat "$tmp/stdout"
        if [ -s "$tmp/stderr" ]; then echo "-- stderr --"; cat "$tmp/stderr"; fi
        echo "-- exit $rc --"
    ) >"$out"
    if [ "$update" = 1 ]; then
        cp "$out" "$golden/$name.txt"
        return
    fi
    if diff -u "$golden/$name.txt" "$out" >"$tmp/diff" 2>&1; then
        passed=$((passed + 1)); echo "ok   $name"
    else
        failed=$((failed + 1)); echo "FAIL $name"; cat "$tmp/diff"
    fi
}

# check NAME COMMAND: COMMAND must exit 0 (for checks without a transcript).
check() {
    if (cd "$tmp/work" && sh -c "$2") >"$tmp/check" 2>&1; then
        passed=$((passed + 1)); echo "ok   $1"
    else
        failed=$((failed + 1)); echo "FAIL $1"; cat "$tmp/check"
    fi
}

mkdir -p "$tmp/work"

# ---- usage and help ----------------------------------------------------------
t help           '"$DRCLI" --help'
t help_encode    '"$DRCLI" encode --help'
t help_decode    '"$DRCLI" help decode'
t no_args        '"$DRCLI"'
t bad_command    '"$DRCLI" frobnicate'
t bad_option     '"$DRCLI" list --verbose'
t list_both      '"$DRCLI" list --json --markdown'
[ "$update" = 1 ] || check version '"$DRCLI" --version | grep -Eqx "drcli [0-9]+\.[0-9]+\.[0-9]+"'

# ---- list --------------------------------------------------------------------
t list_all       '"$DRCLI" list'
t list_dr7       '"$DRCLI" list dr7 bit_in'
t list_json      '"$DRCLI" list --json io_control'
t list_unknown   '"$DRCLI" list io_stat'

# ---- encode ------------------------------------------------------------------
t encode_hex     '"$DRCLI" encode --hex io_control cb_do[3]=1 ao[0]=2.5'
t encode_full    '"$DRCLI" encode --hex io_control io_control.tool_do[6]=1 dr7.ao_type.ao1=true cb_do=0xa5a5 cb_do[1]=0'
t encode_raw     '"$DRCLI" encode io_control cb_do[3]=1 ao[0]=2.5 | od -An -tx1'
t encode_gpr     '"$DRCLI" encode --hex int_in [0]=-1 [7]=2147483647 int_in[23]=-2147483648'
t encode_bits    '"$DRCLI" encode --hex bit_out [0]=1 [63]=1 [9]=true'
t encode_zero    '"$DRCLI" encode --hex io_control'
t err_field      '"$DRCLI" encode --hex io_control cb_dp[3]=1'
t err_field2     '"$DRCLI" encode --hex task_state external_force.q=1'
t err_index      '"$DRCLI" encode --hex io_control cb_do[17]=1'
t err_noindex    '"$DRCLI" encode --hex joint_state position=1'
t err_badindex   '"$DRCLI" encode --hex io_control "ao[x]=1"'
t err_bit        '"$DRCLI" encode --hex io_control cb_do[3]=2'
t err_mask       '"$DRCLI" encode --hex io_control tool_do=64'
t err_usint      '"$DRCLI" encode --hex io_state version.major=256'
t err_dint       '"$DRCLI" encode --hex int_in "[3]=2147483648"'
t err_dint_frac  '"$DRCLI" encode --hex int_in "[3]=1.5"'
t err_real       '"$DRCLI" encode --hex io_control ao[0]=1,5'
t err_real_big   '"$DRCLI" encode --hex io_control ao[0]=1e39'
t err_nonfinite  '"$DRCLI" encode --hex io_control ao[0]=nan'
t err_enum       '"$DRCLI" encode --hex io_state robot_state=operating'
t err_other_asm  '"$DRCLI" encode --hex io_control io_state.cb_di=1'
t err_no_eq      '"$DRCLI" encode --hex io_control ao[0]'
t err_asm        '"$DRCLI" encode --hex io_contrl ao[0]=1'
t err_partial    '"$DRCLI" encode io_control ao[0]=1 ao[1]=x >img; echo "exit $?, $(wc -c <img) bytes written"'

# ---- decode ------------------------------------------------------------------
t decode_ioc     '"$DRCLI" encode io_control cb_do[3]=1 tool_do[2]=1 ao[0]=2.5 ao[1]=-0.1 | "$DRCLI" decode dr7 -'
t decode_hex     'printf "04 00 02 02\n00 00 20 40 cd cc cc bd\n" | "$DRCLI" decode --hex io_control'
t decode_iostate '"$DRCLI" encode io_state cb_di=5 cb_do[16]=1 aio_type.ai1=1 ai[0]=0.1 ao[1]=31.5 tool_di=0x21 version.major=2 version.minor=11 version.patch=7 robot_state=OPERATING servo_on=1 power_button_pressed=1 >img && "$DRCLI" decode io_state img'
t decode_unknown '"$DRCLI" encode io_state robot_state=13 >img && "$DRCLI" decode io_state img | grep robot_state'
t decode_joint   '"$DRCLI" encode joint_state position[1]=31.5 position[6]=-90 velocity[2]=0.1 motor_temperature[3]=36.6 external_torque[6]=-1e-7 | "$DRCLI" decode joint_state'
t decode_json    '"$DRCLI" encode io_control cb_do[3]=1 ao[0]=2.5 ao[1]=0.1 | "$DRCLI" decode --json io_control'
t decode_reals   '"$DRCLI" encode float_in "[0]=0.1" "[1]=31.5" "[2]=1e-7" "[3]=3.4028235e38" "[4]=0.33333334" "[5]=1e6" "[6]=-0" "[7]=2" "[8]=123456789" "[9]=16777217" "[10]=1.17549435e-38" "[11]=1e-45" "[12]=-3.4028235e38" | "$DRCLI" decode --json float_in'
t decode_nonfin  '"$DRCLI" encode float_out "[0]=nan" "[1]=-inf" "[2]=inf" | "$DRCLI" decode --json float_out | head -n 5'
t decode_gpr     '"$DRCLI" encode bit_in [0]=1 [63]=1 | "$DRCLI" decode bit_in | head -n 3'
t err_short      'head -c 35 /dev/zero | "$DRCLI" decode io_state'
t err_long       'head -c 13 /dev/zero >img && "$DRCLI" decode io_control img'
t err_hexlen     'printf "00 00\n" | "$DRCLI" decode --hex io_control'
t err_hexchar    'printf "00 00\n00 0g\n" | "$DRCLI" decode --hex io_control'
t err_hexsplit   'printf "00 0 0\n" | "$DRCLI" decode --hex io_control'
t err_hexodd     'printf "000\n" | "$DRCLI" decode --hex io_control'
t err_nofile     '"$DRCLI" decode io_control no-such-file'
t err_decode_use '"$DRCLI" decode io_control a b'

# ---- eds -----------------------------------------------------------------------
# A vendor-style EDS (one input, one output, a configuration assembly, RPI
# limits) into its plan; malformed ones refused with FILE:LINE (a tab in a
# quoted value shown as a space, never raw); drsim's EDS written and read
# back.
cp "$here"/eds/*.eds "$tmp/work/"
t eds_vendor      '"$DRCLI" eds -H 192.168.137.100 vendor_robot.eds'
t eds_malformed   '"$DRCLI" eds malformed.eds'
t eds_unclosed    '"$DRCLI" eds unclosed.eds'
t eds_tab_string  '"$DRCLI" eds tab_in_string.eds'
t eds_roundtrip   '"$DRCLI" eds --write > drsim.eds && "$DRCLI" eds drsim.eds'
t eds_combined    '"$DRCLI" eds --write --layout combined > c.eds && "$DRCLI" eds c.eds | tail -9'
t eds_gpr_only    '"$DRCLI" eds --write --layout gpr_only > g.eds && "$DRCLI" eds g.eds | tail -9'
t eds_bad_layout  '"$DRCLI" eds --write --layout nope'

# ---- independent cross-check -------------------------------------------------
if [ "$update" = 0 ]; then
    if command -v python3 >/dev/null 2>&1; then
        check crosscheck_json "python3 '$here/crosscheck.py' '$DRCLI'"
    else
        failed=$((failed + 1)); echo "FAIL crosscheck_json: python3 not found"
    fi
fi

# drsim's EDS read by eds_pie (an independent parser, tests/requirements.txt)
if [ "$update" = 0 ]; then
    py=$here/../../.venv/bin/python3
    [ -x "$py" ] || py=python3
    check eds_pie "'$py' '$here/eds_check.py' '$DRCLI'"
fi
if [ "$update" = 1 ]; then
    echo "golden files rewritten in $golden; review with git diff"
    exit 0
fi
echo "cli: $passed passed, $failed failed"
if [ -n "$results" ]; then
    mkdir -p "$(dirname "$results")"
    echo "$passed $failed $label" >>"$results"
fi
[ "$failed" -eq 0 ]
