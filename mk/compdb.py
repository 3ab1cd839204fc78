#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
# Write a compile_commands.json (clang's JSON compilation database) for
# clang-tidy, cppcheck --project and editors. mk/static.mk writes one line
# per source file, "FILE FLAGS...", with the flags of the Makefile rule that
# builds it; this turns them into entries (shell quoting as make's shell
# would undo it) and rewrites the output only when it changed.
# usage: compdb.py DIRECTORY COMPILER IN OUT
import json
import os
import shlex
import sys

directory, compiler, src, out = sys.argv[1:5]
entries = []
seen = set()
with open(src) as f:
    for line in f:
        words = shlex.split(line)
        if not words or words[0] in seen:
            continue
        seen.add(words[0])
        entries.append({
            "directory": directory,
            "file": words[0],
            # "command", not "arguments": cppcheck 2.10 drops the quotes of
            # -DNAME="string" from an arguments list, not from a command.
            "command": shlex.join([compiler] + words[1:] + ["-c", words[0]]),
        })
text = json.dumps(entries, indent=1) + "\n"
try:
    with open(out) as f:
        if f.read() == text:
            sys.exit(0)
except OSError:
    pass
tmp = out + ".tmp"
with open(tmp, "w") as f:
    f.write(text)
os.replace(tmp, out)
