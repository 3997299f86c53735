#!/usr/bin/env python3
"""`make check-size`: no C file over 700 lines, no function over 150.

Owned by the build (Makefile, tests/all.sh's test-tree step).  Reads the
C files of lib/, service/, tools/, tests/, fuzz/ and bench/ (not the
generated lib/optics/glass_table.h).  A function is found the way
.clang-format lays it out: its opening brace alone on a line at column 0,
its closing brace at column 0; its length is the lines from one to the
other, and its name is the identifier before the first "(" of the lines
above the brace.  A file or function over its limit fails unless
tools/size-allow.txt lists it ("FILE reason" or "FILE:FUNCTION reason");
a listed one that is now within its limit (or gone) fails too, so the
list can only shrink.  Exit status 0 when clean.

    python3 tools/check-size.py [REPO_ROOT]
"""
import os
import re
import sys

import allow_list

FILE_MAX = 700
FUNC_MAX = 150
DIRS = ["lib", "service", "tools", "tests", "fuzz", "bench"]
SKIP = {"lib/optics/glass_table.h"}
ALLOW = "tools/size-allow.txt"
NAME = re.compile(r"([A-Za-z_][A-Za-z_0-9]*)\s*\(")
COMMENT = re.compile(r"/\*.*?\*/")
ATTR = re.compile(r"__attribute__\s*\(\(.*?\)\)")


def sources(root):
    for top in DIRS:
        for d, _, files in sorted(os.walk(os.path.join(root, top))):
            for f in sorted(files):
                p = os.path.relpath(os.path.join(d, f), root)
                if f.endswith((".c", ".h")) and p not in SKIP:
                    yield p


def functions(lines):
    """(name, first line, length) of each function body in lines."""
    out = []
    start = None
    for i, line in enumerate(lines):
        if start is None and line.rstrip() == "{":
            # The signature: the lines above, back to a blank line, a
            # comment's end or a preprocessor line.
            sig = []
            j = i - 1
            while j >= 0 and lines[j].strip() and not lines[j].startswith(
                    ("#", " *", "/*")):
                sig.insert(0, lines[j])
                j -= 1
            m = NAME.search(ATTR.sub("", COMMENT.sub("", " ".join(sig))))
            start = (m.group(1) if m else f"line{i + 1}", i)
        elif start is not None and line.startswith("}"):
            out.append((start[0], start[1] + 1, i - start[1] + 1))
            start = None
    return out


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    errors = []
    allowed = allow_list.read(root, ALLOW, 1, "FILE[:FUNCTION]", errors)

    seen = set()
    files = 0
    for p in sources(root):
        files += 1
        with open(os.path.join(root, p), errors="replace") as f:
            lines = f.read().split("\n")
        if lines and lines[-1] == "":
            lines.pop()
        if len(lines) > FILE_MAX:
            if (p,) in allowed:
                seen.add((p,))
            else:
                errors.append(f"{p}: {len(lines)} lines, over {FILE_MAX}")
        for name, first, length in functions(lines):
            if length <= FUNC_MAX:
                continue
            key = (f"{p}:{name}",)
            if key in allowed:
                seen.add(key)
            else:
                errors.append(f"{p}:{first}: {name} is {length} lines, over {FUNC_MAX}")
    allow_list.stale(allowed, seen, ALLOW, "is within its limit now (or gone)", errors)

    for e in errors:
        print(e)
    if errors:
        print(f"check-size: {len(errors)} problem(s) (limits: {FILE_MAX} lines a file, "
              f"{FUNC_MAX} a function)")
        return 1
    print(f"check-size: {files} files; none over {FILE_MAX} lines or with a function "
          f"over {FUNC_MAX} but the {len(seen)} listed in {ALLOW}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
