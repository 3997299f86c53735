#!/usr/bin/env python3
"""`make check-layers`: lib/'s folders include one way, lower never upper.

Owned by the build (Makefile, tests/all.sh's test-tree step).  Reads every
`#include "PATH"` in lib/, service/ and tools/.  lib/ is the include root,
so a lib/ header is named by its path under lib/ ("camera/camera.h") and
the first folder of PATH is its layer; a lib/ header named by its bare
file name fails, so the layer is always visible.  The layers, lowest first:

    util < json < sampling < image < optics < camera < scene < accel
         < integrator < render < clients (service/, tools/)

A file may include its own layer and any lower one; the clients include
no lib/ header at all, only include/lensray.h and their own.  An include of a
higher layer fails unless tools/layers-allow.txt lists it ("FILE HEADER
reason"); a listed include that is no longer there (or no longer upward)
fails too, so the list can only shrink.  Exit status 0 when clean.

    python3 tools/check-layers.py [REPO_ROOT]
"""
import os
import re
import sys

import allow_list

LAYERS = ["util", "json", "sampling", "image", "optics", "camera", "scene",
          "accel", "integrator", "render", "clients"]
CLIENT_DIRS = ["service", "tools"]
ALLOW = "tools/layers-allow.txt"
INCLUDE = re.compile(r'\s*#\s*include\s+"([^"]+)"')


def sources(root, top):
    for d, _, files in sorted(os.walk(os.path.join(root, top))):
        for f in sorted(files):
            if f.endswith((".c", ".h")):
                yield os.path.relpath(os.path.join(d, f), root)


def layer_of(path):
    parts = path.split("/")
    return parts[1] if parts[0] == "lib" else "clients"


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    errors = []
    headers = {}  # "camera/camera.h" -> "lib/camera/camera.h"
    bare = {}     # "camera.h" -> "camera/camera.h"
    for p in sources(root, "lib"):
        if p.endswith(".h"):
            headers[p[len("lib/"):]] = p
            bare.setdefault(os.path.basename(p), p[len("lib/"):])
    for p in headers.values():
        if layer_of(p) not in LAYERS:
            errors.append(f"{p}: folder is not a layer (tools/check-layers.py LAYERS)")

    allowed = allow_list.read(root, ALLOW, 2, "FILE HEADER", errors)

    files = list(sources(root, "lib"))
    for top in CLIENT_DIRS:
        files += sources(root, top)
    seen = set()
    for p in files:
        rank = LAYERS.index(layer_of(p)) if layer_of(p) in LAYERS else None
        with open(os.path.join(root, p), errors="replace") as f:
            for n, line in enumerate(f, 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                name = m.group(1)
                target = headers.get(name)
                here = os.path.join(os.path.dirname(p), name)
                own = not p.startswith("lib/") and os.path.exists(
                    os.path.join(root, here))  # a client's own header
                if target is None and name in bare and not own:
                    errors.append(f"{p}:{n}: include \"{bare[name]}\", "
                                  f"not \"{name}\": the path shows the layer")
                    continue
                if target is None or rank is None:
                    continue  # lensray.h, or a client's own header
                up = LAYERS.index(layer_of(target))
                if up <= rank and LAYERS[rank] != "clients":
                    continue
                if (p, name) in allowed:
                    seen.add((p, name))
                    continue
                if LAYERS[rank] == "clients":
                    errors.append(f"{p}:{n}: a client includes {name}: "
                                  "service/ and tools/ call only lensray.h")
                else:
                    errors.append(f"{p}:{n}: {LAYERS[rank]} includes {name}, "
                                  f"of the higher layer {layer_of(target)}")
    allow_list.stale(allowed, seen, ALLOW, "is no longer an upward include", errors)

    for e in errors:
        print(e)
    if errors:
        print(f"check-layers: {len(errors)} problem(s); the layers, lowest first: "
              + " < ".join(LAYERS))
        return 1
    print(f"check-layers: {len(files)} files include downward "
          f"({len(seen)} upward includes allowed by {ALLOW})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
