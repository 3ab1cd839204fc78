#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""drsim's EDS (drcli eds --write) read by an independent EDS parser,
eds_pie (PyPI, pinned in tests/requirements.txt): it must parse with no
error or warning, and what it reads must be the field table's: the
identity, one parameter per leaf of `drcli list --json` plus the RPI
(named by the leaf's path, with its unit), the assemblies of the layout
with their sizes, the Class 1 connections.

usage: eds_check.py DRCLI"""
import json
import logging
import subprocess
import sys

try:
    from eds_pie.eds_pie import CIP_EDS
except ImportError:
    print("eds_pie not installed (make test-deps)")
    sys.exit(1)

SIZES = {"io_state": 36, "joint_state": 144, "task_state": 96, "bit_out": 8,
         "int_out": 96, "float_out": 96, "io_control": 12, "bit_in": 8,
         "int_in": 96, "float_in": 96}
LAYOUTS = {
    "per_assembly": ({101 + i: s for i, s in enumerate(SIZES.values())}, 6),
    "combined": ({100: 476, 150: 212}, 3),
    "gpr_only": ({100: 200, 150: 200}, 3),
}


class Count(logging.Handler):
    def __init__(self):
        super().__init__(logging.WARNING)
        self.records = []

    def emit(self, record):
        self.records.append(self.format(record))


def main():
    drcli = sys.argv[1]
    logging.getLogger().setLevel(logging.WARNING)
    for name in list(logging.root.manager.loggerDict):
        logging.getLogger(name).setLevel(logging.WARNING)
    bad = Count()
    logging.getLogger().addHandler(bad)
    leaves = json.loads(subprocess.run([drcli, "list", "--json"], check=True,
                                       capture_output=True, text=True).stdout)
    if isinstance(leaves, dict):
        leaves = leaves.get("fields", leaves.get("leaves", []))
    failures = [] if len(leaves) > 300 else [f"only {len(leaves)} leaves from drcli list --json"]
    for layout, (assems, nconn) in LAYOUTS.items():
        text = subprocess.run([drcli, "eds", "--write", "--layout", layout], check=True,
                              capture_output=True, text=True).stdout
        eds = CIP_EDS(text)
        for name in list(logging.root.manager.loggerDict):
            logging.getLogger(name).setLevel(logging.WARNING)

        def want(cond, what):
            if not cond:
                failures.append(f"{layout}: {what}")

        want(eds.get_value("Device", "VendCode") == 0xFFFF, "VendCode")
        want(eds.get_value("Device", "ProdName") == "drsim Doosan robot simulator", "ProdName")
        want(eds.get_value("Params", "Param1", 6) == "RPI", "Param1 is the RPI")
        for i, leaf in enumerate(leaves):
            path = leaf.get("path") or leaf.get("name")
            entry = f"Param{i + 2}"
            want(eds.get_value("Params", entry, 6) == path, f"{entry} named {path}")
            want(eds.get_value("Params", entry, 7) == (leaf.get("unit") or ""),
                 f"{entry} unit {leaf.get('unit')}")
        want(not eds.has_entry("Params", f"Param{len(leaves) + 2}"), "no extra parameter")
        for inst, size in assems.items():
            want(eds.get_value("Assembly", f"Assem{inst}", 2) == size,
                 f"Assem{inst} is {size} bytes")
        for n in range(1, nconn + 1):
            want(eds.has_entry("Connection Manager", f"Connection{n}"), f"Connection{n}")
        want(not eds.has_entry("Connection Manager", f"Connection{nconn + 1}"),
             f"{nconn} connections")
        print(f"eds_pie: {layout}: {len(leaves) + 1} parameters, {len(assems)} assemblies, "
              f"{nconn} connections")
    failures += bad.records
    for f in failures:
        print("FAIL", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
