"""The allow-lists of tools/check-layers.py and tools/check-size.py.

Owned by those two checks.  An allow-list is a text file of lines "KEY...
reason" ('#' starts a comment line); a line whose KEY the check no longer
meets is an error, so a list can only shrink.
"""
import os


def read(root, path, nkeys, form, errors):
    """{tuple of the first nkeys words: line number}; bad lines to errors."""
    allowed = {}
    with open(os.path.join(root, path)) as f:
        for n, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            parts = line.split(None, nkeys)
            if len(parts) <= nkeys:
                errors.append(f"{path}:{n}: want '{form} reason'")
                continue
            allowed[tuple(parts[:nkeys])] = n
    return allowed


def stale(allowed, seen, path, why, errors):
    """An error for each listed key not in seen: "PATH:LINE: KEY WHY"."""
    for key, n in sorted(allowed.items(), key=lambda kv: kv[1]):
        if key not in seen:
            errors.append(f"{path}:{n}: {' '.join(key)} {why}: delete the line")
