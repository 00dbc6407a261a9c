#!/usr/bin/env python3
"""gen_vectors.py -- exact rational reference vectors for the refinement kernel.

Python 3 standard library only (fractions.Fraction). Written from the rules as
stated (tests/vectors/README.md, "Rules"), not from firmware/: nothing here
knows how the kernel rounds, windows or streams.

    python3 tests/tools/gen_vectors.py --write tests/vectors/generated [--seed S]
        write the generated corpus (deterministic: the same seed gives the
        same files, byte for byte); removes stale *.txt files there
    python3 tests/tools/gen_vectors.py --check tests/vectors/generated [--sample N]
        regenerate the corpus in memory and compare it byte for byte with
        the files there (every file, or every N-th one, always including the
        file list itself); exit 1 on any difference
    python3 tests/tools/gen_vectors.py --verify DIR [DIR ...]
        for every case file in DIR, recompute the output from its input and
        header and compare it exactly (closed curves up to a cyclic rotation,
        limit tangents by direction); prints the counts, exit 1 on a mismatch

Each run that checks something ends with "N passed, N failed".
"""
import argparse
import math
import os
import sys
from fractions import Fraction as Fr

PK_UM_MAX = (1 << 21) - 1   # firmware/pk_fixed.h: inputs are whole um, |v| <= PK_UM_MAX
DEFAULT_SEED = 20240611
MAX_DEPTH = 8


# ---------------------------------------------------------------- the rules

def avg(a, b):
    return tuple((x + y) / 2 for x, y in zip(a, b))


def lin(coefs, pts):
    """sum c_i * P_i for exact coefficients."""
    return tuple(sum(c * p[k] for c, p in zip(coefs, pts)) for k in range(len(pts[0])))


def lr_passes(P, D, closed):
    """Lane-Riesenfeld: double every point, then average each element with the
    next one D times (cyclically when closed; else each pass drops one)."""
    Q = [p for p in P for _ in (0, 1)]
    for _ in range(D):
        n = len(Q)
        if closed:
            Q = [avg(Q[i], Q[(i + 1) % n]) for i in range(n)]
        else:
            Q = [avg(Q[i], Q[i + 1]) for i in range(n - 1)]
    return Q


def clamped_level(P, D):
    """Midpoint knot insertion for the clamped (open-uniform) B-spline of
    degree d = min(D, m - 1) with control points P (Boehm's algorithm)."""
    m = len(P)
    d = min(D, m - 1)
    span = m - d                          # knot intervals 0..span
    t = [Fr(0)] * (d + 1) + [Fr(j) for j in range(1, span)] + [Fr(span)] * (d + 1)
    pts = list(P)
    for j in range(span):
        u = Fr(2 * j + 1, 2)
        k = max(i for i in range(len(t) - 1) if t[i] <= u < t[i + 1])
        new = []
        for i in range(len(pts) + 1):
            if i <= k - d:
                new.append(pts[i])
            elif i <= k:
                a = (u - t[i]) / (t[i + d] - t[i])
                new.append(lin((1 - a, a), (pts[i - 1], pts[i])))
            else:
                new.append(pts[i - 1])
        pts = new
        t = t[:k + 1] + [u] + t[k + 1:]
    return pts


def dlg_new(a, b, c, d):
    return lin((Fr(-1, 16), Fr(9, 16), Fr(9, 16), Fr(-1, 16)), (a, b, c, d))


def dlg_level(P, closed):
    m = len(P)
    out = []
    if closed:
        for i in range(m):
            out += [P[i], dlg_new(P[i - 1], P[i], P[(i + 1) % m], P[(i + 2) % m])]
        return out
    g = [lin((2, -1), (P[0], P[1]))] + list(P) + [lin((2, -1), (P[-1], P[-2]))]
    for i in range(m - 1):
        out += [P[i], dlg_new(g[i], g[i + 1], g[i + 2], g[i + 3])]
    return out + [P[-1]]


def refine_level(P, scheme, D, ends, closed):
    """One level. scheme 'bspline' (degree D) or 'dlg'."""
    m = len(P)
    if m <= 1 or (m == 2 and not closed):
        return list(P)
    if scheme == 'dlg':
        return dlg_level(P, closed)
    if closed:
        # listed centred: the first point's stencil starts floor((D-1)/2)
        # doubled points before P0 (D = 3: the vertex point of P0 first)
        Q = lr_passes(P, D, True)
        s = (D - 1) // 2
        return Q[len(Q) - s:] + Q[:len(Q) - s]
    if ends == 'clamped':
        return clamped_level(P, D)
    R = lr_passes(P, D, False)
    if ends == 'none':
        return R
    if len(R) < 2:                        # replace
        return [P[0], P[-1]]
    return [P[0]] + R[1:-1] + [P[-1]]


def refine(P, scheme, D, ends, closed, depth):
    for _ in range(depth):
        P = refine_level(P, scheme, D, ends, closed)
    return P


def cardinal(D, x):
    """The uniform B-spline of degree D (support [0, D+1]) at x, exactly
    (Cox-de Boor recursion on the integer knots)."""
    if D == 0:
        return Fr(1) if 0 <= x < 1 else Fr(0)
    return (x * cardinal(D - 1, x) + (D + 1 - x) * cardinal(D - 1, x - 1)) / D


def limit_closed(L, D):
    """Closed uniform B-spline of degree D with control polygon L: the point
    at each vertex (odd D) or edge midpoint (even D), and its derivative (an
    exact unnormalised direction; zero for D = 1). Anchor a: vertex a, or
    the edge L_a L_a+1; for D = 2 this is the edge midpoint with the edge
    as tangent, for D = 3 (L_a-1 + 4 L_a + L_a+1)/6 with L_a+1 - L_a-1."""
    n = len(L)
    dim = len(L[0])
    # the curve is sum_j B_D(s - j) L_j with knots at the integers; L_a's
    # basis function is centred at a + (D+1)/2, a knot for odd D; for even
    # D the knot a + D/2 + 1 lies between L_a's and L_a+1's centres
    s0 = Fr((D + 2) // 2)
    ks = [k for k in range(-D - 1, D + 2) if cardinal(D, s0 - k) != 0]
    w = {k: cardinal(D, s0 - k) for k in ks}
    # derivative: d/ds B_D(s - k) = B_{D-1}(s - k) - B_{D-1}(s - k - 1)
    dw = {}
    if D > 1:
        for k in range(-D - 1, D + 2):
            c = cardinal(D - 1, s0 - k) - cardinal(D - 1, s0 - k - 1)
            if c != 0:
                dw[k] = c
        # only the direction matters: the smallest integer weights
        # (D = 2: L_a+1 - L_a; D = 3: L_a+1 - L_a-1)
        den = 1
        for c in dw.values():
            den = den * c.denominator // math.gcd(den, c.denominator)
        num = 0
        for c in dw.values():
            num = math.gcd(num, int(c * den))
        dw = {k: c * den / num for k, c in dw.items()}
    out = []
    for a in range(n):
        pos = tuple(sum(c * L[(a + k) % n][x] for k, c in w.items()) for x in range(dim))
        tan = tuple(sum(c * L[(a + k) % n][x] for k, c in dw.items()) for x in range(dim))
        out.append((pos, tan))
    return out


# ---------------------------------------------------------------- case files

def parse_case(path):
    with open(path) as f:
        lines = f.read().split('\n')
    hdr, inp, out, i = {}, [], [], 0
    order = []
    while i < len(lines):
        ln = lines[i].strip()
        i += 1
        if not ln:
            continue
        k, _, v = ln.partition(' ')
        v = v.strip()
        if k in ('input', 'output'):
            rows = [lines[i + j].split() for j in range(int(v))]
            i += int(v)
            if k == 'input':
                inp = [tuple(int(t) for t in r) for r in rows]
            else:
                out = [tuple(Fr(t) for t in r) for r in rows]
        else:
            hdr[k] = v
            order.append(k)
    hdr['_order'] = order
    return hdr, inp, out


def spec_of(hdr):
    s = hdr['scheme']
    if s == 'chaikin':
        scheme, D = 'bspline', 2
    elif s == 'dlg':
        scheme, D = 'dlg', 0
    else:
        scheme, D = 'bspline', int(s.split(':')[1])
    return scheme, D, hdr.get('ends', '-'), hdr['closed'] == '1', int(hdr['depth']), \
        int(hdr['dim']), hdr.get('limit', '0') == '1'


def compute(hdr, inp):
    """The exact output rows for a case header and integer input."""
    scheme, D, ends, closed, depth, dim, limit = spec_of(hdr)
    P = [tuple(Fr(c) for c in p[:dim]) for p in inp]
    L = refine(P, scheme, D, ends, closed, depth)
    if not limit:
        return [tuple(p) for p in L]
    if not closed or scheme != 'bspline':
        raise ValueError('limit vectors are closed B-splines only')
    if not L:
        return []
    if len(L) == 1:
        return [L[0] + tuple(Fr(0) for _ in range(dim))]
    return [p + t for p, t in limit_closed(L, D)]


def fmt_row(row, dim, limit):
    s = ' '.join(str(x) for x in row[:dim])
    if limit:
        s += '  ' + ' '.join(str(x) for x in row[dim:])
    return s


def render(hdr, inp, out):
    scheme, D, ends, closed, depth, dim, limit = spec_of(hdr)
    lines = ['scheme ' + hdr['scheme'], 'ends ' + ends, 'closed %d' % closed,
             'depth %d' % depth, 'dim %d' % dim]
    if limit:
        lines.append('limit 1')
    lines.append('input %d' % len(inp))
    lines += [' '.join(str(c) for c in p[:dim]) for p in inp]
    lines.append('output %d' % len(out))
    lines += [fmt_row(r, dim, limit) for r in out]
    return '\n'.join(lines) + '\n'


def rotations(n, closed):
    return range(n) if closed and n else range(1)


def same_output(got, exp, closed, dim, limit):
    """(equal, rotation): exact equality of positions (and parallel,
    same-sense tangents for limit rows), closed up to a cyclic rotation."""
    if len(got) != len(exp):
        return False, None
    n = len(got)

    def row_eq(g, e):
        if g[:dim] != e[:dim]:
            return False
        if not limit:
            return True
        tg, te = g[dim:], e[dim:]
        if all(x == 0 for x in tg) or all(x == 0 for x in te):
            return all(x == 0 for x in tg) and all(x == 0 for x in te)
        # parallel and pointing the same way: te = lambda * tg, lambda > 0
        k = next(i for i in range(dim) if tg[i] != 0)
        lam = te[k] / tg[k]
        return lam > 0 and all(te[i] == lam * tg[i] for i in range(dim))

    for r in rotations(n, closed):
        if all(row_eq(got[(i + r) % n], exp[i]) for i in range(n)):
            return True, r
    return False, None


# ---------------------------------------------------------------- the corpus

class Rng:
    """Deterministic across Python versions: only getrandbits (Mersenne
    Twister, seeded by an int), no randrange/choice whose algorithms may
    change."""

    def __init__(self, seed):
        import random
        self.r = random.Random(seed)

    def below(self, n):
        k = max(1, n.bit_length())
        while True:
            v = self.r.getrandbits(k)
            if v < n:
                return v

    def int(self, lo, hi):
        return lo + self.below(hi - lo + 1)


# the 26 scheme / end-rule combinations the kernel builds (pk_refine.h)
COMBOS = ([('bspline', D, 'none', False) for D in range(1, 8)] +
          [('bspline', D, 'replace', False) for D in range(1, 8)] +
          [('bspline', D, 'clamped', False) for D in range(1, 4)] +
          [('bspline', D, '-', True) for D in range(1, 8)] +
          [('dlg', 0, '-', False), ('dlg', 0, '-', True)])


def scheme_name(scheme, D):
    return 'dlg' if scheme == 'dlg' else 'chaikin' if D == 2 else 'bspline:%d' % D


def combo_tag(scheme, D, ends, closed):
    s = 'dlg' if scheme == 'dlg' else 'chaikin' if D == 2 else 'bspline%d' % D
    return s + ('_closed' if closed else '_open' if scheme == 'dlg' else '_open_' + ends)


def pts_random(rng, m, dim, mag):
    return [tuple(rng.int(-mag, mag) for _ in range(dim)) for _ in range(m)]


def pts_extreme(rng, m, dim):
    """Every coordinate at +-PK_UM_MAX (the largest inputs, sign changes
    between neighbours: the largest overshoot DLG can make)."""
    return [tuple(PK_UM_MAX if rng.below(2) else -PK_UM_MAX for _ in range(dim))
            for _ in range(m)]


def pts_collinear(rng, m, dim):
    """On one line through the range, forwards and back (exact multiples of
    an integer direction from an integer base)."""
    d = tuple(rng.int(-2000, 2000) for _ in range(dim))
    span = max(1, max(abs(x) for x in d))
    lim = PK_UM_MAX // (span * 2)
    base = tuple(rng.int(-PK_UM_MAX // 2, PK_UM_MAX // 2) for _ in range(dim))
    lim = min(lim, min((PK_UM_MAX - abs(b)) // span for b in base))
    return [tuple(b + t * x for b, x in zip(base, d))
            for t in (rng.int(-lim, lim) for _ in range(m))]


def pts_duplicates(rng, m, dim):
    """Runs of repeated points (a stroke that stops, a closed stroke that
    repeats its first point at the end)."""
    out = []
    while len(out) < m:
        p = tuple(rng.int(-PK_UM_MAX, PK_UM_MAX) for _ in range(dim))
        out += [p] * (1 + rng.below(3))
    out = out[:m]
    if m >= 2:
        out[-1] = out[0]
    return out


def pts_tiny(rng, m, dim):
    """Coordinates in -3..3: every rounding tie the kernel makes is visible."""
    return [tuple(rng.int(-3, 3) for _ in range(dim)) for _ in range(m)]


def min_points(scheme, D, closed):
    """The fewest points whose refinement grows at every level (a full
    stencil somewhere): outputs about 2^depth * 2 for open curves."""
    if scheme == 'dlg':
        return 4
    return 3 if closed else D + 2


def m_for_depth(depth, lo):
    """Random-case size: enough points for every stencil, few outputs deep."""
    return lo if depth >= 6 else max(lo, min(12, 256 >> depth))


def corpus(seed, only=None):
    """[(filename, text)] in a fixed order. Every scheme/end-rule/closed
    combination at every depth 0..8, in 2 and 3 dimensions, on full-range
    random polygons, the extreme corners of the range, collinear points,
    repeated points, tiny coordinates, their reversals, 0/1/2/3 points,
    long polygons at shallow depth; closed B-spline limit points and
    tangents at every depth. With `only` (a set of names), only those
    cases are computed (the others come back with text None); the random
    stream, hence every input, is the same either way."""
    rng = Rng(seed)
    files = []

    def add(tag, kind, scheme, D, ends, closed, depth, dim, inp, limit=False):
        hdr = {'scheme': scheme_name(scheme, D), 'ends': ends, 'closed': '1' if closed else '0',
               'depth': str(depth), 'dim': str(dim)}
        if limit:
            hdr['limit'] = '1'
        name = '%s%s_%s_m%d_d%d_%dd.txt' % ('limit_' if limit else '', tag, kind, len(inp),
                                           depth, dim)
        if only is not None and name not in only:
            files.append((name, None))
        else:
            files.append((name, render(hdr, inp, compute(hdr, inp))))

    for ci, (scheme, D, ends, closed) in enumerate(COMBOS):
        tag = combo_tag(scheme, D, ends, closed)
        lo = min_points(scheme, D, closed)
        for depth in range(MAX_DEPTH + 1):
            dim = 2 + (ci + depth) % 2
            other = 5 - dim
            m = m_for_depth(depth, lo)
            inp = pts_random(rng, m, dim, PK_UM_MAX)
            add(tag, 'rand', scheme, D, ends, closed, depth, dim, inp)
            if depth in (1, 3, 5):
                add(tag, 'rev', scheme, D, ends, closed, depth, dim, inp[::-1])
            if depth in (0, 2, 4):
                add(tag, 'rand', scheme, D, ends, closed, depth, other,
                    pts_random(rng, max(lo, m // 2), other, PK_UM_MAX))
            if depth in (0, 3, 5, 8):
                add(tag, 'extreme', scheme, D, ends, closed, depth, 2, pts_extreme(rng, lo, 2))
            if depth in (1, 4, 7):
                add(tag, 'tiny', scheme, D, ends, closed, depth, other, pts_tiny(rng, lo + 1, other))
            if depth in (1, 8):
                for k in (0, 1, 2):
                    kd = 2 + (k + depth) % 2
                    add(tag, 'few', scheme, D, ends, closed, depth, kd,
                        pts_random(rng, k, kd, PK_UM_MAX))
            if depth == 2:
                add(tag, 'few', scheme, D, ends, closed, depth, dim, pts_random(rng, 3, dim, PK_UM_MAX))
            if depth in (2, 5):
                add(tag, 'collinear', scheme, D, ends, closed, depth, dim,
                    pts_collinear(rng, lo + 2, dim))
            if depth in (1, 4):
                add(tag, 'dup', scheme, D, ends, closed, depth, other,
                    pts_duplicates(rng, lo + 3, other))
        for depth in (0, 1, 2):
            add(tag, 'long', scheme, D, ends, closed, depth, 2 + depth % 2,
                pts_random(rng, 40 >> depth, 2 + depth % 2, PK_UM_MAX))

    for D in range(1, 8):
        tag = combo_tag('bspline', D, '-', True)
        # every depth for the README's two (chaikin, cubic); to 6 for the rest
        for depth in range(MAX_DEPTH + 1 if D in (2, 3) else 7):
            dim = 2 if depth >= 7 else 2 + (D + depth) % 2
            m = 3 + (depth + D) % 4 if depth < 6 else 3
            add(tag, 'rand', 'bspline', D, '-', True, depth, dim,
                pts_random(rng, m, dim, PK_UM_MAX), limit=True)
        add(tag, 'few', 'bspline', D, '-', True, 2, 2, pts_random(rng, 1, 2, PK_UM_MAX), limit=True)
        add(tag, 'few', 'bspline', D, '-', True, 1, 3, pts_random(rng, 2, 3, PK_UM_MAX), limit=True)

    names = [n for n, _ in files]
    assert len(set(names)) == len(names), 'duplicate case names'
    return files


# ---------------------------------------------------------------- commands

def cmd_write(dirname, seed):
    os.makedirs(dirname, exist_ok=True)
    files = corpus(seed)
    keep = {n for n, _ in files}
    for fn in os.listdir(dirname):
        if fn.endswith('.txt') and fn not in keep:
            os.remove(os.path.join(dirname, fn))
    for name, text in files:
        with open(os.path.join(dirname, name), 'w', newline='\n') as f:
            f.write(text)
    with open(os.path.join(dirname, 'SEED'), 'w') as f:
        f.write('%d\n' % seed)
    total = sum(len(t) for _, t in files)
    print('wrote %d cases (%d bytes) to %s, seed %d' % (len(files), total, dirname, seed))


def cmd_check(dirname, seed, sample):
    passed = failed = 0
    try:
        with open(os.path.join(dirname, 'SEED')) as f:
            seed = int(f.read().strip()) if seed is None else seed
    except OSError:
        print('FAIL %s/SEED missing' % dirname)
        print('0 passed, 1 failed')
        return False
    # the file list comes from the corpus plan; only sampled cases are computed
    files = corpus_names(seed)
    have = sorted(fn for fn in os.listdir(dirname) if fn.endswith('.txt'))
    if sorted(files) != have:
        extra = sorted(set(have) - set(files))[:5]
        missing = sorted(set(files) - set(have))[:5]
        print('FAIL file list differs: extra %s missing %s' % (extra, missing))
        failed += 1
    else:
        passed += 1
    want = set(files[::sample]) if sample > 1 else set(files)
    for name, text in corpus(seed, only=want):
        if text is None:
            continue
        path = os.path.join(dirname, name)
        try:
            with open(path, newline='') as f:
                ok = f.read() == text
        except OSError:
            ok = False
        if ok:
            passed += 1
        else:
            failed += 1
            print('FAIL %s differs from its regeneration' % name)
    print('regenerated %d of %d cases (seed %d)' % (passed + failed - 1, len(files), seed))
    print('%d passed, %d failed' % (passed, failed))
    return failed == 0


def cmd_verify(dirs):
    passed = failed = rotated = identical = skipped = 0
    by_kind = {}
    for d in dirs:
        names = sorted(fn for fn in os.listdir(d) if fn.endswith('.txt'))
        for fn in names:
            path = os.path.join(d, fn)
            hdr, inp, exp = parse_case(path)
            scheme, _, _, closed, _, dim, limit = spec_of(hdr)
            if limit and (not closed or scheme != 'bspline' or 'tangent_decimal' in hdr):
                skipped += 1           # open / DLG limit points: not stated rules
                continue
            got = compute(hdr, inp)
            ok, rot = same_output(got, exp, closed, dim, limit)
            key = hdr['scheme'] + (' limit' if limit else '') + (' closed' if closed else ' open')
            s = by_kind.setdefault(key, [0, 0, 0])
            if ok:
                passed += 1
                s[0] += 1
                if rot:
                    rotated += 1
                    s[2] += 1
                with open(path, newline='') as f:
                    if f.read() == render(hdr, inp, got):
                        identical += 1
            else:
                failed += 1
                s[1] += 1
                print('FAIL %s: regenerated output differs' % path)
    for k in sorted(by_kind):
        print('  %-24s %4d match, %d differ, %d of them rotated' % (k, *by_kind[k]))
    print('%d match exactly (%d closed ones up to a rotation, %d byte-identical files); '
          '%d skipped (limit points of open or DLG curves)' % (passed, rotated, identical, skipped))
    print('%d passed, %d failed' % (passed, failed))
    return failed == 0


def corpus_names(seed):
    return [n for n, _ in corpus(seed, only=set())]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument('--write', metavar='DIR')
    g.add_argument('--check', metavar='DIR')
    g.add_argument('--verify', metavar='DIR', nargs='+')
    ap.add_argument('--seed', type=int, default=None)
    ap.add_argument('--sample', type=int, default=1, metavar='N',
                    help='--check: regenerate every N-th case only')
    a = ap.parse_args()
    if a.write:
        cmd_write(a.write, DEFAULT_SEED if a.seed is None else a.seed)
        return 0
    if a.check:
        return 0 if cmd_check(a.check, a.seed, max(1, a.sample)) else 1
    return 0 if cmd_verify(a.verify) else 1


if __name__ == '__main__':
    sys.exit(main())
