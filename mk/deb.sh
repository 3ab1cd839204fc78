#!/bin/sh
# SPDX-License-Identifier: MIT
# make deb: the Debian packages (debian/: drgate, drgate-sim, libdrgate1,
# libdrgate-dev) from the files git tracks in this tree, built in a copy
# under BUILD_DIR/deb/src with dpkg-buildpackage; the .debs end up in
# BUILD_DIR/deb/, then lintian on them (no error, no warning). Work in
# progress, not in make check (issue 24, section 2: the mmdebstrap install
# test, the drgate system user and arm64 are still to do).
# usage: deb.sh BUILD_DIR
set -eu
cd "$(dirname "$0")/.."
out=$(cd "${1:-build}" 2>/dev/null && pwd || { mkdir -p "${1:-build}"; cd "${1:-build}"; pwd; })/deb
for t in dpkg-buildpackage dh; do
    command -v $t >/dev/null || { echo "deb: $t missing (apt-get install dpkg-dev debhelper)" >&2; exit 1; }
done
rm -rf "$out"
mkdir -p "$out/src"
git ls-files -z --cached --others --exclude-standard | xargs -0 tar cf - | tar xf - -C "$out/src"
(cd "$out/src" && dpkg-buildpackage -b -us -uc)
ls -l "$out"/*.deb
# lintian: no error and no warning (issue 24)
if command -v lintian >/dev/null; then
    (cd "$out" && lintian --fail-on error,warning --tag-display-limit 0 ./*.changes) &&
        echo "deb: lintian: no error, no warning"
else
    echo "deb: lintian not installed (apt-get install lintian): not run" >&2
fi
