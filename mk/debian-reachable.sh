#!/bin/sh
# SPDX-License-Identifier: MIT
# Exit 0 if the Debian archive mmdebstrap uses (deb.debian.org, bookworm)
# answers within 20 s: check-deb and check-arm64 skip without it.
exec python3 - <<'PY'
import sys, urllib.request
try:
    urllib.request.urlopen("http://deb.debian.org/debian/dists/bookworm/Release", timeout=20).read(64)
except Exception as e:
    print(f"deb.debian.org: {e}", file=sys.stderr)
    sys.exit(1)
PY
