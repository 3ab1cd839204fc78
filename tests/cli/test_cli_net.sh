#!/bin/sh
# SPDX-License-Identifier: MIT
# End-to-end test of drcli's network commands (get, dump, set, watch,
# identity, probe) against the simulated robot drsim and against cpppo's
# EtherNet/IP server. Each case runs one shell command and compares its
# transcript (stdout, stderr, exit status) with tests/cli/golden-net/NAME.txt;
# port numbers are replaced by names (SIMPORT, ...) first. `requests CMD`
# runs CMD and then lists the requests drsim logged meanwhile, which shows
# how many Get/Set requests a command sent (none after a usage error).
#
# drsim listens on 127.0.0.2 and cpppo on 127.0.0.4, on free ports picked
# at the start. drsim's T->O values move over time: the golden files
# use only what is stable (version, robot_state once OPERATING, servo_on,
# the echo of what the test sets) and filter the rest.
#
# usage: test_cli_net.sh DRCLI DRSIM [RESULTS [LABEL [PYTHON]]]
#        test_cli_net.sh --update DRCLI DRSIM [PYTHON]   (rewrite the golden
#                                              files; review with git diff)
# PYTHON is the interpreter with cpppo (default .venv/bin/python, which
# `make test-deps` installs from tests/requirements.txt).
set -u
export LC_ALL=C
update=0
if [ "${1:-}" = "--update" ]; then update=1; shift; fi
DRCLI=${1:?usage: test_cli_net.sh [--update] DRCLI DRSIM [RESULTS [LABEL [PYTHON]]]}
DRSIM=${2:?usage: test_cli_net.sh [--update] DRCLI DRSIM [RESULTS [LABEL [PYTHON]]]}
if [ "$update" = 1 ]; then
    results='' label='' PYTHON=${3:-.venv/bin/python}
else
    results=${3:-} label=${4:-cli-net} PYTHON=${5:-.venv/bin/python}
fi
abs() { case $1 in /*) echo "$1" ;; *) echo "$(pwd)/$1" ;; esac; }
DRCLI=$(abs "$DRCLI") DRSIM=$(abs "$DRSIM") PYTHON=$(abs "$PYTHON")
here=$(cd "$(dirname "$0")" && pwd)
golden=$here/golden-net
tmp=$(mktemp -d)
pids=''
cleanup() {
    for p in $pids; do kill "$p" 2>/dev/null; done
    for p in $pids; do wait "$p" 2>/dev/null; done
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
passed=0 failed=0
fail() { failed=$((failed + 1)); echo "FAIL $*"; }

# ---- ports and peers ---------------------------------------------------------
# Free ports picked now (TCP and UDP both free), so that several builds can
# run this at once: drsim (TCP, UDP), a slow drsim (TCP, UDP), cpppo, and
# one where nothing listens. Never 44818 or 2222, which outputs show.
free_port() {
    python3 - "$1" "$taken" <<'PY'
import socket, sys
addr, taken = sys.argv[1], set(sys.argv[2].split())
for _ in range(100):
    t = socket.socket()
    u = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        t.bind((addr, 0))
        port = t.getsockname()[1]
        u.bind((addr, port))
        if str(port) not in taken and port not in (44818, 2222):
            print(port)
            break
    except OSError:
        pass
    finally:
        t.close()
        u.close()
PY
}
taken=''
for v in SIM SIM_UDP SLOW SLOW_UDP DEAD CPPPO; do
    case $v in CPPPO) addr=127.0.0.4 ;; *) addr=127.0.0.2 ;; esac
    p=$(free_port $addr)
    [ -n "$p" ] || { echo "no free port on $addr"; exit 1; }
    eval "$v=$p"
    taken="$taken $p"
done
SIMLOG=$tmp/drsim.log
export DRCLI SIM SLOW CPPPO DEAD SIMLOG
unset DRCLI_HOST

# start_drsim LOG TCP UDP [OPTION...]: wait (5 s at most) until it listens.
start_drsim() {
    log=$1 tcp=$2 udp=$3
    : >"$log"
    shift 3
    "$DRSIM" --address 127.0.0.2 --tcp-port "$tcp" --udp-port "$udp" --seed 7 \
        "$@" >"$log" 2>&1 </dev/null &
    pids="$pids $!"
    i=0
    while [ $i -lt 50 ]; do
        grep -q 'listening on' "$log" && return 0
        sleep 0.1
        i=$((i + 1))
    done
    echo "drsim did not start:"; cat "$log"
    return 1
}

# wait_for TEXT COMMAND: run COMMAND (10 s at most) until its output has TEXT.
wait_for() {
    i=0
    while [ $i -lt 100 ]; do
        sh -c "$2" 2>/dev/null | grep -q "$1" && return 0
        sleep 0.1
        i=$((i + 1))
    done
    return 1
}

# `requests CMD...`: CMD, then what drsim logged meanwhile, one request a line.
mkdir -p "$tmp/bin" "$tmp/work"
cat >"$tmp/bin/requests" <<'EOF'
#!/bin/sh
n=$(wc -l <"$SIMLOG")
"$@"
rc=$?
echo "-- drsim saw --"
tail -n +"$((n + 1))" "$SIMLOG" |
    sed -n 's/^drsim: request 0x\(..\) class \(0x..\) instance \([0-9]*\) attribute \(-*[0-9]*\).*/\1 class \2 instance \3 attribute \4/p' |
    sed 's/^0E/Get_Attribute_Single/; s/^10/Set_Attribute_Single/; s/^01/Get_Attributes_All/; s/^52/Unconnected_Send/'
exit $rc
EOF
chmod +x "$tmp/bin/requests"

# t NAME COMMAND: COMMAND is shell text calling "$DRCLI"; it runs in an
# empty scratch directory with `requests` on the PATH.
t() {
    name=$1 cmd=$2
    out=$tmp/$name.txt
    shown=$(printf '%s\n' "$cmd" | sed 's/"\$DRCLI"/drcli/g')
    (
        cd "$tmp/work" || exit 99
        printf '$ %s\n' "$shown"
        PATH=$tmp/bin:$PATH sh -c "$cmd" >"$tmp/stdout" 2>"$tmp/stderr" </dev/null
        rc=$?
        cat "$tmp/stdout"
        if [ -s "$tmp/stderr" ]; then echo "-- stderr --"; cat "$tmp/stderr"; fi
        echo "-- exit $rc --"
    ) | sed "s/\\b$SIM\\b/SIMPORT/g; s/\\b$SLOW\\b/SLOWPORT/g; s/\\b$CPPPO\\b/CPPPOPORT/g; s/\\b$DEAD\\b/DEADPORT/g" >"$out"
    if [ "$update" = 1 ]; then
        cp "$out" "$golden/$name.txt"
        return
    fi
    if diff -u "$golden/$name.txt" "$out" >"$tmp/diff" 2>&1; then
        passed=$((passed + 1)); echo "ok   $name"
    else
        fail "$name"; cat "$tmp/diff"
    fi
}

# check NAME COMMAND: COMMAND must exit 0 (for checks without a transcript).
check() {
    [ "$update" = 1 ] && return
    if (cd "$tmp/work" && PATH=$tmp/bin:$PATH sh -c "$2") >"$tmp/check" 2>&1; then
        passed=$((passed + 1)); echo "ok   $1"
    else
        fail "$1"; cat "$tmp/check"
    fi
}

finish() {
    if [ "$update" = 1 ]; then
        echo "golden files rewritten in $golden; review with git diff"
        exit 0
    fi
    echo "cli-net: $passed passed, $failed failed"
    if [ -n "$results" ]; then
        mkdir -p "$(dirname "$results")"
        echo "$passed $failed $label" >>"$results"
    fi
    [ "$failed" -eq 0 ]
    exit
}

mkdir -p "$golden"

# ---- help (no network) -------------------------------------------------------
t help_get       '"$DRCLI" get --help'
t help_dump      '"$DRCLI" help dump'
t help_set       '"$DRCLI" set -h'
t help_watch     '"$DRCLI" watch --help'
t help_identity  '"$DRCLI" identity --help'
t help_probe     '"$DRCLI" probe --help'

# ---- usage errors: status 2, nothing sent --------------------------------------
t err_no_host    '"$DRCLI" get io_state.robot_state'
t err_offline    '"$DRCLI" -H 127.0.0.2 list io_control'
t err_port       '"$DRCLI" -H 127.0.0.2 --port 70000 get io_state.robot_state'
t err_timeout_ms '"$DRCLI" -H 127.0.0.2 --timeout 0 get io_state.robot_state'
t err_instance   '"$DRCLI" -H 127.0.0.2 --instance io_state get io_state.robot_state'
t err_instance_n '"$DRCLI" -H 127.0.0.2 --instance dr1=0 get io_state.robot_state'
t err_instance_a '"$DRCLI" -H 127.0.0.2 --instance io_stat=101 get io_state.robot_state'
t err_get_none   '"$DRCLI" -H 127.0.0.2 get'
t err_dump_asm   '"$DRCLI" -H 127.0.0.2 dump io_contrl'
t err_set_json   '"$DRCLI" -H 127.0.0.2 set --json bit_in[0]=1'
t err_probe_raw  '"$DRCLI" -H 127.0.0.2 probe --raw'
t err_probe_arg  '"$DRCLI" -H 127.0.0.2 probe io_state'
t err_watch_int  '"$DRCLI" -H 127.0.0.2 watch --interval 0 io_state.robot_state'
t err_watch_cnt  '"$DRCLI" -H 127.0.0.2 watch --count x io_state.robot_state'
t err_watch_raw  '"$DRCLI" -H 127.0.0.2 watch --raw io_state.robot_state'
t err_bad_option '"$DRCLI" -H 127.0.0.2 get --verbose io_state.robot_state'
t err_lead_opt   '"$DRCLI" --verbose get io_state.robot_state'

# ---- unreachable robots: no peer needed ------------------------------------------
# In a network namespace of the test's own (root, unshare and ip; skipped
# loudly without): an unreachable route (no route to host), no route at all
# (network unreachable), and an address on a veth link whose far end has
# no address, with a static neighbour entry: the SYNs leave and nothing
# ever answers (no answer, after --timeout). Nothing outside is touched.
if [ "$(id -u)" = 0 ] && command -v ip >/dev/null 2>&1 && unshare -n true 2>/dev/null; then
    cat >"$tmp/bin/in_netns" <<'EOF'
#!/bin/sh
exec unshare -n sh -c 'set -e
ip link set lo up
ip route add unreachable 10.2.0.0/24
ip link add v0 type veth peer name v1
ip addr add 10.8.0.1/24 dev v0
ip link set v0 up
ip link set v1 up
ip neigh add 10.8.0.9 lladdr 02:00:00:00:00:09 dev v0 nud permanent
exec "$@"' sh "$@"
EOF
    chmod +x "$tmp/bin/in_netns"
    t err_no_route    'in_netns "$DRCLI" -H 10.2.0.5 get io_state.robot_state'
    t err_net_unreach 'in_netns "$DRCLI" -H 10.5.0.5 get io_state.robot_state'
    t err_no_answer   'in_netns "$DRCLI" -H 10.8.0.9 --timeout 300 get io_state.robot_state'
elif [ "$update" = 0 ]; then
    echo "SKIPPED err_no_route err_net_unreach err_no_answer: no network namespace here (needs root, unshare and ip)"
fi

# ---- drsim ---------------------------------------------------------------------
if ! start_drsim "$SIMLOG" "$SIM" "$SIM_UDP" -v -v ||
   ! start_drsim "$tmp/slow.log" "$SLOW" "$SLOW_UDP" --delay 1000 -v; then
    fail "drsim: cannot start $DRSIM"
    finish
fi
# Boots in 3 s: INITIALIZING, STANDBY, then OPERATING for good.
if ! wait_for OPERATING '"$DRCLI" -H 127.0.0.2 --port $SIM get io_state.robot_state'; then
    fail "drsim: robot_state never OPERATING"
    finish
fi

# Usage errors against a live robot: the log shows that nothing was sent.
t err_field      'requests "$DRCLI" -H 127.0.0.2 --port $SIM get io_state.robot_stat'
t err_field_set  'requests "$DRCLI" -H 127.0.0.2 --port $SIM set io_control.cb_dp[1]=1'
t err_t2o        'requests "$DRCLI" -H 127.0.0.2 --port $SIM set io_control.cb_do[1]=1 io_state.cb_do[3]=1'
t err_index      'requests "$DRCLI" -H 127.0.0.2 --port $SIM set io_control.cb_do[17]=1'
t err_noindex    'requests "$DRCLI" -H 127.0.0.2 --port $SIM set int_in=1'
t err_bit        'requests "$DRCLI" -H 127.0.0.2 --port $SIM set io_control.tool_do[1]=2'
t err_mask       'requests "$DRCLI" -H 127.0.0.2 --port $SIM set io_control.tool_do=0x40'
t err_dint       'requests "$DRCLI" -H 127.0.0.2 --port $SIM set int_in[0]=2147483648'
t err_malformed  'requests "$DRCLI" -H 127.0.0.2 --port $SIM set float_in[0]=1,5'
t err_nonfinite  'requests "$DRCLI" -H 127.0.0.2 --port $SIM set io_control.ao[0]=inf'
t err_no_eq      'requests "$DRCLI" -H 127.0.0.2 --port $SIM set int_in[0]'

# Network and CIP failures: status 3 and 4, host:port, step, status in words.
t err_refused    '"$DRCLI" -H 127.0.0.2 --port $DEAD get io_state.robot_state'
t err_timeout    '"$DRCLI" -H 127.0.0.2 --port $SLOW --timeout 300 get io_state.robot_state'
t err_cip        '"$DRCLI" -H 127.0.0.2 --port $SIM --instance io_state=150 get io_state.robot_state'
t err_cip_set    'requests "$DRCLI" -H 127.0.0.2 --port $SIM --instance dr7=150 set io_control.cb_do[1]=1'
t err_cip_watch  '"$DRCLI" -H 127.0.0.2 --port $SIM watch --instance int_out=99 int_out[0]'

# get: one Get_Attribute_Single per assembly, values in the order asked.
t get            '"$DRCLI" -H 127.0.0.2 --port $SIM get io_state.version.major io_state.version.minor io_state.version.patch io_state.robot_state dr1.servo_on io_state.emergency_stopped'
t get_json       '"$DRCLI" -H 127.0.0.2 --port $SIM get --json io_state.version.major io_state.version.minor io_state.robot_state dr1.servo_on'
t get_requests   'requests "$DRCLI" -H 127.0.0.2 --port $SIM get io_state.robot_state int_out[3] io_state.version.major int_out[5] dr1.servo_on'
t get_env_host   'DRCLI_HOST=127.0.0.2 "$DRCLI" --port $SIM get io_state.version.minor'
t get_opts_after '"$DRCLI" get io_state.version.minor --port=$SIM -H 127.0.0.2 --timeout 1000'
t get_route      'requests "$DRCLI" --route -H 127.0.0.2 --port $SIM get io_state.version.patch'
t get_moving     '"$DRCLI" -H 127.0.0.2 --port $SIM get dr2.position[1] task_state.position.z | sed "s/= -*[0-9.e+-]*/= N/"'

# set: checked, then one read-modify-write per assembly; drsim echoes the
# GPR inputs to the outputs and io_control to io_state.
t set_requests   'requests "$DRCLI" -H 127.0.0.2 --port $SIM set io_control.cb_do[1]=1 io_control.cb_do[2]=1 io_control.tool_do[1]=1'
t set_together   '"$DRCLI" -H 127.0.0.2 --port $SIM get io_control.cb_do io_state.cb_do io_control.tool_do io_state.tool_di'
t set_keeps      '"$DRCLI" -H 127.0.0.2 --port $SIM set io_control.cb_do[2]=0 && "$DRCLI" -H 127.0.0.2 --port $SIM get io_control.cb_do io_control.tool_do'
t set_echo       '"$DRCLI" -H 127.0.0.2 --port $SIM set bit_in[0]=1 bit_in[5]=true int_in[7]=-123456 float_in[2]=0.1 io_control.ao[1]=-2.5 && "$DRCLI" -H 127.0.0.2 --port $SIM get bit_out[0] bit_out[1] bit_out[5] int_out[7] float_out[2] io_state.ao[1]'
t set_mask       '"$DRCLI" -H 127.0.0.2 --port $SIM set bit_in=0x8000000000000001 && "$DRCLI" -H 127.0.0.2 --port $SIM get bit_out | sed -n "1,3p;\$p"'
t set_dry_run    'requests "$DRCLI" -H 127.0.0.2 --port $SIM set --dry-run int_in[3]=77 io_control.cb_do[16]=1'
t set_dry_after  '"$DRCLI" -H 127.0.0.2 --port $SIM get int_in[3] int_out[3] io_control.cb_do[16]'
t set_raw        '"$DRCLI" -H 127.0.0.2 --port $SIM set --raw float_in[0]=2.5'
t set_route      'requests "$DRCLI" -H 127.0.0.2 --port $SIM --route set int_in[1]=42'

# dump: grouped, aligned; JSON; raw bytes.
t dump_o2t       '"$DRCLI" -H 127.0.0.2 --port $SIM dump io_control dr8'
t dump_json      '"$DRCLI" -H 127.0.0.2 --port $SIM dump --json io_control'
t dump_raw       '"$DRCLI" -H 127.0.0.2 --port $SIM dump --raw dr7'
t dump_all       'requests "$DRCLI" -H 127.0.0.2 --port $SIM dump | grep -E "^#|^-- |^Get" ; "$DRCLI" -H 127.0.0.2 --port $SIM dump | grep -c " = "'
t get_raw        '"$DRCLI" -H 127.0.0.2 --port $SIM get --raw io_control.cb_do[1] bit_in[63]'
t get_raw_json   '"$DRCLI" -H 127.0.0.2 --port $SIM get --json --raw io_control.cb_do[1] io_control.ao[1]'
check dump_json_all "\"\$DRCLI\" -H 127.0.0.2 --port \$SIM dump --json | python3 -c 'import json,sys; d=json.load(sys.stdin); assert len(d) == 371, len(d)'"

# watch: one line per sample when piped; JSON lines; Ctrl-C ends it with 0.
t watch_lines    '"$DRCLI" -H 127.0.0.2 --port $SIM watch --count 3 --interval 100 io_state.version.major io_state.robot_state io_control.cb_do io_control.ao[1] | cut -d" " -f2-'
t watch_json     '"$DRCLI" -H 127.0.0.2 --port $SIM watch --json -c 2 -i 50 io_state.robot_state bit_out[63] float_out[2]'
check watch_time "\"\$DRCLI\" -H 127.0.0.2 --port \$SIM watch -c 2 io_state.servo_on | grep -Eqx '[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9]{2}:[0-9]{2}:[0-9]{2}\\.[0-9]{3}Z io_state.servo_on=1'"
check watch_interval 's=$(date +%s%N); "$DRCLI" -H 127.0.0.2 --port $SIM watch -c 5 -i 200 io_state.servo_on >/dev/null || exit 1; ms=$(( ($(date +%s%N) - s) / 1000000 )); echo "$ms ms"; [ $ms -ge 780 ] && [ $ms -lt 3000 ]'
check watch_sigint '"$DRCLI" -H 127.0.0.2 --port $SIM watch -i 50 io_state.robot_state >out & p=$!; sleep 0.8; kill -INT $p; wait $p; rc=$?; cat out; [ $rc -eq 0 ] && [ $(grep -c "robot_state=OPERATING$" out) -ge 2 ] && [ $(grep -vc "robot_state=OPERATING$" out) -eq 0 ]'
check watch_sigterm '"$DRCLI" -H 127.0.0.2 --port $SIM watch -i 50 --json io_state.robot_state >out & p=$!; sleep 0.4; kill -TERM $p; wait $p; rc=$?; [ $rc -eq 0 ] && python3 -c "import json,sys; [json.loads(l) for l in open(\"out\")]"'
if command -v script >/dev/null 2>&1; then
    # On a terminal: redrawn in place, only the changed value highlighted.
    check watch_tty 'script -qec "\"$DRCLI\" -H 127.0.0.2 --port $SIM watch -c 3 -i 100 io_state.version.major dr2.position[1]" /dev/null >tty.out;
        esc=$(printf "\033");
        [ $(grep -cF "${esc}[H" tty.out) -ge 3 ] &&
        [ $(grep -F "position[1]" tty.out | grep -cF "${esc}[7m") -ge 1 ] &&
        [ $(grep -F "version.major" tty.out | grep -cF "${esc}[7m") -eq 0 ] &&
        grep -qF "${esc}[?25h" tty.out'
else
    fail "watch_tty: script(1) not found (util-linux)"
fi

# identity, probe.
t identity       '"$DRCLI" -H 127.0.0.2 --port $SIM identity'
t identity_json  '"$DRCLI" -H 127.0.0.2 --port $SIM identity --json'
t probe          '"$DRCLI" -H 127.0.0.2 --port $SIM probe'
t probe_missing  '"$DRCLI" -H 127.0.0.2 --port $SIM --instance io_state=150 --instance dr10=99 probe'
t probe_json     '"$DRCLI" -H 127.0.0.2 --port $SIM --instance dr10=99 probe --json | python3 -c "import json,sys; d=json.load(sys.stdin); print(d[\"ok\"], d[\"assemblies\"][9], d[\"identity\"][\"product_name\"])"'
t probe_requests 'requests "$DRCLI" -H 127.0.0.2 --port $SIM probe | sed -n "/^-- drsim saw/,\$p"'

# ---- cpppo's EtherNet/IP server -------------------------------------------------
# A tag at each assembly's data attribute (class 4, instance 101..110,
# attribute 3) of the assembly's size, all zeros to begin with; instance
# 111 is 30 bytes, for a device whose assembly has the wrong size.
if ! "$PYTHON" -c 'import cpppo' 2>/dev/null; then
    fail "cpppo: not importable by $PYTHON (run make test-deps)"
    finish
fi
tags='' inst=101
for spec in io_state:36 joint_state:144 task_state:96 bit_out:8 int_out:96 \
            float_out:96 io_control:12 bit_in:8 int_in:96 float_in:96; do
    tags="$tags ${spec%%:*}@0x04/$inst/3=USINT[${spec##*:}]"
    inst=$((inst + 1))
done
# shellcheck disable=SC2086 # $tags: one word per tag
"$PYTHON" -m cpppo.server.enip --no-config --no-print --no-udp \
    --address 127.0.0.4:"$CPPPO" $tags \
    short@0x04/111/3=USINT[30] >"$tmp/cpppo.log" 2>&1 </dev/null &
pids="$pids $!"
if ! wait_for INITIALIZING '"$DRCLI" -H 127.0.0.4 --port $CPPPO --timeout 500 get io_state.robot_state'; then
    fail "cpppo: server did not answer"; cat "$tmp/cpppo.log"
    finish
fi

t cpppo_get      '"$DRCLI" -H 127.0.0.4 --port $CPPPO get io_state.robot_state io_state.version.major io_control.ao[0] int_in[0]'
t cpppo_set      '"$DRCLI" -H 127.0.0.4 --port $CPPPO set io_control.cb_do[1]=1 io_control.cb_do[3]=1 io_control.ao[0]=2.5 bit_in[7]=1 bit_in[6]=1 int_in[2]=-7 float_in[1]=0.1 && "$DRCLI" -H 127.0.0.4 --port $CPPPO get io_control.cb_do io_control.ao[0] bit_in[6] bit_in[7] bit_in[8] int_in[2] float_in[1]'
t cpppo_keeps    '"$DRCLI" -H 127.0.0.4 --port $CPPPO set io_control.cb_do[1]=0 && "$DRCLI" -H 127.0.0.4 --port $CPPPO get io_control.cb_do io_control.ao[0]'
t cpppo_route    '"$DRCLI" -H 127.0.0.4 --port $CPPPO --route set int_in[3]=99 && "$DRCLI" -H 127.0.0.4 --port $CPPPO --route get int_in[2] int_in[3]'
t cpppo_dry_run  '"$DRCLI" -H 127.0.0.4 --port $CPPPO set --dry-run io_control.cb_do[2]=1 && "$DRCLI" -H 127.0.0.4 --port $CPPPO get io_control.cb_do'
t cpppo_dump     '"$DRCLI" -H 127.0.0.4 --port $CPPPO dump io_control'
t cpppo_dump_json '"$DRCLI" -H 127.0.0.4 --port $CPPPO dump --json --raw dr8'
t cpppo_watch    '"$DRCLI" -H 127.0.0.4 --port $CPPPO watch -c 2 -i 100 io_control.cb_do int_in[3] | cut -d" " -f2-'
t cpppo_identity '"$DRCLI" -H 127.0.0.4 --port $CPPPO identity'
t cpppo_probe    '"$DRCLI" -H 127.0.0.4 --port $CPPPO probe'
t cpppo_short    '"$DRCLI" -H 127.0.0.4 --port $CPPPO --instance io_state=111 get io_state.robot_state'
t cpppo_short_probe '"$DRCLI" -H 127.0.0.4 --port $CPPPO --instance io_state=111 probe >out; echo "probe: exit $?"; head -n 2 out'
t cpppo_t2o      '"$DRCLI" -H 127.0.0.4 --port $CPPPO set io_state.robot_state=2'
# cpppo answers a request for an object it does not have by ending the
# session (encapsulation status 0x0008), not with a CIP error.
t cpppo_unknown  '"$DRCLI" -H 127.0.0.4 --port $CPPPO --instance io_state=150 get io_state.robot_state'

finish
