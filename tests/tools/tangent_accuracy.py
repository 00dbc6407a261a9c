#!/usr/bin/env python3
"""tangent_accuracy.py -- measure the kernel's --tangents error against the exact
limit tangent as the points get denser (a table, not a pass/fail test).

    python3 tests/tools/tangent_accuracy.py [build/plotkin]

Input: a closed 40-gon on a circle, integer micrometres, edge length = the
"input spacing"; scheme bspline:3 (closed). The exact reference is the
derivative of the uniform cubic B-spline of the exactly refined level polygon
(tests/tools/derive_masks.py), so the error shown is the kernel's fixed-point
rounding only: the masks themselves are exact. The kernel before issue 14 rounded
every level to 1/256 um and took tangents over the last level's tiny edges, so
the error grew as the level-K spacing approached that resolution (1.4 deg at
2 um, depth 5); it now takes them from exact level values and only rounds the
unit vector (Q30, 2^-30 rad = 5e-8 deg), so what is left is a few 1e-8 deg.
"""
import math
import os
import subprocess
import sys
from fractions import Fraction as Fr

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from derive_masks import Rule, ref_limit, refine_pts  # noqa: E402


def worst_error(plotkin, spacing_um, depth, npts=40):
    R = spacing_um * npts / (2 * math.pi)
    P = [(round(R * math.cos(2 * math.pi * i / npts)), round(R * math.sin(2 * math.pi * i / npts)))
         for i in range(npts)]
    r = Rule('bspline', 3, True, None)
    L = refine_pts([tuple(Fr(v) for v in p) for p in P], 'bspline', 3, True, None, depth)
    ref = ref_limit(r, L)
    args = [plotkin, 'refine', '--scheme', 'bspline:3', '--depth', str(depth), '--closed', '--limit',
            '--tangents', '--raw']
    out = subprocess.run(args, input=''.join('%d %d\n' % p for p in P), capture_output=True, text=True).stdout
    got = [l.split() for l in out.splitlines() if l.strip()]
    best, berr = None, None
    for rot in range(len(got)):          # closed: align by position
        g = got[rot:] + got[:rot]
        err = sum(abs(float(e[0][k]) - int(x[k])) for e, x in zip(ref, g) for k in (0, 1))
        if berr is None or err < berr:
            best, berr = g, err
    worst = 0.0
    for e, x in zip(ref, best):
        te = [float(v) for v in e[1]]
        tg = [int(x[2]) / 2 ** 30, int(x[3]) / 2 ** 30]
        c = (te[0] * tg[1] - te[1] * tg[0]) / math.hypot(*te) / math.hypot(*tg)
        worst = max(worst, abs(math.degrees(math.asin(max(-1.0, min(1.0, c))))))
    return worst


def main():
    plotkin = sys.argv[1] if len(sys.argv) > 1 else 'build/plotkin'
    print('closed bspline:3, 40-gon; worst |angle(kernel tangent, exact tangent)| in degrees')
    print('%14s %11s %11s %11s' % ('input spacing', 'depth 0', 'depth 3', 'depth 5'))
    for sp in (1000, 100, 20, 5, 2):
        print('%11d um %11.2e %11.2e %11.2e' % ((sp,) + tuple(worst_error(plotkin, sp, d) for d in (0, 3, 5))))


if __name__ == '__main__':
    main()
