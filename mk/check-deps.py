#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""make check-deps: the build knows which headers each file includes.

Every compile rule writes the headers it read (-MMD -MP, the Makefile's
DEPFLAGS) and the Makefile reads those lists, so that touching a header
rebuilds what includes it. A rule that forgets DEPFLAGS, or a Makefile
that stops reading the lists, leaves a stale build after a header change
(once, `touch lib/fields_internal.h` and `make` said "nothing to do").
This checks it three ways, on a build that is up to date:

1. `make -q TARGETS` says nothing is to be done: no rule is run again on
   every call (a rule whose target never appears, or that leaves no list).
2. make's own database (`make -pq TARGETS`): every built file made from a
   C source of the tree has among its prerequisites every header of the
   tree that the source includes, directly or through other headers, found
   here with a regular expression over the sources, not taken from the
   compiler's lists.
3. As a user would see it: for one header per directory that some built
   source includes, `make -q -W HEADER` (HEADER taken as changed) is no
   longer up to date; for lib/fields_internal.h, `make -n -W` rebuilds the
   objects of the codec.

usage: check-deps.py RESULTS BUILD_DIR TARGET...   (MAKE from the
environment; one "passed failed label" line goes to RESULTS)
"""
import os
import re
import subprocess
import sys

LABEL = "build: every header is a prerequisite of what includes it"
TOP = os.getcwd()
# Directories a quoted or angled include is looked up in, besides the
# including file's own (the -I options of the rules).
SEARCH = [".", "lib/include", "lib", "gateway", "sim", "cli", "tests", "tests/gpio",
          "tests/firmware", "port/lwip", "fuzz", "bench"]
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]', re.M)
COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)


def make(*args):
    cmd = os.environ.get("MAKE", "make").split() + ["--no-print-directory"] + list(args)
    env = dict(os.environ, LC_ALL="C")
    env.pop("MAKEFLAGS", None)  # no -n/-q/-j of the calling make
    env.pop("MFLAGS", None)
    return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, env=env)


def tree_file(path):
    """path as a file of the tree (relative), or None."""
    p = os.path.normpath(path)
    if p.startswith("..") or os.path.isabs(p) or not os.path.isfile(p):
        return None
    return p


_includes = {}


def includes(src):
    """The tree files that src names in #include: each entry a tuple of the
    candidates (a name may exist in several search directories: any one of
    them as a prerequisite is enough)."""
    if src not in _includes:
        try:
            with open(src, errors="replace") as f:
                text = COMMENT.sub("", f.read())
        except OSError:
            text = ""
        out = []
        for name in INCLUDE.findall(text):
            own = tree_file(os.path.join(os.path.dirname(src), name))
            if own:
                out.append((own,))
                continue
            cands = tuple(sorted({p for p in (tree_file(os.path.join(d, name))
                                              for d in SEARCH) if p}))
            if cands:
                out.append(cands)
        _includes[src] = out
    return _includes[src]


def missing(src, prereqs):
    """Headers src reaches that are not among prereqs (a set)."""
    lost, seen, todo = [], set(), [src]
    while todo:
        f = todo.pop()
        for cands in includes(f):
            hit = [c for c in cands if c in prereqs]
            if not hit:
                if cands not in seen:
                    lost.append(" or ".join(cands))
                    seen.add(cands)
                continue
            for h in hit:
                if h not in seen:
                    seen.add(h)
                    todo.append(h)
    return lost


def stale(target, prereqs):
    """The target is older than one of its prerequisites: make rebuilds it
    (and writes its list again) before anything uses it."""
    t = os.path.getmtime(target)
    return any(os.path.exists(p) and os.path.getmtime(p) > t for p in prereqs)


def database(targets):
    """({target: set of prerequisites}, set of the targets that have a
    recipe) from make -pq."""
    out = make("-pq", *targets).stdout
    db, files = {}, False
    not_target = False
    recipe, last = set(), []
    for line in out.splitlines():
        if files and line.startswith("\t"):
            recipe.update(last)
            continue
        if line.startswith("# Files"):
            files = True
            continue
        if line.startswith("# files hash-table stats") or line.startswith("# VPATH"):
            files = False
        if not files:
            continue
        if line.startswith("# Not a target"):
            not_target = True
            continue
        if not line or line.startswith("#"):
            if not line:
                not_target = False
                last = []
            continue
        m = re.match(r"^([^:=\s][^:=]*?):{1,2}(?!=)\s*(.*)$", line)
        if not m or not_target:
            continue
        # the compiler writes a header as it found it ("fuzz/../cli/x.h"):
        # the same file for make, which stats the name as written
        deps = [os.path.normpath(d) for d in m.group(2).split("|")[0].split()]
        last = m.group(1).split()
        for t in last:
            db.setdefault(t, set()).update(deps)
    return db, recipe


def main():
    results, build, targets = sys.argv[1], sys.argv[2].rstrip("/"), sys.argv[3:]
    problems = []

    q = make("-q", *targets)
    if q.returncode != 0:
        again = make("-n", *targets).stdout.strip().splitlines()
        problems.append("make -q: not up to date right after building; make would run:\n    "
                        + "\n    ".join(again[:10]))

    db, recipe = database(targets)
    checked = 0
    user = {}  # header -> a built file that includes it
    for target, prereqs in sorted(db.items()):
        # built files of this build only: the lists of the builds nested in
        # it ($(B)/asan, ...) name files that no rule of this one makes,
        # and may be older than the sources until that build runs again
        if not target.startswith(build + "/") or not os.path.exists(target) \
                or target not in recipe or stale(target, prereqs):
            continue
        srcs = [p for p in prereqs if p.endswith(".c") and tree_file(p)]
        for src in srcs:
            checked += 1
            for h in missing(src, prereqs):
                problems.append("%s: make does not know that %s includes %s"
                                % (target, src, h))
            for cands in includes(src):
                for h in cands:
                    user.setdefault(h, target)
    if checked == 0:
        problems.append("no built file made from a C source found in make's database")

    sample = {}
    for h in sorted(user):
        if not h.endswith(".c"):
            sample.setdefault(os.path.dirname(h), h)
    for h in sorted(sample.values()):
        if make("-q", "-W", h, user[h]).returncode == 0:
            problems.append("make -q -W %s %s: still up to date, as if %s did not include it"
                            % (h, user[h], user[h]))
    codec = make("-n", "-W", "lib/fields_internal.h", *targets).stdout
    if not re.search(r"-c lib/codec\.c -o \S*lib/codec\.o", codec):
        problems.append("make -n -W lib/fields_internal.h does not rebuild lib/codec.o")

    for p in problems:
        print("check-deps: " + p)
    ok = not problems
    print("check-deps: %d files made from C sources checked, %d headers touched: %s"
          % (checked, len(sample) + 1, "ok" if ok else "%d problem(s)" % len(problems)))
    os.makedirs(os.path.dirname(os.path.abspath(results)), exist_ok=True)
    with open(results, "a") as f:
        f.write("%d %d %s\n" % (ok, not ok, LABEL))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
