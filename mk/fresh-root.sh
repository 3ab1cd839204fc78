#!/bin/sh
# SPDX-License-Identifier: MIT
# Fresh machines: the README's commands run in a minimal Debian root made
# with mmdebstrap, cached on this machine, each run in a new throwaway copy
# of it, isolated (its own mount, PID and network namespaces) and reaching
# the outside only through an HTTP proxy that lets through the Debian
# archive its apt sources name and PyPI (mk/fresh-proxy.py).
#
# usage (as root):
#   sh mk/fresh-root.sh run SUITE -- COMMAND...
#         COMMAND in a fresh copy of SUITE's root, in /src: a `git clone` of
#         this repository's committed HEAD (uncommitted changes are not in
#         it). Prints the command, its exit status, its wall time and how
#         many packages it installed; exits with COMMAND's status (124 on
#         timeout). The copy is removed afterwards, also on failure or ^C.
#         Example: sh mk/fresh-root.sh run trixie -- sh -c 'DEPS_YES=1 make demo'
#   sh mk/fresh-root.sh build SUITE...
#         make (or refresh) the cached roots now; `run` does it when needed
#   sh mk/fresh-root.sh check BUILD_DIR [RESULTS]
#         make check-fresh (mk/fresh.mk): on bookworm and on trixie,
#         `DEPS_YES=1 make demo` (trixie: make -j2 demo) passes and shows the demo's output; on
#         bookworm-old, `DEPS_YES=1 make test-deps` passes. Logs in
#         BUILD_DIR/fresh/.
# SUITE: bookworm, trixie, or bookworm-old (bookworm whose dpkg status says
# perl, perl-base, perl-modules-5.36, libperl5.36 are 5.36.0-7 and libc6,
# libc-bin are 2.36-9+deb12u4: older than the archive, so that installing
# lintian or build-essential needs upgrades, as on a machine not upgraded
# for a while).
#
# The roots: FRESH_CACHE/roots/SUITE.tar.zst (FRESH_CACHE: /var/cache/drgate),
# `mmdebstrap --variant=minbase --include=git,ca-certificates,make,iproute2
# SUITE`, made again when older than FRESH_MAX_AGE days (7) or when the
# recipe (SUITE.recipe beside it) changed. apt's downloads are kept in
# FRESH_CACHE/apt-SUITE (bind-mounted over the root's
# /var/cache/apt/archives), so a second run downloads only the package lists.
#
# In a run: the copy is extracted under FRESH_TMP (/var/tmp); the host's
# /usr/local/share/ca-certificates/*.crt are added (this site's HTTPS has
# its own CA), and /etc/hosts as Debian's installer writes it (localhost);
# then `unshare --mount --pid --net --fork --kill-child` and
# chroot, with /proc, /sys, /dev (a few nodes, devpts, /dev/net/tun),
# /run (tmpfs) mounted in that mount namespace only. The network namespace
# has loopback only; socat (the host's, inside the namespace) bridges
# 127.0.0.1:3128 to the proxy's unix socket. apt gets Acquire::http::Proxy,
# the command gets http_proxy/https_proxy (pip) and no_proxy for loopback.
# The proxy refuses other hosts with 403 and logs every request; the run
# prints how many went through and every refused one.
# dpkg runs with force-unsafe-io in the copy (it is thrown away; no fsync).
#
# (dash: `local` is used.)
# Environment: FRESH_CACHE, FRESH_TMP, FRESH_MAX_AGE (days),
# FRESH_TIMEOUT (seconds per run command, 3600), FRESH_SEED (a directory
# with SUITE.tar.zst made by the same recipe, copied when the cache has
# none; unset: do not seed).
set -u
cd "$(dirname "$0")/.."
top=$(pwd)
CACHE=${FRESH_CACHE:-/var/cache/drgate}
TMPBASE=${FRESH_TMP:-/var/tmp}
MAX_AGE=${FRESH_MAX_AGE:-7}
RUN_TIMEOUT=${FRESH_TIMEOUT:-3600}
SEED=${FRESH_SEED:-}
INCLUDE=git,ca-certificates,make,iproute2
# Bump when the way a root is made changes: every cached root is remade.
RECIPE_VERSION=1
# bookworm-old: "SOURCE-PACKAGE=OLD-VERSION" for the packages it claims.
STALE="perl=5.36.0-7 glibc=2.36-9+deb12u4"
PROXY_PORT=3128
# The test peers' registries: PyPI (pip) and npm's (Eclipse Tahu's
# packages, npm ci in make test-deps).
PIP_HOSTS="pypi.org files.pythonhosted.org registry.npmjs.org"
PY=$(command -v python3)

say() { echo "fresh-root: $*"; }
die() { echo "fresh-root: $*" >&2; exit 1; }

# ---- the cached roots --------------------------------------------------------
recipe() { # SUITE
    case $1 in
        bookworm|trixie) echo "v$RECIPE_VERSION mmdebstrap --variant=minbase --include=$INCLUDE $1" ;;
        bookworm-old) echo "v$RECIPE_VERSION $(recipe bookworm) + dpkg status: $STALE" ;;
        *) die "unknown suite '$1' (bookworm, trixie, bookworm-old)" ;;
    esac
}
tarball() { echo "$CACHE/roots/$1.tar.zst"; }
# apt's archive cache: bookworm-old downloads what bookworm does.
apt_cache() { echo "$CACHE/apt-${1%-old}"; }

# Up to date: there, made by today's recipe, younger than MAX_AGE days
# (bookworm-old: and younger than the bookworm root it was made from).
current() { # SUITE
    local t; t=$(tarball "$1")
    [ -s "$t" ] && [ "$(cat "$t.recipe" 2>/dev/null)" = "$(recipe "$1")" ] &&
        [ -n "$(find "$t" -mtime -"$MAX_AGE")" ] || return 1
    [ "$1" != bookworm-old ] || [ ! "$(tarball bookworm)" -nt "$t" ]
}

age() { # FILE: its age in hours
    echo $(( ($(date +%s) - $(stat -c %Y "$1")) / 3600 ))
}

ensure_root() { # SUITE: make it if it is not current (under a lock)
    current "$1" && return 0
    mkdir -p "$CACHE/roots" || return 1
    (
        flock -w 1800 9 || die "waited 30 min for $CACHE/roots/.lock"
        current "$1" && exit 0
        build_root "$1"
    ) 9>"$CACHE/roots/.lock"
}

build_root() { # SUITE (under the lock)
    local s t t0; s=$1 t=$(tarball "$1")
    rm -f "$t" "$t.recipe"
    if [ "$s" = bookworm-old ]; then
        ensure_root bookworm || return 1
        build_old "$t" || return 1
    else
        if [ -n "$SEED" ] && [ -s "$SEED/$s.tar.zst" ] &&
                [ -n "$(find "$SEED/$s.tar.zst" -mtime -"$MAX_AGE")" ]; then
            say "$s: seeding the cache from $SEED/$s.tar.zst ($(age "$SEED/$s.tar.zst") h old)"
            cp -p "$SEED/$s.tar.zst" "$t.new.tar.zst" || return 1
        else
            say "$s: building the root: mmdebstrap --variant=minbase --include=$INCLUDE $s"
            t0=$(date +%s)
            if ! timeout -k 10 1200 mmdebstrap --quiet --variant=minbase --include="$INCLUDE" \
                    "$s" "$t.new.tar.zst" > "$t.log" 2>&1; then
                tail -5 "$t.log" >&2; rm -f "$t.new.tar.zst"
                say "$s: mmdebstrap failed (log: $t.log)"; return 1
            fi
            say "$s: built in $(( $(date +%s) - t0 )) s, $(( $(stat -c %s "$t.new.tar.zst") / 1048576 )) MB"
        fi
        mv "$t.new.tar.zst" "$t"
    fi
    recipe "$s" > "$t.recipe"
}

# bookworm-old: the bookworm root with its dpkg status edited so that the
# packages of the sources in STALE claim OLD-VERSION (their relations to
# each other at that version too), then checked: apt plans the upgrades.
build_old() { # TARBALL
    local t0 d plan missing p l; t0=$(date +%s)
    d=$(mktemp -d "$TMPBASE/drgate-fresh-old.XXXXXX") || return 1
    mkdir "$d/root"
    zstd -dcq "$(tarball bookworm)" | tar -x --numeric-owner -C "$d/root" || { rm -rf "$d"; return 1; }
    "$PY" - "$d/root/var/lib/dpkg/status" $STALE <<'PY' || { rm -rf "$d"; return 1; }
import re, sys
path, stale = sys.argv[1], dict(a.split("=", 1) for a in sys.argv[2:])
stanzas = open(path).read().rstrip("\n").split("\n\n")
out = []
for st in stanzas:
    pkg = re.search(r"^Package: (\S+)$", st, re.M).group(1)
    src = re.search(r"^Source: (\S+)", st, re.M)
    src = src.group(1) if src else pkg
    if src in stale:
        cur = re.search(r"^Version: (\S+)$", st, re.M).group(1)
        # the installed version, and every relation naming it (perl's
        # Depends: perl-base (= V), libperl5.36 (= V), ...)
        st = st.replace(cur, stale[src])
        print(f"  {pkg}: {cur} -> {stale[src]}")
    out.append(st)
open(path, "w").write("\n\n".join(out) + "\n")
PY
    tar -C "$d/root" --numeric-owner -cf - . | zstd -q -T0 -3 > "$1.new.tar.zst" ||
        { rm -rf "$d" "$1.new.tar.zst"; return 1; }
    rm -rf "$d"
    mv "$1.new.tar.zst" "$1"
    recipe bookworm-old > "$1.recipe"
    # apt on that root must now plan the upgrades a stale machine needs
    say "bookworm-old: checking that apt plans the upgrades (apt-get -s install lintian build-essential)"
    plan=$(FRESH_QUIET=1 sh "$0" run bookworm-old -- sh -c \
        'apt-get update -qq && apt-get -s install --no-install-recommends lintian build-essential' 2>&1)
    missing=
    for p in perl-base perl libperl5.36 perl-modules-5.36 libc6 libc-bin; do
        l=$(printf '%s\n' "$plan" | grep "^Inst $p \[") || missing="$missing $p"
        [ -z "$l" ] || echo "  $l"
    done
    if [ -n "$missing" ]; then
        printf '%s\n' "$plan" | tail -20 >&2
        rm -f "$1" "$1.recipe"
        say "bookworm-old: apt plans no upgrade of$missing: the root is not stale"; return 1
    fi
    say "bookworm-old: made in $(( $(date +%s) - t0 )) s"
}

# ---- a run -------------------------------------------------------------------
pkgs() { # ROOT: installed packages
    dpkg-query --admindir="$1/var/lib/dpkg" -W -f='${db:Status-Abbrev}\n' 2>/dev/null | grep -c '^ii'
}

# The hosts the root's apt sources name (one-line and deb822 formats).
apt_hosts() { # ROOT
    cat "$1"/etc/apt/sources.list "$1"/etc/apt/sources.list.d/*.list \
        "$1"/etc/apt/sources.list.d/*.sources 2>/dev/null |
        grep -oE '(http|https)://[^/ ]+' | sed 's|.*://||; s|:.*||' | sort -u
}

# Mount points at or under DIR, in this (the host's) mount namespace.
mounts_under() { # DIR
    awk -v d="$1" '$5 == d || index($5, d "/") == 1 { print $5 }' /proc/self/mountinfo
}

# Runs in the new namespaces, as their PID 1, before the chroot. It is
# written into the run's directory and started with the host's sh.
inner_script() {
    cat <<'EOF'
set -eu
r=$1 sock=$2 cache=$3 port=$4; shift 4
# the root a mount point of its own: `ip netns exec` remounts / as a slave
mount --bind "$r" "$r"
mount -t proc -o nosuid,nodev,noexec proc "$r/proc"
mount -t sysfs -o nosuid,nodev,noexec sysfs "$r/sys"
mount -t tmpfs -o nosuid,mode=755,size=64m dev "$r/dev"
for n in null zero full random urandom tty; do
    touch "$r/dev/$n"; mount --bind "/dev/$n" "$r/dev/$n"
done
if [ -e /dev/net/tun ]; then mkdir "$r/dev/net"; touch "$r/dev/net/tun"; mount --bind /dev/net/tun "$r/dev/net/tun"; fi
mkdir "$r/dev/pts" "$r/dev/shm"
mount -t devpts -o newinstance,ptmxmode=0666,mode=620 devpts "$r/dev/pts"
ln -s pts/ptmx "$r/dev/ptmx"
mount -t tmpfs -o nosuid,nodev,mode=1777 shm "$r/dev/shm"
ln -s /proc/self/fd "$r/dev/fd"; ln -s /proc/self/fd/0 "$r/dev/stdin"
ln -s /proc/self/fd/1 "$r/dev/stdout"; ln -s /proc/self/fd/2 "$r/dev/stderr"
mount -t tmpfs -o nosuid,nodev,mode=755 run "$r/run"
mount --bind "$cache" "$r/var/cache/apt/archives"
ip link set lo up
# The proxy's port on loopback: the host's socat, in this network namespace.
socat TCP-LISTEN:"$port",bind=127.0.0.1,reuseaddr,fork UNIX-CONNECT:"$sock" &
hex=$(printf '%04X' "$port") i=0
until grep -q "^ *[0-9]*: 0100007F:$hex 00000000:0000 0A" /proc/net/tcp; do
    i=$((i + 1)); [ $i -le 50 ] || { echo "fresh-root: socat did not listen on $port" >&2; exit 125; }
    sleep 0.1
done
proxy=http://127.0.0.1:$port
set +e
chroot "$r" /usr/bin/env -i PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    HOME=/root TERM="${TERM:-dumb}" http_proxy=$proxy https_proxy=$proxy \
    HTTP_PROXY=$proxy HTTPS_PROXY=$proxy no_proxy=localhost,127.0.0.1,::1 \
    NO_PROXY=localhost,127.0.0.1,::1 NODE_EXTRA_CA_CERTS=/etc/ssl/certs/ca-certificates.crt \
    /bin/sh -c \
    'update-ca-certificates >/dev/null 2>&1 || echo "fresh-root: update-ca-certificates failed" >&2
     cd /src && exec "$@"' sh "$@"
st=$?
# the cache keeps only what the archive still has
[ -z "$(ls "$r/var/lib/apt/lists" | grep -v '^lock$\|^partial$\|^auxfiles$')" ] ||
    chroot "$r" apt-get -qq autoclean >/dev/null 2>&1 || true
exit $st
EOF
}

run() { # SUITE COMMAND...
    s=$1; shift
    recipe "$s" >/dev/null
    [ "$(id -u)" = 0 ] || die "run needs root (unshare, chroot)"
    ensure_root "$s" || die "$s: no root"
    sha=$(git -C "$top" rev-parse HEAD) || die "no git HEAD in $top"
    tmp=$(mktemp -d "$TMPBASE/drgate-fresh-$s.XXXXXX") || die "mktemp in $TMPBASE"
    root=$tmp/root pxpid= nspid=
    # shellcheck disable=SC2317
    cleanup() {
        [ -z "$nspid" ] || { kill "$nspid" 2>/dev/null; wait "$nspid" 2>/dev/null; }
        [ -z "$pxpid" ] || { kill "$pxpid" 2>/dev/null; wait "$pxpid" 2>/dev/null; }
        left=$(mounts_under "$tmp")
        if [ -n "$left" ]; then
            # never rm -rf through a mount (the apt cache, /dev)
            echo "fresh-root: mounts left under $tmp, not removing it:" $left >&2
        else
            tc=$(date +%s)
            rm -rf "$tmp"
            [ -n "${FRESH_QUIET:-}" ] || say "$s: the copy removed in $(( $(date +%s) - tc )) s"
        fi
    }
    trap cleanup EXIT
    trap 'exit 130' INT
    trap 'exit 143' TERM HUP
    t0=$(date +%s)
    mkdir "$root" "$tmp/px"
    zstd -dcq "$(tarball "$s")" | tar -x --numeric-owner -C "$root" || die "$s: extracting failed"
    # apt: through the proxy, one request per connection (the proxy's way),
    # keeping what it downloads (in the bind-mounted cache); a docker-clean
    # style hook would delete it.
    for f in "$root"/etc/apt/apt.conf.d/*; do
        if grep -qs 'cache/apt/archives' "$f"; then say "$s: removing ${f#"$root"} (deletes apt's downloads)"; rm -f "$f"; fi
    done
    cat > "$root/etc/apt/apt.conf.d/00drgate-fresh" <<EOF
// mk/fresh-root.sh: the root reaches the archive through its proxy only
Acquire::http::Proxy "http://127.0.0.1:$PROXY_PORT";
Acquire::https::Proxy "http://127.0.0.1:$PROXY_PORT";
Acquire::http::Pipeline-Depth "0";
Acquire::Retries "3";
APT::Keep-Downloaded-Packages "true";
Binary::apt::APT::Keep-Downloaded-Packages "true";
EOF
    mkdir -p "$root/etc/dpkg/dpkg.cfg.d"
    echo force-unsafe-io > "$root/etc/dpkg/dpkg.cfg.d/drgate-fresh-unsafe-io"
    cp /usr/local/share/ca-certificates/*.crt "$root/usr/local/share/ca-certificates/" 2>/dev/null || true
    # What every installed Debian has and a minbase root lacks: no package
    # ships /etc/hosts, the installer (or the cloud image) writes it, so
    # "localhost" resolves there (test_tls_by_host_name names its broker so)
    [ -e "$root/etc/hosts" ] || printf '127.0.0.1\tlocalhost\n::1\t\tlocalhost ip6-localhost ip6-loopback\n' \
        > "$root/etc/hosts"
    git clone -q --no-checkout "$top" "$root/src" && git -C "$root/src" checkout -q "$sha" ||
        die "git clone of $top at $sha failed"
    cache=$(apt_cache "$s")
    mkdir -p "$cache/partial"
    # one run at a time per apt cache (apt's lock in it would fail the other)
    exec 8>"$cache.lock"
    flock -w 1800 8 || die "waited 30 min for $cache.lock (another run)"
    hosts="$(apt_hosts "$root" | tr '\n' ' ')$PIP_HOSTS"
    sock=$tmp/px/proxy.sock
    "$PY" mk/fresh-proxy.py "$sock" "$tmp/proxy.log" $hosts &
    pxpid=$!
    i=0
    until [ -S "$sock" ]; do
        i=$((i + 1)); [ $i -le 100 ] && kill -0 "$pxpid" 2>/dev/null || die "the proxy did not start"
        sleep 0.1
    done
    inner_script > "$tmp/inner.sh"
    c0=$(pkgs "$root")
    [ -n "${FRESH_QUIET:-}" ] ||
        say "$s: root $(age "$(tarball "$s")") h old, $c0 packages, /src at $(git -C "$top" log -1 --format='%h %s' | cut -c1-60), extracted in $(( $(date +%s) - t0 )) s; proxy allows: $hosts"
    [ -n "${FRESH_QUIET:-}" ] || [ -z "$(git -C "$top" status --porcelain --untracked-files=no)" ] ||
        say "$s: (uncommitted changes in $top are not in /src)"
    show=${FRESH_SHOW:-$*}
    [ -n "${FRESH_QUIET:-}" ] || say "$s: \$ $show"
    t1=$(date +%s)
    timeout -k 10 "$RUN_TIMEOUT" unshare --mount --pid --net --fork --kill-child --propagation private \
        sh "$tmp/inner.sh" "$root" "$sock" "$cache" "$PROXY_PORT" "$@" &
    nspid=$!
    wait "$nspid"; st=$?; nspid=
    t2=$(date +%s)
    c1=$(pkgs "$root")
    na=$(grep -c ' allow ' "$tmp/proxy.log")
    nd=$(grep -c ' DENY ' "$tmp/proxy.log")
    [ "$st" != 124 ] || say "$s: timed out after $RUN_TIMEOUT s (FRESH_TIMEOUT)"
    say "$s: \$ $show: exit $st, $((t2 - t1)) s; packages $c0 -> $c1 (+$((c1 - c0))); proxy: $na requests through, $nd refused"
    grep ' DENY \| FAIL ' "$tmp/proxy.log" | sed "s/^/fresh-root: $s: proxy: /" | head -20
    return "$st"
}

# ---- make check-fresh ------------------------------------------------------
check() { # BUILD_DIR [RESULTS]
    . tests/skip.sh
    b=$1 res=${2:-}
    label="fresh machines: make demo on bookworm and trixie, make test-deps on an old bookworm, the unit, gateway and package checks on trixie (mk/fresh-root.sh)"
    skip_name=check-fresh skip_results=$res skip_label=$label
    [ "$(id -u)" = 0 ] || skip "not root (unshare, chroot)"
    for t in mmdebstrap unshare zstd socat python3 flock; do
        command -v $t >/dev/null || skip "no $t (make test-deps, or apt-get install ${t%%unshare}${t#unshare})"
    done
    . mk/check-lib.sh
    mkdir -p "$b/fresh"
    for s in bookworm trixie bookworm-old; do
        t=$(tarball "$s")
        if current "$s"; then
            ok "root $s: cached, $(age "$t") h old ($t)"
        else
            t0=$(date +%s)
            if ensure_root "$s" > "$b/fresh/root-$s.log" 2>&1; then
                sed 's/^/  /' "$b/fresh/root-$s.log"
                ok "root $s: made in $(( $(date +%s) - t0 )) s"
            else
                sed 's/^/  /' "$b/fresh/root-$s.log"; bad "root $s: could not be made"
            fi
        fi
    done
    # one case: SUITE NAME COMMAND [SHOWN]; its output in $b/fresh/SUITE-NAME.log
    case_run() {
        local log cst; log=$b/fresh/$1-$2.log
        FRESH_SHOW=${4:-$3} sh "$0" run "$1" -- sh -c "$3" < /dev/null > "$log" 2>&1; cst=$?
        grep '^fresh-root: ' "$log" | sed 's/^fresh-root: /    /'
        return $cst
    }
    # the end of a failed case's log, its own lines only
    log_tail() { grep -v '^fresh-root: \|^probe-' "$1" | tail -"$2" | sed 's/^/    | /'; }
    # bookworm and trixie: the README's `make demo`, then two probes of the
    # isolation (the proxy refuses another host; no route out but it)
    # (on trixie with -j2: the build must wait for the install, as it does
    # serially)
    demo='DEPS_YES=1 make $J demo; st=$?
bash -c '\''exec 3<>/dev/tcp/127.0.0.1/'"$PROXY_PORT"' && printf "CONNECT example.com:443 HTTP/1.1\r\n\r\n" >&3 && head -1 <&3'\'' 2>&1 | sed "s/^/probe-proxy: /"
ip route get 192.0.2.1 2>&1 | sed "s/^/probe-direct: /"
exit $st'
    for s in bookworm trixie; do
        l=$b/fresh/$s-demo.log
        j=; [ "$s" = trixie ] && j=-j2
        if case_run "$s" demo "J=$j; $demo" "DEPS_YES=1 make $j demo  (then 2 probes of the isolation)"; then
            if grep -q 'link up' "$l" && [ "$(grep -cE '^\[[0-9]+\]:' "$l")" -ge 20 ] &&
                    grep -qE '^\[[0-9]+\]:[[:space:]]*4242$' "$l" &&
                    grep -qE '^Written [0-9]+ references' "$l" && grep -q 'Illegal data value' "$l"; then
                ok "$s: make demo: exit 0, the demo's output (link up, registers, 4242 echoed, NaN refused)"
            else
                log_tail "$l" 12
                bad "$s: make demo: exit 0 but not the demo's output (link up, registers, int_out 4242, the NaN write refused; log: $l)"
            fi
        else
            log_tail "$l" 12
            bad "$s: make demo failed (log: $l)"
        fi
        grep -q '^probe-proxy: HTTP/1.1 403' "$l" && grep -qi '^probe-direct: .*unreachable' "$l" &&
            ok "$s: isolated (the proxy refuses example.com, no route out)" ||
            bad "$s: isolation probes: $(grep '^probe-' "$l" | tr '\n' ' ')"
    done
    if case_run bookworm-old test-deps 'DEPS_YES=1 make test-deps'; then
        ok "bookworm-old: make test-deps exit 0"
        # deps.sh named the upgrades before it made them
        grep -q '^deps: and upgrade .* installed packages' "$b/fresh/bookworm-old-test-deps.log" &&
            grep -q '^  perl-base 5.36.0-7 -> ' "$b/fresh/bookworm-old-test-deps.log" &&
            ok "bookworm-old: the upgrades were named first (perl-base 5.36.0-7 -> $(sed -n 's/^  perl-base 5.36.0-7 -> //p' "$b/fresh/bookworm-old-test-deps.log"))" ||
            bad "bookworm-old: deps.sh did not name the upgrade of perl-base"
    else
        log_tail "$b/fresh/bookworm-old-test-deps.log" 8
        bad "bookworm-old: make test-deps failed (log: $b/fresh/bookworm-old-test-deps.log)"
    fi
    # trixie: what make check can run there beyond the demo: the unit
    # tests, the gateway's end-to-end suite, the library's CMake package
    # (trixie's newer CMake), the OPC UA side's (only trixie packages
    # open62541, mk/opcua.mk) and the Debian packages (amd64 and arm64),
    # after `make test-deps`. The inner make's results come back
    # as "result: PASSED FAILED LABEL" lines of the log.
    trixie_check='DEPS_YES=1 make test-deps && make -j2 all || exit 1
make -k check-unit check-gateway check-cmake check-opcua check-deb check-arm64 RESULTS=/src/build/trixie-results; st=$?
sed "s/^/result: /" build/trixie-results
exit $st'
    l=$b/fresh/trixie-check.log
    case_run trixie check "$trixie_check" \
        "DEPS_YES=1 make test-deps && make -j2 all && make check-unit check-gateway check-cmake check-opcua check-deb check-arm64"
    cst=$?
    if grep -q '^result: ' "$l"; then
        # shellcheck disable=SC2034
        sed -n 's/^result: //p' "$l" | while read -r p f what; do
            [ "$f" = 0 ] && echo "  ok: trixie: $what: $p passed" ||
                echo "  FAIL: trixie: $what: $p passed, $f failed"
        done
        n_bad=$(sed -n 's/^result: //p' "$l" | awk '$2 > 0' | grep -c .)
        n_ok=$(sed -n 's/^result: //p' "$l" | awk '$2 == 0' | grep -c .)
        pass=$((pass + n_ok)) fail=$((fail + n_bad))
        [ "$cst" = 0 ] || [ "$n_bad" -gt 0 ] || bad "trixie: make check-... exit $cst (log: $l)"
    else
        log_tail "$l" 15
        bad "trixie: make test-deps or the build failed (log: $l)"
    fi
    check_done
}

case "${1:-}" in
    run)
        shift; [ $# -ge 3 ] && [ "$2" = -- ] || die "usage: fresh-root.sh run SUITE -- COMMAND..."
        s=$1; shift 2; run "$s" "$@"; exit ;;
    build)
        shift; [ "$(id -u)" = 0 ] || die "build needs root"
        for s in "$@"; do recipe "$s" >/dev/null
            current "$s" && say "$s: current ($(age "$(tarball "$s")") h old)" || ensure_root "$s" || exit 1
        done ;;
    check) shift; check "$@" ;;
    *) sed -n '3,/^set -u/p' "$0" | sed '$d; s/^# \{0,1\}//' >&2; exit 2 ;;
esac
