#!/usr/bin/env python3
"""`make check-style`: two habits .clang-format cannot see (issue 28).

Owned by the build (Makefile's test-tree).  Fails on, in every C file of
lib/, service/, tools/, tests/, fuzz/ and bench/:

  * an assignment inside the condition of an `if` or `while`
    (`if ((p = malloc(n)) == NULL)`, `else if (!(ok = f()))`): assign on
    its own line, then test.  GCC's -Wparentheses already refuses the
    bare `if (x = y)`; this finds the parenthesised form it lets through.
  * atoi, atol and atoll, which cannot report a bad number: use strtol
    and check its end pointer (or, for a number already known good,
    strtol(s, NULL, 10)).

    python3 tools/check-style.py [REPO_ROOT]
"""
import os
import re
import sys

DIRS = ["lib", "service", "tools", "tests", "fuzz", "bench"]
COND = re.compile(r"^\s*(?:\}\s*)?(?:else\s+)?(?:if|while)\s*\((.*)$")
# An opening parenthesis, then an lvalue, then `=` that is not `==`.
ASSIGN = re.compile(r"\(\s*[*&]?[A-Za-z_][\w.\->\[\]]*\s*=(?!=)")
ATOI = re.compile(r"\bato(?:i|l|ll)\s*\(")


def condition(lines, i):
    """The text of the condition that starts on line i: up to the
    parenthesis that closes it (it may span lines)."""
    m = COND.match(lines[i])
    text, depth, out = m.group(1), 1, []
    j = i
    while True:
        for ch in text:
            if ch == "(":
                depth += 1
            elif ch == ")":
                depth -= 1
                if depth == 0:
                    return "(" + "".join(out) + ")"
            out.append(ch)
        j += 1
        if j >= len(lines) or j > i + 8:
            return "(" + "".join(out) + ")"
        text = lines[j]


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    errors, n = [], 0
    for top in DIRS:
        for d, _, files in sorted(os.walk(os.path.join(root, top))):
            for f in sorted(files):
                if not f.endswith((".c", ".h")):
                    continue
                p = os.path.join(d, f)
                n += 1
                with open(p, errors="replace") as fh:
                    lines = fh.read().split("\n")
                rel = os.path.relpath(p, root)
                for i, line in enumerate(lines):
                    code = line.split("//")[0]
                    if ATOI.search(code) and not code.lstrip().startswith("*"):
                        errors.append(f"{rel}:{i + 1}: atoi/atol: use strtol")
                    if COND.match(code) and ASSIGN.search(condition(lines, i)):
                        errors.append(f"{rel}:{i + 1}: an assignment inside "
                                      "a condition: assign first, then test")
    for e in errors:
        print(e)
    if errors:
        print(f"check-style: {len(errors)} problem(s)")
        return 1
    print(f"check-style: {n} files, no assignment in a condition, no atoi")
    return 0


if __name__ == "__main__":
    sys.exit(main())
