#!/usr/bin/env python3
"""check_limit_vectors.py -- run `plotkin refine --limit --tangents --raw` on every
limit reference vector and compare with the exact answer.

    python3 tests/tools/check_limit_vectors.py build/plotkin tests/vectors/cases [more dirs]

Bounds (stated, and printed with the measured worst case):
  * position: |kernel - exact| <= 1 LSB (1 um) per coordinate. The kernel rounds
    once per level at 1/256 um and once to whole um on output, so the
    expected error is < 0.5 + (depth + 1)/256 LSB.
  * tangent: angle between the kernel's Q1.30 unit tangent and the exact (or
    12-digit decimal) direction <= 0.05 degrees; a zero exact tangent needs a
    zero kernel tangent. (The inputs are random with |v| <= 2^20, so the
    level polygons' spacing is large; on a polygon whose points are only a few
    LSB apart the kernel's 1/256-LSB rounding alone could tilt a tangent by
    more than 0.05 degrees.)
  * closed curves are compared up to a cyclic rotation (README).
Prints one line per failing case and ends with "N passed, N failed".
"""
import math
import os
import subprocess
import sys
from fractions import Fraction as Fr


def parse(path):
    hdr, inp, out = {}, [], []
    with open(path) as f:
        lines = [l.rstrip('\n') for l in f if l.strip()]
    i = 0
    while i < len(lines):
        k, _, v = lines[i].strip().partition(' ')
        if k == 'input':
            inp = [lines[i + 1 + j].split() for j in range(int(v))]
            i += 1 + int(v)
        elif k == 'output':
            out = [lines[i + 1 + j].split() for j in range(int(v))]
            i += 1 + int(v)
        else:
            hdr[k] = v.strip()
            i += 1
    return hdr, inp, out


def angle_deg(u, v):
    nu = math.sqrt(sum(a * a for a in u))
    nv = math.sqrt(sum(a * a for a in v))
    if nu == 0 or nv == 0:
        return 0.0 if nu == nv == 0 else 180.0
    u = [a / nu for a in u]
    v = [a / nv for a in v]
    dot = sum(a * b for a, b in zip(u, v))
    if len(u) == 2:
        cr = abs(u[0] * v[1] - u[1] * v[0])
    else:
        cr = math.sqrt((u[1] * v[2] - u[2] * v[1]) ** 2 + (u[2] * v[0] - u[0] * v[2]) ** 2 +
                       (u[0] * v[1] - u[1] * v[0]) ** 2)
    return math.degrees(math.atan2(cr, dot))


def compare(exp, got, dim, dec):
    """(ok, worst position error, worst angle) for aligned lists."""
    wp = wa = 0.0
    ok = True
    for e, g in zip(exp, got):
        pe = [Fr(x) for x in e[:dim]]
        pg = [int(x) for x in g[:dim]]
        err = max(float(abs(a - b)) for a, b in zip(pe, pg))
        wp = max(wp, err)
        if err > 1:
            ok = False
        te = [float(Fr(x)) if not dec else float(x) for x in e[dim:2 * dim]]
        tg = [int(x) / 2 ** 30 for x in g[dim:2 * dim]]
        an = angle_deg(te, tg)
        wa = max(wa, an)
        if an > 0.05:
            ok = False
    return ok, wp, wa


def run_case(plotkin, path):
    hdr, inp, out = parse(path)
    dim = int(hdr['dim'])
    args = [plotkin, 'refine', '--scheme', hdr['scheme'], '--depth', hdr['depth'], '--limit',
            '--tangents', '--raw']
    if hdr['closed'] == '1':
        args.append('--closed')
    elif hdr['scheme'] != 'dlg':
        args += ['--ends', hdr['ends']]
    stdin = ''.join(' '.join(p) + '\n' for p in inp)
    res = subprocess.run(args, input=stdin, capture_output=True, text=True)
    if res.returncode != 0:
        return False, 'exit %d: %s' % (res.returncode, res.stderr.strip()[:200]), 0, 0
    got = [l.split() for l in res.stdout.splitlines() if l.strip()]
    if len(got) != len(out):
        return False, '%d outputs, expected %d' % (len(got), len(out)), 0, 0
    if any(len(g) != 2 * dim for g in got):
        return False, 'expected %d numbers per line' % (2 * dim), 0, 0
    dec = hdr.get('tangent_decimal') == '1'
    rots = range(len(out)) if hdr['closed'] == '1' and out else [0]
    best = None
    for r in rots:
        g = got[r:] + got[:r]
        ok, wp, wa = compare(out, g, dim, dec)
        if ok:
            return True, '', wp, wa
        if best is None or wp + wa < best[0] + best[1]:
            best = (wp, wa)
    return False, 'worst position error %.3g LSB, tangent %.3g deg' % best, best[0], best[1]


def main():
    plotkin = sys.argv[1]
    dirs = sys.argv[2:]
    passed = failed = 0
    wp = wa = 0.0
    for d in dirs:
        if not os.path.isdir(d):
            continue
        for fn in sorted(os.listdir(d)):
            if not fn.startswith('limit_'):
                continue
            ok, msg, p, a = run_case(plotkin, os.path.join(d, fn))
            if ok:
                passed += 1
                wp, wa = max(wp, p), max(wa, a)
            else:
                failed += 1
                print('FAIL %s: %s' % (fn, msg))
    print('limit vectors through the kernel: worst position error %.3g LSB (bound 1), '
          'worst tangent error %.3g deg (bound 0.05)' % (wp, wa))
    print('%d passed, %d failed' % (passed, failed))
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
