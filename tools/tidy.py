#!/usr/bin/env python3
"""Run clang-tidy (checks in .clang-tidy) over drape's own translation units.

  tools/tidy.py [--build DIR] [-j N] [FILE ...]   every source of DIR's compile database
                                                  (default build/), or the named ones

Exit 1 if clang-tidy reports anything (every enabled check is an error). A build must
exist: the compile commands come from DIR/compile_commands.json and the headers each
source includes from Ninja's dependency log (`ninja -t deps`), so run it after a build.

A translation unit found clean is remembered (DRAPE_TIDY_CACHE, default
~/.cache/drape-tidy) under a hash of everything its result depends on: clang-tidy's
version, .clang-tidy, the compile command (checkout path left out, so checkouts share
it) and the contents of the source and of every header it includes. A source is run
again only when one of those changed; one that reported something is never remembered.
Without a dependency log for a source (not built yet) it is always run.
"""
import argparse
import concurrent.futures
import hashlib
import json
import os
import re
import shlex
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCE_DIRS = ("common", "garments", "generator", "runtime", "cli", "python", "fuzz", "tests", "bench")
CLANG_TIDY = os.environ.get("DRAPE_CLANG_TIDY", "clang-tidy-14")
# Findings in drape's own headers count, anchored at this checkout (a third-party path
# such as /usr/include/pcl/common/ must not match).
HEADER_FILTER = "^" + re.escape(ROOT) + "/(" + "|".join(SOURCE_DIRS) + ")/"
# clang parses gcc's command lines: these gcc flags it does not know or does not use
# would otherwise be reported as errors (the commands carry -Werror).
EXTRA_ARGS = ["-Wno-unknown-warning-option", "-Wno-ignored-optimization-argument", "-Wno-unused-command-line-argument"]


def project_sources(database):
    """Compile-database entries for drape's own sources (not generated files)."""
    entries = []
    for e in database:
        path = os.path.normpath(os.path.join(e["directory"], e["file"]))
        rel = os.path.relpath(path, ROOT)
        if rel.split(os.sep)[0] in SOURCE_DIRS:
            entries.append((rel, e))
    return sorted(entries, key=lambda x: x[0])


def ninja_deps(build_dir):
    """{object path relative to build_dir: [header paths]} from Ninja's dependency log."""
    out = subprocess.run(["ninja", "-C", build_dir, "-t", "deps"], capture_output=True, text=True, check=True).stdout
    deps, current = {}, None
    for line in out.splitlines():
        if not line.strip():
            current = None
        elif not line.startswith(" "):
            # "common/CMakeFiles/x.dir/y.cpp.o: #deps 123, deps mtime ... (VALID)"
            obj, _, status = line.partition(": #deps")
            current = obj if "VALID" in status and "STALE" not in status else None
            if current is not None:
                deps[current] = []
        elif current is not None:
            deps[current].append(line.strip())
    return deps


class Hasher:
    def __init__(self):
        self.memo = {}

    def file(self, path):
        if path not in self.memo:
            h = hashlib.sha256()
            try:
                with open(path, "rb") as f:
                    h.update(f.read())
            except OSError:
                h.update(b"missing")
            self.memo[path] = h.hexdigest()
        return self.memo[path]


def cache_key(hasher, base, entry, headers):
    """Hash of what a clean result depends on, or None if the headers are unknown."""
    if headers is None:
        return None
    h = hashlib.sha256(base)
    # The checkout's absolute path is left out, so that another clone of the same
    # commit finds the result (the files' contents are hashed instead).
    h.update(entry["command"].replace(ROOT, "<root>").encode())
    directory = entry["directory"]
    for path in [entry["file"]] + headers:
        full = os.path.normpath(os.path.join(directory, path))
        h.update(os.path.relpath(full, ROOT).encode() if full.startswith(ROOT + os.sep) else full.encode())
        h.update(hasher.file(full).encode())
    return h.hexdigest()


def object_of(entry):
    args = shlex.split(entry["command"])
    return args[args.index("-o") + 1] if "-o" in args else None


def run_tidy(build_dir, rel):
    t = time.time()
    proc = subprocess.run(
        [CLANG_TIDY, "-p", build_dir, "--quiet", "--header-filter=" + HEADER_FILTER]
        + ["--extra-arg=" + a for a in EXTRA_ARGS]
        + [os.path.join(ROOT, rel)],
        capture_output=True,
        text=True,
    )
    # clang-tidy prints "N warnings generated." and suppressed counts on stderr.
    return proc.returncode, proc.stdout.strip(), time.time() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("-j", "--jobs", type=int, default=os.cpu_count())
    ap.add_argument("files", nargs="*")
    args = ap.parse_args()

    build_dir = os.path.abspath(args.build)
    db_path = os.path.join(build_dir, "compile_commands.json")
    if not os.path.exists(db_path):
        sys.exit(f"tidy: {db_path} not found: build first (./setup.sh build)")
    with open(db_path) as f:
        entries = project_sources(json.load(f))
    if args.files:
        wanted = {os.path.relpath(os.path.abspath(p), ROOT) for p in args.files}
        entries = [(rel, e) for rel, e in entries if rel in wanted]
        missing = wanted - {rel for rel, _ in entries}
        if missing:
            sys.exit(f"tidy: not in {db_path}: {', '.join(sorted(missing))}")

    cache_dir = os.environ.get("DRAPE_TIDY_CACHE", os.path.expanduser("~/.cache/drape-tidy"))
    os.makedirs(cache_dir, exist_ok=True)
    version = subprocess.run([CLANG_TIDY, "--version"], capture_output=True, text=True, check=True).stdout
    with open(os.path.join(ROOT, ".clang-tidy"), "rb") as f:
        base = version.encode() + f.read() + " ".join(EXTRA_ARGS).encode()
    deps = ninja_deps(build_dir)
    hasher = Hasher()

    todo = []
    for rel, e in entries:
        key = cache_key(hasher, base, e, deps.get(object_of(e)))
        if key is None or not os.path.exists(os.path.join(cache_dir, key)):
            todo.append((rel, key))
    print(f"tidy: {len(entries)} sources, {len(entries) - len(todo)} unchanged since a clean run, {len(todo)} to check")

    failed = []
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(run_tidy, build_dir, rel): (rel, key) for rel, key in todo}
        for fut in concurrent.futures.as_completed(futures):
            rel, key = futures[fut]
            rc, out, seconds = fut.result()
            if rc != 0 or out:
                failed.append(rel)
                print(f"tidy: {rel}: findings ({seconds:.0f} s)\n{out}\n", flush=True)
            elif key is not None:
                open(os.path.join(cache_dir, key), "w").close()
    if failed:
        print(f"tidy: {len(failed)} of {len(entries)} sources have findings: {' '.join(sorted(failed))}")
        return 1
    print(f"tidy: clean ({len(entries)} sources)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
