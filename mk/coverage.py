#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Line coverage per top-level directory from gcovr's JSON summary
(mk/coverage.mk): prints a table, writes it to a file, and with --check
compares each directory that has a floor with it, appending one
"passed failed label" line per floor to the results file.

usage: coverage.py SUMMARY.json TABLE.txt [--check RESULTS] [DIR=PERCENT...]
"""
import json
import sys


def main(argv):
    summary, table = argv[0], argv[1]
    rest = argv[2:]
    results = None
    if rest[:1] == ["--check"]:
        results, rest = rest[1], rest[2:]
    floors = {}
    for a in rest:
        d, p = a.split("=")
        floors[d.rstrip("/")] = float(p)

    with open(summary) as f:
        files = json.load(f)["files"]
    per = {}
    for f in files:
        top = f["filename"].split("/")[0]
        c, t = per.setdefault(top, [0, 0, []])[:2]
        per[top][0] = c + f["line_covered"]
        per[top][1] = t + f["line_total"]
        per[top][2].append(f)

    lines = ["%-10s %8s %8s %8s   %s" % ("directory", "lines", "covered", "percent", "floor")]
    failed = []
    for d in sorted(per):
        c, t, _ = per[d]
        pct = 100.0 * c / t if t else 100.0
        fl = floors.get(d)
        mark = "" if fl is None else ("%.0f%% %s" % (fl, "ok" if pct >= fl else "BELOW"))
        lines.append("%-10s %8d %8d %7.1f%%   %s" % (d + "/", t, c, pct, mark))
        if fl is not None and pct < fl:
            failed.append(d)
    # directories with a floor but no data at all are a failure too
    for d in sorted(floors):
        if d not in per:
            lines.append("%-10s %8s %8s %8s   %.0f%% BELOW (no coverage data)"
                         % (d + "/", "-", "-", "-", floors[d]))
            failed.append(d)
    # the files that pull a directory below its floor, least covered first
    for d in failed:
        if d in per:
            lines.append("")
            lines.append("%s/ below its floor: least covered files" % d)
            for f in sorted(per[d][2], key=lambda f: f["line_percent"])[:8]:
                lines.append("  %-36s %5d lines, %5.1f%%" % (f["filename"], f["line_total"],
                                                           f["line_percent"]))
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    with open(table, "w") as f:
        f.write(text)

    if results is not None:
        with open(results, "a") as f:
            for d in sorted(floors):
                c, t = per.get(d, [0, 0])[:2]
                pct = 100.0 * c / t if t else 0.0
                ok = d not in failed
                f.write("%d %d coverage %s/: %.1f%% of %d lines (floor %.0f%%)\n"
                        % (1 if ok else 0, 0 if ok else 1, d, pct, t, floors[d]))
    return 1 if (results is not None and failed) else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
