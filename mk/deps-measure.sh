#!/bin/sh
# SPDX-License-Identifier: MIT
# make deps-measure: what `make deps` (deps.sh demo) and `make test-deps`
# would install on a fresh Debian bookworm machine, in packages and bytes.
# A fresh machine is taken as a minimal bookworm (debootstrap --variant=minbase,
# the debian:bookworm container): the packages of Priority required,
# Essential and apt, and what they depend on. Its dpkg status is cut out of this machine's (those stanzas only), and
# apt plans the install against it with this machine's package lists
# (apt-get -s, --print-uris): nothing is installed or downloaded. Not in make
# check (it reads every package list: a few seconds); docs/deployment.md
# quotes its output.
set -eu
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
sh mk/minimal-root.sh "$tmp"
base=$(grep -c '^Package:' "$tmp/status")
echo "minimal bookworm root: $base packages (Priority required, Essential, apt and their dependencies)"
for set in demo test; do
    pk=$(sh mk/deps.sh --list "$set" | grep -v ':s390x\|:arm64' | tr '\n' ' ')
    apt="apt-get -q -o Dir::State::status=$tmp/status -o APT::Architectures=amd64 \
         install --no-install-recommends"
    # shellcheck disable=SC2086
    n=$($apt -s $pk 2>/dev/null | grep -c '^Inst ')
    # shellcheck disable=SC2086
    bytes=$($apt --print-uris -y $pk 2>/dev/null | awk '/^'\''/ { s += $3 } END { print s + 0 }')
    # shellcheck disable=SC2086
    disk=$($apt --print-uris -y $pk 2>/dev/null | sed -n 's/^After this operation, \(.*\) of additional.*/\1/p')
    printf '%-5s %3d packages, %5.1f MB to download, %s on disk%s\n' "$set" "$n" \
        "$(echo "$bytes" | awk '{ print $1 / 1e6 }')" "${disk:-?}" \
        "$([ "$set" = test ] && echo ' (amd64 only: + the s390x and arm64 libraries)')"
done
