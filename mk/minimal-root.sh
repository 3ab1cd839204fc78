#!/bin/sh
# SPDX-License-Identifier: MIT
# usage: minimal-root.sh DIR: writes DIR/status, the dpkg status of a fresh
# minimal Debian bookworm (debootstrap --variant=minbase, the debian:bookworm
# container): the installed packages of Priority required, Essential and apt,
# and what they depend on, cut out of this machine's /var/lib/dpkg/status,
# each at the version of the package lists (a root made today).
# apt plans against it (-o Dir::State::status=DIR/status) and dpkg-query
# reads it (--admindir=DIR) as if on that machine: nothing is installed.
set -eu
mkdir -p "$1"
# The seed and everything it depends on, closed over this machine's status.
python3 - "$1/status" <<'PY'
import re, sys
stanzas = open("/var/lib/dpkg/status").read().split("\n\n")
pk = {}
for st in stanzas:
    f = dict(re.findall(r"^([A-Za-z-]+): ?(.*)$", st, re.M))
    if "install ok installed" in f.get("Status", "") and f.get("Architecture") != "s390x":
        pk[f["Package"]] = (st.strip(), f)
todo = [n for n, (_, f) in pk.items()
        if f.get("Priority") == "required" or f.get("Essential") == "yes" or n == "apt"]
keep = set()
while todo:
    n = todo.pop()
    if n in keep or n not in pk:
        continue
    keep.add(n)
    f = pk[n][1]
    for dep in (f.get("Depends", "") + "," + f.get("Pre-Depends", "")).split(","):
        for alt in dep.split("|"):
            m = re.match(r"\s*([^\s:(]+)", alt)
            if m and m.group(1) in pk:
                todo.append(m.group(1))
                break
# As installed today: each package at the version the package lists
# have (this machine's may be older), as apt describes it.
import subprocess
out = subprocess.run(["apt-cache", "show", "--no-all-versions"] + sorted(keep),
                     capture_output=True, text=True).stdout
fresh = {}
for st in out.split("\n\n"):
    m = re.search(r"^Package: (\S+)$", st, re.M)
    if m and m.group(1) in keep:
        st = re.sub(r"^(Package: .*)$", r"\1\nStatus: install ok installed", st.strip(),
                    count=1, flags=re.M)
        fresh[m.group(1)] = st
text = "\n\n".join(fresh.get(n, pk[n][0]) for n in sorted(keep))
open(sys.argv[1], "w").write(text + "\n")
PY
