#!/usr/bin/env python3
"""checker-obj.py: writes the black squares of a checkerboard as an OBJ.

Usage: python3 tools/checker-obj.py COLS ROWS > scenes/meshes/checker.obj

Squares of side 1 in the plane z = 0, centred on the origin, the square
at the lower-left corner black; the white ones are left out (the scene's
backdrop shows through).  scenes/lens-chart.json uses it.
"""
import sys


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    cols, rows = int(sys.argv[1]), int(sys.argv[2])
    x0, y0 = -cols / 2, -rows / 2
    print('# %d x %d checkerboard, black squares only (tools/checker-obj.py)' % (cols, rows))
    n = 0
    for j in range(rows):
        for i in range(cols):
            if (i + j) % 2:
                continue
            x, y = x0 + i, y0 + j
            for vx, vy in ((x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)):
                print('v %g %g 0' % (vx, vy))
            print('f %d %d %d %d' % (n + 1, n + 2, n + 3, n + 4))
            n += 4


if __name__ == '__main__':
    main()
