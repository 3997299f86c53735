#!/usr/bin/env python3
"""cputime.py: runs a command and reports the CPU time it used.

Usage: python3 bench/cputime.py COMMAND [ARG...]

Prints the command's standard output, then one line
"CPUTIME cpu_seconds=U+S wall_seconds=W", and exits with its status.
CPU time (all threads, user + system) is what other processes competing
for the cores do not inflate; bench/run.sh uses it for its estimates.
"""
import os
import subprocess
import sys
import time


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    before = os.times()
    t0 = time.perf_counter()
    rc = subprocess.call(sys.argv[1:])
    wall = time.perf_counter() - t0
    after = os.times()
    cpu = (after.children_user - before.children_user) + \
          (after.children_system - before.children_system)
    sys.stdout.flush()
    print('CPUTIME cpu_seconds=%.3f wall_seconds=%.3f' % (cpu, wall))
    sys.exit(rc)


if __name__ == '__main__':
    main()
