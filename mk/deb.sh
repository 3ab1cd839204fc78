#!/bin/sh
# SPDX-License-Identifier: MIT
# make deb: the Debian packages (debian/: drgate, drgate-sim, libdrgate2,
# libdrgate-dev) from the files git tracks in this tree, built in a copy
# under BUILD_DIR/deb/src with dpkg-buildpackage; the .debs end up in
# BUILD_DIR/deb/, then lintian on them (no error, no warning).
# DEB_HOST_ARCH=arm64: cross-built for arm64 into BUILD_DIR/deb-arm64/
# (dpkg-buildpackage -a arm64; the arm64 build dependencies come from
# multiarch, make test-deps). DEB_LINTIAN=no: not lintian (check-deb runs
# it and counts it). make check runs this from mk/check-deb.sh.
# usage: deb.sh BUILD_DIR
set -eu
cd "$(dirname "$0")/.."
arch=${DEB_HOST_ARCH:-}
out=$(cd "${1:-build}" 2>/dev/null && pwd || { mkdir -p "${1:-build}"; cd "${1:-build}"; pwd; })/deb${arch:+-$arch}
for t in dpkg-buildpackage dh; do
    command -v $t >/dev/null || { echo "deb: $t missing (apt-get install dpkg-dev debhelper)" >&2; exit 1; }
done
rm -rf "$out"
mkdir -p "$out/src"
git ls-files -z --cached --others --exclude-standard | xargs -0 tar cf - | tar xf - -C "$out/src"
# parallel=2: the package's make -j2 (the build is most of the time).
# A cross build runs no test (debian/rules) and needs no test dependency
# of the other architecture: the nocheck profile and option.
# Without open62541 1.4 (Debian 12 has no package of it) the daemon is
# built without its OPC UA side: the pkg.drgate.noopcua profile drops that
# build dependency (debian/control, docs/deployment.md).
profiles=${arch:+nocheck}
pkg-config --exists open62541 2>/dev/null || profiles="${profiles:+$profiles,}pkg.drgate.noopcua"
(cd "$out/src" && DEB_BUILD_OPTIONS="parallel=${DEB_JOBS:-2} ${arch:+nocheck} ${DEB_BUILD_OPTIONS:-}" \
    dpkg-buildpackage -b -us -uc ${arch:+-a "$arch"} ${profiles:+-P"$profiles"})
ls -l "$out"/*.deb
# lintian: no error and no warning (issue 24)
if [ "${DEB_LINTIAN:-yes}" = no ]; then
    :
elif command -v lintian >/dev/null; then
    (cd "$out" && lintian --fail-on error,warning --tag-display-limit 0 ./*.changes) &&
        echo "deb: lintian: no error, no warning"
else
    echo "deb: lintian not installed (apt-get install lintian): not run" >&2
fi
