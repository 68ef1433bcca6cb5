#!/usr/bin/env python3
"""List C++ function definitions by length; check the house rule on long ones.

  tools/function_lengths.py [--over N] [FILE|DIR ...]   functions over N lines (default 80)
  tools/function_lengths.py --check                     exit 1 if one has no reason

Length is clang-tidy's (readability-function-size, LineThreshold): the line of the
closing brace minus the line of the opening brace. The house rule: no function over 80
lines unless the comment right above it has a line starting `// Long because:` saying
why. tools/function_lengths_pending.txt names the few that another change is rewriting;
--check lists them but does not fail on them.

A scanner, not a compiler: comments, strings and preprocessor lines are blanked, then
each `{` outside a function is classified by the text before it (namespace, class,
initializer, or a function: the text ends with `)` and qualifiers, or a constructor's
initializer list). Everything inside a function (lambdas, local classes) counts toward
it. On the tree it gave the same functions, lines and lengths as clang-tidy's check.
With no paths it reads the C++ files git tracks under the source folders (tests and
benchmarks included).
"""
import argparse
import bisect
import os
import re
import subprocess
import sys

SOURCE_DIRS = ["common", "garments", "generator", "runtime", "cli", "python", "fuzz", "tests"]
EXTENSIONS = (".cpp", ".cc", ".h", ".hpp")
REASON = "// Long because:"
QUALIFIERS = {"const", "noexcept", "override", "final", "mutable", "try", "volatile"}


def blank(text):
    """The text with comments, string/char literals and preprocessor lines replaced by
    spaces (newlines kept, so positions and line numbers stay)."""
    out = list(text)
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c in " \t":
            i += 1
            continue
        if line_start and c == "#":  # preprocessor line, with its continuations
            j = i
            while j < n and text[j] != "\n":
                if text[j] == "\\" and j + 1 < n and text[j + 1] == "\n":
                    j += 2
                    continue
                if text.startswith("/*", j):  # a block comment inside it
                    k = text.find("*/", j + 2)
                    j = n if k < 0 else k + 2
                    continue
                j += 1
            for k in range(i, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j
            continue
        line_start = c == "\n"
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            for k in range(i, j):
                out[k] = " "
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            for k in range(i, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^()\\ ]{0,16})\(', text[i:])
            if not m:
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i + m.end())
            j = n if end < 0 else end + len(m.group(1)) + 2
            for k in range(i + 1, j):
                if out[k] != "\n":
                    out[k] = " "
            out[i] = '"'
            out[j - 1] = '"'
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            for k in range(i + 1, min(j, n)):
                out[k] = " "
            i = j + 1
        else:
            i += 1
    return "".join(out)


def top_level(header):
    """The header with everything inside (), [] and {} removed."""
    depth, out = 0, []
    for ch in header:
        if ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth = max(0, depth - 1)
        elif depth == 0:
            out.append(ch)
    return "".join(out)


def strip_template_prefix(h):
    h = h.lstrip()
    while h.startswith("template"):
        # skip template < ... > (angle brackets balanced)
        i = h.find("<")
        if i < 0:
            return h
        depth = 0
        for j in range(i, len(h)):
            if h[j] == "<":
                depth += 1
            elif h[j] == ">":
                depth -= 1
                if depth == 0:
                    h = h[j + 1 :].lstrip()
                    break
        else:
            return h
    return h


def strip_trailing_qualifiers(h):
    """The header without trailing noexcept(...), const, override, -> T, & and &&."""
    h = h.rstrip()
    while True:
        before = h
        m = re.search(r"noexcept\s*\([^()]*\)$", h)
        if m:
            h = h[: m.start()].rstrip()
        m = re.search(r"->\s*[\w:<>,\s*&]+$", h)
        if m:
            h = h[: m.start()].rstrip()
        m = re.search(r"(\w+)$", h)
        if m and m.group(1) in QUALIFIERS:
            h = h[: m.start()].rstrip()
        h = re.sub(r"&&?$", "", h).rstrip()
        if h == before:
            return h


def classify(header):
    """What a `{` opens, from the text before it back to the last `;`, `{` or `}`:
    'namespace', 'class', 'function', 'init' (a brace in a constructor's initializer
    list: the header goes on after it) or 'other'."""
    h = strip_template_prefix(header)
    if re.match(r"(inline\s+)?namespace\b", h) or re.match(r"extern\s*\"", h):
        return "namespace"
    flat = top_level(h)
    if re.search(r"\boperator\b", flat):
        return "function" if not re.search(r"=\s*$", flat) else "other"
    if re.match(r"(class|struct|union|enum)\b", h):
        return "class"
    if "=" in flat.replace("==", "").replace("!=", "").replace("<=", "").replace(">=", ""):
        return "other"
    s = strip_trailing_qualifiers(h)
    if s.endswith(")"):
        return "function"
    # Constructor initializer list: `) : a_(x), b_` then `{`.
    if re.search(r"\)\s*:[^:]", h) and re.search(r"[\w>]$", s):
        return "init"
    return "other"


def function_name(header):
    h = strip_template_prefix(header).strip()
    h = re.sub(r"__attribute__\s*\(\([^()]*(\([^()]*\)[^()]*)*\)\)|\[\[[^\]]*\]\]", " ", h).strip()
    m = re.search(r"(operator\s*(\(\)|[^\s(]+)|[~\w:]+)\s*\(", h)
    if m:
        name = m.group(1)
        # A macro like TEST(Suite, Name): keep the arguments.
        if re.fullmatch(r"[A-Z][A-Z_0-9]+", name):
            close = h.find(")", m.end())
            return re.sub(r"\s+", " ", h[m.start(1) : close + 1])
        return name
    return re.sub(r"\s+", " ", h)[:60]


def functions(path, text=None):
    """(name, first line of the signature, body lines, has reason) per function."""
    if text is None:
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
    lines = text.split("\n")
    b = blank(text)
    newline_positions = [i for i, ch in enumerate(b) if ch == "\n"]

    def line(pos):  # 1-based line of an offset
        return bisect.bisect_left(newline_positions, pos) + 1

    results = []
    stack = []  # (kind, open position, header start position)
    header_start = 0
    in_function = 0
    pending_init = None  # header start of a constructor whose init list holds braces
    i = 0
    n = len(b)
    while i < n:
        c = b[i]
        if c == "{":
            if in_function:
                stack.append(("inner", i, None))
                in_function += 1
            else:
                start = pending_init if pending_init is not None else header_start
                kind = classify(b[start:i])
                if kind == "init":
                    pending_init = start
                elif kind == "function":
                    pending_init = None
                    in_function = 1
                else:
                    pending_init = None
                stack.append((kind, i, start))
            header_start = i + 1
        elif c == "}":
            if not stack:
                i += 1
                header_start = i
                continue
            kind, open_pos, start = stack.pop()
            if kind == "inner":
                in_function -= 1
            elif kind == "function":
                in_function = 0
                sig = start
                while sig < open_pos and b[sig].isspace():
                    sig += 1
                first = line(sig)
                # The contiguous // comment block right above the signature.
                k = first - 2
                comment = []
                while k >= 0 and lines[k].strip().startswith("//"):
                    comment.append(lines[k].strip())
                    k -= 1
                has_reason = any(l.startswith(REASON) for l in comment)
                results.append((function_name(b[start:open_pos]), first, line(i) - line(open_pos), has_reason))
            header_start = i + 1
            if kind != "init":  # after an initializer-list brace the header goes on: `a_{x}, b_(y) {`
                pending_init = None
        elif c == ";" and not in_function:
            header_start = i + 1
            pending_init = None
        i += 1
    return results


def tracked_files(root):
    try:
        out = subprocess.run(
            ["git", "-C", root, "ls-files", "--"] + SOURCE_DIRS, capture_output=True, text=True, check=True
        ).stdout
        files = [os.path.join(root, f) for f in out.split("\n") if f.endswith(EXTENSIONS)]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d in SOURCE_DIRS:
            for dirpath, _, names in os.walk(os.path.join(root, d)):
                files += [os.path.join(dirpath, f) for f in names if f.endswith(EXTENSIONS)]
    return sorted(files)


def expand(paths):
    files = []
    for p in paths:
        if os.path.isdir(p):
            for dirpath, _, names in os.walk(p):
                files += [os.path.join(dirpath, f) for f in names if f.endswith(EXTENSIONS)]
        else:
            files.append(p)
    return sorted(files)


def read_pending(path):
    """(file, name) pairs from the pending list: `PATH NAME  # why` per line."""
    pending = set()
    if not os.path.exists(path):
        return pending
    with open(path, encoding="utf-8") as f:
        for raw in f:
            line = raw.split("#", 1)[0].strip()
            if line:
                file, name = line.split(None, 1)
                pending.add((file, name.strip()))
    return pending


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("paths", nargs="*")
    ap.add_argument("--over", type=int, default=80, help="list functions longer than this (lines)")
    ap.add_argument("--check", action="store_true", help="fail if a function over --over has no reason")
    ap.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    args = ap.parse_args()
    root = os.path.normpath(args.root)
    pending = read_pending(os.path.join(root, "tools", "function_lengths_pending.txt"))
    files = expand(args.paths) if args.paths else tracked_files(root)
    rows = []
    for f in files:
        for name, first, length, has_reason in functions(f):
            if length > args.over:
                rows.append((length, os.path.relpath(f, root), first, name, has_reason))
    rows.sort(key=lambda r: (-r[0], r[1], r[2]))
    bad = []
    for length, f, first, name, has_reason in rows:
        state = "" if has_reason else "  (pending: see function_lengths_pending.txt)" if (f, name) in pending else "  (no reason)"
        if not has_reason and (f, name) not in pending:
            bad.append(name)
        if not (args.check and has_reason):
            print(f"{length:5d}  {f}:{first}  {name}{state}")
    found = {(r[1], r[3]) for r in rows}
    if args.check and not args.paths:
        for f, name in sorted(pending - found):
            print(f"note: {f} {name} is no longer over {args.over} lines: remove it from function_lengths_pending.txt")
    print(f"{len(rows)} functions over {args.over} lines in {len(files)} files; {len(bad)} without a "
          f"'{REASON}' line above them or a pending entry")
    if args.check and bad:
        print(f"error: split each at its steps into named functions, or write why it is long in a line "
              f"starting '{REASON}' right above it")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
