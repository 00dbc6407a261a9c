#!/usr/bin/env python3
"""derive_masks.py -- derive, verify and emit plotkin's limit (evaluation) and
tangent masks for every subdivision scheme the kernel supports.

Python 3 standard library only (fractions.Fraction for exact arithmetic).

    python3 tests/tools/derive_masks.py --check-shared tests/vectors/exact
        re-implement the refinement rules and check them against the reference
        exact vectors (every case must match exactly)
    python3 tests/tools/derive_masks.py --verify
        derive every mask and verify it by brute force: deep exact refinement
        of random polygons, distance of each claimed limit point to the refined
        polygon and angle of each claimed tangent to the refined polygon's chord
    python3 tests/tools/derive_masks.py --emit firmware
        write firmware/pk_masks.h and firmware/pk_masks.c (generated tables)
    python3 tests/tools/derive_masks.py --vectors tests/vectors
        write exact reference vectors for the limit stage, computed
        independently of the masks (de Boor evaluation of the B-spline /
        deep local refinement), see tests/vectors/README.md

Derivation in one paragraph (longer version in the header of pk_masks.h):
one refinement level is a linear map S (new points = S * old points). A
point of the refined polygon whose index is a fixed point of the level-to-
level index map sigma ("stationary" anchor, e.g. the end point of an open
curve) sees, in a window W closed under S, the local subdivision matrix A =
S|W. Its eigenvalues are 1 > lambda1 > lambda2 ... ; the left eigenvector
l0 of 1 (normalised to sum 1) is the evaluation mask (A^k -> 1 l0), and the
left eigenvector l1 of the subdominant lambda1 is the tangent mask (the
window points approach l0.P along the direction l1.P, with the error
decaying like (lambda2/lambda1)^k). Anchors that are not stationary are
followed along sigma until they reach stationary or uniform territory and
the mask there is pulled back through S (mask_a = mask_sigma(a) * S).
Uniform B-spline masks are the cardinal B-spline and its derivative at the
knots; clamped masks are the clamped B-spline evaluated at the anchor's
Greville abscissa.
"""
import argparse
import math
import os
import random
import sys
from fractions import Fraction as Fr

# --------------------------------------------------------------------------
# The refinement rules (the specification, on one coordinate at a time; all
# rules are linear and act on each coordinate independently).
# --------------------------------------------------------------------------


def lr_open_none(x, D):
    s = [v for v in x for _ in (0, 1)]
    for _ in range(D):
        s = [(s[i] + s[i + 1]) / 2 for i in range(len(s) - 1)]
    return s


def bspline_eval_knots(P, T, d, t, deriv=False):
    """Value (or first derivative) at t of the B-spline with control values P,
    knot vector T, degree d. Exact for Fractions. t in [T[d], T[len(P)]]."""
    n = len(P)
    lo, hi = T[d], T[n]
    assert lo <= t <= hi
    # span l with T[l] <= t < T[l+1], d <= l <= n-1 (the last span is closed)
    l = d
    while l < n - 1 and T[l + 1] <= t:
        l += 1
    if deriv:
        if d == 0:
            return 0 * P[0]
        Q = [d * (P[i + 1] - P[i]) / (T[i + d + 1] - T[i + 1]) for i in range(n - 1)]
        return bspline_eval_knots(Q, T[1:-1], d - 1, t)
    # de Boor
    dpts = [P[j] for j in range(l - d, l + 1)]
    for r in range(1, d + 1):
        for j in range(d, r - 1, -1):
            i = j + l - d
            den = T[i + d - r + 1] - T[i]
            a = (t - T[i]) / den if den != 0 else 0
            dpts[j] = (1 - a) * dpts[j - 1] + a * dpts[j]
    return dpts[d]


def clamped_knots(n, d):
    return [Fr(0)] * (d + 1) + [Fr(k) for k in range(1, n - d)] + [Fr(n - d)] * (d + 1)


def clamped_refine(x, D):
    m = len(x)
    d = min(D, m - 1)
    T = clamped_knots(m, d)
    P = list(x)
    for k in range(m - d):
        u = Fr(2 * k + 1, 2)
        l = d
        while T[l + 1] <= u:
            l += 1
        Q = []
        for i in range(len(P) + 1):
            if i <= l - d:
                Q.append(P[i])
            elif i <= l:
                a = (u - T[i]) / (T[i + d] - T[i])
                Q.append((1 - a) * P[i - 1] + a * P[i])
            else:
                Q.append(P[i - 1])
        P = Q
        T = T[:l + 1] + [u] + T[l + 1:]
    return P


def dlg_mid(a, b, c, d):
    return (-a + 9 * b + 9 * c - d) / 16


def refine1(x, scheme, D, closed, ends):
    """One level of refinement of one coordinate list x (the spec)."""
    m = len(x)
    if m <= 1:
        return list(x)
    if scheme == 'dlg':
        if closed:
            out = []
            for i in range(m):
                out += [x[i], dlg_mid(x[i - 1], x[i], x[(i + 1) % m], x[(i + 2) % m])]
            return out
        if m == 2:
            return list(x)
        g = [2 * x[0] - x[1]] + list(x) + [2 * x[-1] - x[-2]]
        out = []
        for i in range(m - 1):
            out += [x[i], dlg_mid(g[i], g[i + 1], g[i + 2], g[i + 3])]
        return out + [x[-1]]
    if closed:
        s = [v for v in x for _ in (0, 1)]
        for _ in range(D):
            s = [(s[i] + s[(i + 1) % len(s)]) / 2 for i in range(len(s))]
        return s
    if m == 2:
        return list(x)
    if ends == 'none':
        return lr_open_none(x, D)
    if ends == 'replace':
        r = lr_open_none(x, D)
        if len(r) < 2:
            return [x[0], x[-1]]
        r[0] = x[0]
        r[-1] = x[-1]
        return r
    if ends == 'clamped':
        return clamped_refine(x, D)
    raise ValueError(ends)


def refine_pts(P, scheme, D, closed, ends, levels=1):
    """Refine a list of points (tuples) `levels` times."""
    for _ in range(levels):
        if not P:
            return []
        cols = [refine1([p[k] for p in P], scheme, D, closed, ends) for k in range(len(P[0]))]
        P = list(zip(*cols))
    return P


def smatrix(n, scheme, D, closed, ends):
    """Subdivision matrix (list of rows, Fractions) of one level for n points."""
    cols = []
    for j in range(n):
        e = [Fr(0)] * n
        e[j] = Fr(1)
        cols.append(refine1(e, scheme, D, closed, ends))
    nn = len(cols[0]) if cols else 0
    return [[cols[j][i] for j in range(n)] for i in range(nn)]


# --------------------------------------------------------------------------
# Shared-vector check of the rules above.
# --------------------------------------------------------------------------


def parse_case(path):
    with open(path) as f:
        lines = [l.strip() for l in f if l.strip() and not l.startswith('#')]
    hdr = {}
    i = 0
    inp, out = [], []
    while i < len(lines):
        k, _, v = lines[i].partition(' ')
        if k == 'input':
            cnt = int(v)
            inp = [tuple(Fr(t) for t in lines[i + 1 + j].split()) for j in range(cnt)]
            i += 1 + cnt
            continue
        if k == 'output':
            cnt = int(v)
            out = [tuple(Fr(t) for t in lines[i + 1 + j].split()) for j in range(cnt)]
            i += 1 + cnt
            continue
        hdr[k] = v
        i += 1
    return hdr, inp, out


def scheme_of(s):
    if s == 'chaikin':
        return 'bspline', 2
    if s == 'dlg':
        return 'dlg', 0
    a, _, d = s.partition(':')
    return 'bspline', int(d)


def rot_equal(a, b):
    if len(a) != len(b):
        return False
    if not a:
        return True
    return any(a[k:] + a[:k] == b for k in range(len(a)))


def check_shared(dirname):
    bad = 0
    n = 0
    for fn in sorted(os.listdir(dirname)):
        if not fn.endswith('.txt'):
            continue
        if fn.startswith('limit_'):
            bad += 0 if check_shared_limit(os.path.join(dirname, fn)) else 1
            n += 1
            continue
        hdr, inp, out = parse_case(os.path.join(dirname, fn))
        sch, D = scheme_of(hdr['scheme'])
        closed = hdr['closed'] == '1'
        got = refine_pts(inp, sch, D, closed, hdr['ends'], int(hdr['depth']))
        ok = rot_equal(got, out) if closed else got == out
        n += 1
        if not ok:
            bad += 1
            print('MISMATCH', fn)
    print('shared refinement and limit vectors: %d checked, %d mismatches' % (n, bad))
    return bad == 0


def check_shared_limit(path):
    """The generated tables reproduce a shared limit vector exactly."""
    hdr, inp, out = parse_case(path)
    sch, D = scheme_of(hdr['scheme'])
    closed = hdr['closed'] == '1'
    r = Rule(sch, D, closed, None if closed or sch == 'dlg' else hdr['ends'])
    if not closed:
        find_min_n(r)
    L = refine_pts(inp, sch, D, closed, r.ends, int(hdr['depth']))
    got = limit_outputs(tables_of(r), L)
    dim = int(hdr['dim'])
    want = [(o[:dim], o[dim:]) for o in out]
    for rot in range(max(1, len(got))):
        g = got[rot:] + got[:rot]
        if len(g) == len(want) and all(x[1] == w[0] and exact_parallel(x[2], w[1])
                                       for x, w in zip(g, want)):
            return True
    print('MISMATCH (limit tables)', os.path.basename(path))
    return False


# --------------------------------------------------------------------------
# Exact linear algebra on small matrices of Fractions.
# --------------------------------------------------------------------------


def nullspace(M):
    """Basis of {x : M x = 0} (M: list of rows of Fractions)."""
    rows = [list(r) for r in M]
    ncol = len(M[0])
    piv = []
    r = 0
    for c in range(ncol):
        p = next((i for i in range(r, len(rows)) if rows[i][c] != 0), None)
        if p is None:
            continue
        rows[r], rows[p] = rows[p], rows[r]
        inv = 1 / rows[r][c]
        rows[r] = [v * inv for v in rows[r]]
        for i in range(len(rows)):
            if i != r and rows[i][c] != 0:
                f = rows[i][c]
                rows[i] = [a - f * b for a, b in zip(rows[i], rows[r])]
        piv.append(c)
        r += 1
        if r == len(rows):
            break
    free = [c for c in range(ncol) if c not in piv]
    basis = []
    for fc in free:
        x = [Fr(0)] * ncol
        x[fc] = Fr(1)
        for i, pc in enumerate(piv):
            x[pc] = -rows[i][fc]
        basis.append(x)
    return basis


def transpose(A):
    return [list(c) for c in zip(*A)]


def matmul(A, B):
    Bt = transpose(B)
    return [[sum(a * b for a, b in zip(r, c)) for c in Bt] for r in A]


def charpoly(A):
    """Coefficients c[0..n] of det(x I - A) = sum c[k] x^k (Faddeev-LeVerrier)."""
    n = len(A)
    c = [Fr(0)] * (n + 1)
    c[n] = Fr(1)
    M = [[Fr(0)] * n for _ in range(n)]
    for k in range(1, n + 1):
        # M_k = A M_{k-1} + c_{n-k+1} I
        AM = matmul(A, M) if k > 1 else [[Fr(0)] * n for _ in range(n)]
        for i in range(n):
            AM[i][i] += c[n - k + 1]
        M = AM
        AMk = matmul(A, M)
        c[n - k] = -sum(AMk[i][i] for i in range(n)) / k
    return c


def poly_eval(c, x):
    v = 0
    for a in reversed(c):
        v = v * x + a
    return v


def poly_div_linear(c, r):
    """c(x) / (x - r), assuming r is a root."""
    n = len(c) - 1
    q = [Fr(0)] * n
    acc = Fr(0)
    for k in range(n, 0, -1):
        acc = acc * r + c[k]
        q[k - 1] = acc
    return q


def rational_roots(c):
    """All rational roots with multiplicity, and the remaining factor."""
    roots = []
    c = list(c)
    while len(c) > 1:
        den = 1
        for a in c:
            den = den * a.denominator // math.gcd(den, a.denominator)
        ic = [int(a * den) for a in c]
        if ic[0] == 0:
            roots.append(Fr(0))
            c = c[1:]
            continue
        found = None
        a0, an = abs(ic[0]), abs(ic[-1])
        ps = [p for p in range(1, a0 + 1) if a0 % p == 0] if a0 < 10 ** 7 else []
        qs = [q for q in range(1, an + 1) if an % q == 0] if an < 10 ** 7 else []
        for p in ps:
            for q in qs:
                for sgn in (1, -1):
                    r = Fr(sgn * p, q)
                    if poly_eval(c, r) == 0:
                        found = r
                        break
                if found is not None:
                    break
            if found is not None:
                break
        if found is None:
            break
        roots.append(found)
        c = poly_div_linear(c, found)
    return roots, c


def complex_roots(c):
    """All roots of the polynomial c (floats, Durand-Kerner)."""
    n = len(c) - 1
    if n == 0:
        return []
    a = [float(x / c[-1]) for x in c]
    z = [complex(0.4, 0.9) ** k for k in range(n)]
    for _ in range(2000):
        nz = []
        for i in range(n):
            num = sum(a[k] * z[i] ** k for k in range(n + 1))
            den = 1
            for j in range(n):
                if j != i:
                    den *= (z[i] - z[j])
            nz.append(z[i] - num / den)
        z = nz
    return z


def refine_real_root(c, approx, bits=200):
    """Bisection in Fractions around a float approximation of a simple real root."""
    w = Fr(1, 10 ** 6)
    lo, hi = Fr(approx) - w, Fr(approx) + w
    flo = poly_eval(c, lo)
    assert flo * poly_eval(c, hi) < 0, 'no sign change near %r' % approx
    while hi - lo > Fr(1, 2 ** bits):
        mid = (lo + hi) / 2
        fm = poly_eval(c, mid)
        if (fm < 0) == (flo < 0):
            lo, flo = mid, fm
        else:
            hi = mid
    return (lo + hi) / 2


class Eigen:
    """Spectrum and dominant/subdominant left eigenvectors of a local matrix."""

    def __init__(self, A):
        self.A = A
        n = len(A)
        c = charpoly(A)
        rr, rest = rational_roots(c)
        self.rational = rr
        self.rest = rest              # irreducible-ish remainder (degree >= 0)
        self.irr = complex_roots(rest) if len(rest) > 1 else []
        allv = [complex(float(r)) for r in rr] + self.irr
        self.spectrum = sorted(allv, key=lambda z: -abs(z))
        At = transpose(A)
        I = lambda lam: [[At[i][j] - (lam if i == j else 0) for j in range(n)] for i in range(n)]
        ns1 = nullspace(I(Fr(1)))
        self.l0 = None
        if len(ns1) == 1 and sum(ns1[0]) != 0:
            s = sum(ns1[0])
            self.l0 = [v / s for v in ns1[0]]
        # subdominant: largest modulus below 1
        others = [z for z in self.spectrum if abs(z - 1) > 1e-12]
        self.lam1 = others[0] if others else None
        self.lam2 = others[1] if len(others) > 1 else 0
        self.l1 = None
        self.l1_exact = False
        self.lam1_text = ''
        if self.lam1 is None:
            return
        ties = [z for z in others if abs(abs(z) - abs(self.lam1)) < 1e-9]
        if len(ties) > 1 or abs(self.lam1.imag) > 1e-12:
            return   # not simple / complex: no tangent from this matrix
        lr = [r for r in rr if abs(float(r) - self.lam1.real) < 1e-12]
        if lr:
            lam = lr[0]
            ns = nullspace(I(lam))
            if len(ns) != 1:
                return
            self.l1 = ns[0]
            self.l1_exact = True
            self.lam1_exact = lam
            self.lam1_text = str(lam)
        else:
            lam = refine_real_root(rest, self.lam1.real)
            self.lam1_exact = lam
            self.lam1_text = describe_root(rest, self.lam1.real)
            M = I(lam)
            # fix the component with the largest cofactor-ish: try each, keep best
            best = None
            for j0 in range(n):
                for drop in range(n):
                    rows = [M[i] for i in range(n) if i != drop]
                    sub = [[r[j] for j in range(n) if j != j0] for r in rows]
                    rhs = [-r[j0] for r in rows]
                    x = solve(sub, rhs)
                    if x is None:
                        continue
                    v = x[:j0] + [Fr(1)] + x[j0:]
                    res = max(abs(sum(M[i][j] * v[j] for j in range(n))) for i in range(n))
                    nv = max(abs(t) for t in v)
                    if best is None or res / nv < best[0]:
                        best = (res / nv, v)
            self.l1 = best[1]
            self.l1_residual = best[0]


def describe_root(c, approx):
    """Text for an irrational root: closed form for quadratics."""
    if len(c) == 3:
        a, b, cc = c[2], c[1], c[0]
        disc = b * b - 4 * a * cc
        # root = (-b +- sqrt(disc)) / 2a ; write sqrt(disc) = sqrt(p)/q
        num, den = disc.numerator, disc.denominator
        sq = math.isqrt(den)
        if sq * sq == den:
            k = 1
            p = num
            for f in range(2, 1000):
                while p % (f * f) == 0:
                    p //= f * f
                    k *= f
            sgn = 1 if approx * 2 * float(a) + float(b) > 0 else -1
            base = -b / (2 * a)
            coef = Fr(k, sq) / (2 * a) * sgn
            return '%s %s %s*sqrt(%d)  (root of %s)' % (base, '+' if coef > 0 else '-', abs(coef), p,
                                                       poly_text(c))
    return '%.15g (root of %s)' % (approx, poly_text(c))


def poly_text(c):
    den = 1
    for a in c:
        den = den * a.denominator // math.gcd(den, a.denominator)
    ic = [int(a * den) for a in c]
    terms = []
    for k in range(len(ic) - 1, -1, -1):
        if ic[k]:
            terms.append('%+d%s' % (ic[k], '' if k == 0 else ('x' if k == 1 else 'x^%d' % k)))
    return ' '.join(terms)


def solve(M, b):
    n = len(M)
    A = [list(r) + [v] for r, v in zip(M, b)]
    for c in range(n):
        p = next((i for i in range(c, n) if A[i][c] != 0), None)
        if p is None:
            return None
        A[c], A[p] = A[p], A[c]
        inv = 1 / A[c][c]
        A[c] = [v * inv for v in A[c]]
        for i in range(n):
            if i != c and A[i][c] != 0:
                f = A[i][c]
                A[i] = [x - f * y for x, y in zip(A[i], A[c])]
    return [A[i][n] for i in range(n)]

# --------------------------------------------------------------------------
# Masks. A mask is a dict {vertex index: weight} (a linear functional on the
# polygon); uniform masks are dicts {offset from the anchor: weight}.
# Tangent masks may be None (undefined: zero tangent).
# --------------------------------------------------------------------------

MBIG = 48      # polygon size for the end analysis (ends far apart)
N0 = 40        # standard rules assumed valid from here (checked by brute force)


def card(D, x):
    """Cardinal B-spline of degree D on knots 0..D+1, at x (exact)."""
    x = Fr(x)
    if D == 0:
        return Fr(1) if 0 <= x < 1 else Fr(0)
    return (x * card(D - 1, x) + (D + 1 - x) * card(D - 1, x - 1)) / D


def uniform_bspline(D):
    """(pos, tan) offset dicts of the uniform degree-D masks; tan None for D=1."""
    pos, tan = {}, {}
    if D % 2:
        h = (D - 1) // 2
        rng = range(-h, h + 1)
        arg = lambda r: Fr(D + 1, 2) - r
    else:
        g = D // 2 - 1
        rng = range(-g, g + 2)
        arg = lambda r: Fr(D, 2) + 1 - r
    for r in rng:
        pos[r] = card(D, arg(r))
        if D >= 2:
            tan[r] = card(D - 1, arg(r)) - card(D - 1, arg(r) - 1)
    return strip(pos), (strip(tan) if D >= 2 else None)


def strip(m):
    return {k: v for k, v in m.items() if v != 0} if m is not None else None


def shift(m, a):
    return {k + a: v for k, v in m.items()} if m is not None else None


def compose(m, S):
    """Functional m on the refined polygon, pulled back to the coarse one."""
    if m is None:
        return None
    out = {}
    for i, w in m.items():
        for j, s in enumerate(S[i]):
            if s != 0:
                out[j] = out.get(j, 0) + w * s
    return strip(out)


def apply(m, xs):
    return sum(w * xs[i] for i, w in m.items())


def orient(t):
    """Scale a tangent functional so that it is positive on x_j = j."""
    if t is None:
        return None
    v = sum(w * i for i, w in t.items())
    if v == 0:
        return None
    return {i: w / abs(v) * (1 if v > 0 else -1) for i, w in t.items()}


def same_dir(a, b, tol=Fr(1, 10 ** 20)):
    if a is None or b is None:
        return a is None and b is None
    a, b = orient(a), orient(b)
    if a is None or b is None:
        return a is None and b is None
    keys = set(a) | set(b)
    return all(abs(a.get(k, 0) - b.get(k, 0)) <= tol for k in keys)


class Rule:
    """Limit rule of one (scheme, D, closed, ends)."""

    def __init__(self, scheme, D, closed, ends):
        self.scheme, self.D, self.closed, self.ends = scheme, D, closed, ends
        self.edge = scheme == 'bspline' and D % 2 == 0
        self.notes = []
        self.end = []          # left end anchors: None (dropped) or (pos, tan) absolute dicts
        self.irrational = []   # per end anchor: tangent irrational?
        self.spectra = []
        if scheme == 'bspline':
            self.upos, self.utan = uniform_bspline(D)
        else:
            self.upos, self.utan = dlg_uniform(self)
        self.min_n, self.small = 1, {}     # closed: uniform masks, indices mod n
        if not closed:
            self.derive_end()

    def name(self):
        s = 'dlg' if self.scheme == 'dlg' else ('chaikin' if self.D == 2 else 'bspline:%d' % self.D)
        return '%s %s' % (s, 'closed' if self.closed else (self.ends or 'open'))

    def nanchors(self, n):
        return n - 1 if self.edge else n

    def uniform_at(self, a, n=None):
        p, t = shift(self.upos, a), shift(self.utan, a)
        if n is not None:
            if min(p) < 0 or max(p) >= n:
                return None
        return p, t

    # ---- index map of anchors from one level to the next (left end) ----
    def sigma(self, a):
        if self.scheme == 'dlg':
            return 2 * a
        if self.ends == 'replace' and a == 0:
            return 0
        b = 2 * a - ((self.D - 1) // 2 if self.D % 2 else self.D // 2 - 1)
        if self.ends == 'replace' and b <= 0:
            return -1      # collapses into the (replaced) end point
        return b

    def uniform_exact(self, a, S, n):
        """Uniform masks at a, sigma(a), ... are consistent through S."""
        b = a
        for _ in range(6):
            ub = self.uniform_at(b, n)
            sb = self.sigma(b)
            us = self.uniform_at(sb, len(S))
            if ub is None or us is None:
                return False
            if compose(us[0], S) != ub[0]:
                return False
            if not same_dir(compose(us[1], S), ub[1]):
                return False
            if sb == b:
                return True
            b = sb
            if b > n // 3:
                return True
        return True

    def local_end(self, S):
        """Local subdivision matrix at the left end: smallest closed window."""
        for w in range(2, 12):
            ok = all(S[i][j] == 0 for i in range(w) for j in range(w, len(S[0])))
            if ok:
                return [row[:w] for row in S[:w]]
        raise RuntimeError('no closed end window')

    def derive_end(self):
        D, n = self.D, MBIG
        S = smatrix(n, self.scheme, D, False, self.ends)
        self.S = S
        self.reversal_symmetric = all(S[len(S) - 1 - i][n - 1 - j] == S[i][j]
                                      for i in range(len(S)) for j in range(n))
        if self.ends == 'clamped':
            self.derive_clamped()
            return
        if self.scheme == 'bspline' and D == 1:
            self.end = [({0: Fr(1)}, {0: Fr(-1), 1: Fr(1)})]
            self.irrational = [False]
            self.notes.append('D=1: the limit is the polygon; tangent undefined (zero) at interior '
                              'vertices (corners), one-sided L1-L0 at the end')
            return
        end = {}
        # end point (replace, dlg): stationary anchor 0, local eigen-analysis
        if self.scheme == 'dlg' or self.ends == 'replace':
            A = self.local_end(S)
            E = Eigen(A)
            self.spectra.append(('end window %d' % len(A), E))
            assert E.l0 is not None and E.l1 is not None
            pos = strip({i: v for i, v in enumerate(E.l0)})
            tan = orient(strip({i: v for i, v in enumerate(E.l1)}))
            end[0] = (pos, tan, not E.l1_exact)
        a = 0
        last_special = 0 if end else -1
        while a < n // 3:
            if a in end:
                a += 1
                continue
            if self.uniform_exact(a, S, n):
                a += 1
                continue
            sa = self.sigma(a)
            if self.scheme == 'dlg' and sa > a:
                # position: interpolating; tangent: pull back the descendant's
                t = sa
                tgt = end.get(t) or self.uniform_at(t, len(S)) + (False,)
                assert self.uniform_exact(t, S, n) or t in end
                end[a] = ({a: Fr(1)}, orient(compose(tgt[1], S)), tgt[2])
                last_special = a
            else:
                end[a] = None   # converges into the end point / outside the domain
                last_special = a
            a += 1
        nend = last_special + 1
        self.end = []
        self.irrational = []
        for a in range(nend):
            e = end.get(a)
            if e is None:
                self.end.append(None)
                self.irrational.append(False)
            else:
                self.end.append((e[0], e[1]))
                self.irrational.append(e[2])

    def derive_clamped(self):
        """Clamped: evaluate the clamped B-spline at each anchor's parameter."""
        n = MBIG
        ms = clamped_masks(n, self.D)
        nend = 0
        for a in range(n // 3):
            u = self.uniform_at(a, n)
            if u is None or ms[a][0] != u[0] or not same_dir(ms[a][1], u[1]):
                nend = a + 1
        self.end = [ms[a] for a in range(nend)]
        self.irrational = [False] * nend
        # the stationary end point, cross-checked with the eigen-analysis
        if self.D >= 2:
            A = self.local_end(self.S)
            E = Eigen(A)
            self.spectra.append(('end window %d' % len(A), E))
            assert strip({i: v for i, v in enumerate(E.l0)}) == self.end[0][0]
            assert same_dir(strip({i: v for i, v in enumerate(E.l1)}), self.end[0][1])

    # ---- the standard assignment for an n-point polygon ----
    def standard(self, n):
        if self.closed:
            return [self.uniform_at(a) for a in range(n)]
        A = self.nanchors(n)
        ne = len(self.end)
        if 2 * ne > A:
            return None
        out = []
        for a in range(A):
            if a < ne:
                out.append(self.end[a])
            elif A - 1 - a < ne:
                e = self.end[A - 1 - a]
                out.append(None if e is None else mirror(e, n))
            else:
                u = self.uniform_at(a, n)
                out.append(u)
        return out


def mirror(e, n):
    p, t = e
    return ({n - 1 - i: w for i, w in p.items()},
            None if t is None else {n - 1 - i: -w for i, w in t.items()})


def clamped_params(n, D):
    """Anchor parameters of an n-point clamped polygon of degree D (n >= D+1)."""
    T = clamped_knots(n, D)
    if D % 2 or D == 1:
        return T, [sum(T[i + 1:i + D + 1]) / D for i in range(n)]      # Greville
    return T, [T[i + D // 2 + 1] for i in range(n - 1)]                 # edge: its knot


def clamped_masks(n, D):
    T, par = clamped_params(n, D)
    out = []
    for a, u in enumerate(par):
        pos, tan = {}, {}
        for j in range(n):
            e = [Fr(0)] * n
            e[j] = Fr(1)
            pos[j] = bspline_eval_knots(e, T, D, u)
            if D >= 2:
                tan[j] = bspline_eval_knots(e, T, D, u, deriv=True)
        tan = strip(tan) if D >= 2 else None
        if D == 1 and a in (0, n - 1):
            tan = {0: Fr(-1), 1: Fr(1)} if a == 0 else {n - 2: Fr(-1), n - 1: Fr(1)}
        out.append((strip(pos), tan))
    return out


def dlg_uniform(rule):
    """DLG uniform masks: eigen-analysis of the 5x5 window of a closed polygon."""
    n = 32
    S = smatrix(n, 'dlg', 0, True, None)
    c = 16
    A = [[S[2 * c + r][c + s] for s in range(-2, 3)] for r in range(-2, 3)]
    # closure: new rows 2c-2..2c+2 use only old c-2..c+2
    for r in range(-2, 3):
        assert all(S[2 * c + r][j] == 0 for j in range(n) if abs(j - c) > 2)
    E = Eigen(A)
    rule.spectra.append(('uniform window 5', E))
    pos = strip({s - 2: v for s, v in enumerate(E.l0)})
    tan = orient(strip({s - 2: v for s, v in enumerate(E.l1)}))
    return pos, tan


# --------------------------------------------------------------------------
# Short polygons: follow the refinement until the standard rules apply.
# --------------------------------------------------------------------------

def limit_matrix(S):
    """lim S^k for a square S whose eigenvalue 1 is semisimple, others < 1."""
    n = len(S)
    I = lambda M: [[M[i][j] - (1 if i == j else 0) for j in range(n)] for i in range(n)]
    L = nullspace(I(transpose(S)))
    R = nullspace(I(S))
    G = [[sum(l[k] * r[k] for k in range(n)) for r in R] for l in L]
    k = len(G)
    Ginv = [solve(G, [Fr(1 if i == j else 0) for i in range(k)]) for j in range(k)]
    Ginv = transpose(Ginv)
    # S_inf = R Ginv L
    RG = [[sum(R[a][i] * Ginv[a][b] for a in range(k)) for b in range(k)] for i in range(n)]
    return [[sum(RG[i][b] * L[b][j] for b in range(k)) for j in range(n)] for i in range(n)]


def small_true(rule, n, memo=None):
    """Slots of an n-point open polygon: list of None or (pos, tan)."""
    if memo is None:
        memo = {}
    if n in memo:
        return memo[n]
    if n >= N0:
        res = rule.standard(n)
    elif n == 0:
        res = []
    elif n == 1:
        res = [({0: Fr(1)}, None)]
    elif n == 2:
        t = {0: Fr(-1), 1: Fr(1)}
        res = [({0: Fr(1)}, t), ({1: Fr(1)}, t)]
    elif rule.ends == 'clamped':
        res = clamped_small(rule, n)
    else:
        S = smatrix(n, rule.scheme, rule.D, False, rule.ends)
        n2 = len(S)
        if n2 > n:
            sub = small_true(rule, n2, memo)
            res = []
            seen = []
            for a in range(rule.nanchors(n)):
                sa = rule.sigma(a)
                # right half: mirror the index map
                if a > (rule.nanchors(n) - 1) / 2:
                    sa = rule.nanchors(n2) - 1 - rule.sigma(rule.nanchors(n) - 1 - a)
                if 0 <= sa < len(sub) and sub[sa] is not None:
                    p = compose(sub[sa][0], S)
                    t = compose(sub[sa][1], S)
                    if p in seen:
                        res.append(None)
                    else:
                        seen.append(p)
                        res.append((p, t))
                else:
                    res.append(None)
        elif n2 < n:
            sub = [s for s in small_true(rule, n2, memo) if s is not None]
            pts = []
            for p, t in sub:
                p = compose(p, S)
                if p not in [q for q, _ in pts]:
                    pts.append((p, compose(t, S)))
            res = pts + [None] * (max(rule.nanchors(n), len(pts)) - len(pts))
        else:
            L = limit_matrix(S)
            rows = []
            for i in range(n):
                p = strip({j: v for j, v in enumerate(L[i])})
                if p not in rows:
                    rows.append(p)
            if len(rows) == 1:
                E = Eigen(S)
                t = orient(strip({j: v for j, v in enumerate(E.l1)})) if E.l1 is not None else None
                pts = [(rows[0], t)]
            else:
                pts = []
                for k, p in enumerate(rows):
                    a, b = rows[max(k - 1, 0)], rows[min(k + 1, len(rows) - 1)]
                    t = strip({j: b.get(j, 0) - a.get(j, 0) for j in set(a) | set(b)})
                    pts.append((p, t))
                if len(pts) > rule.nanchors(n):
                    # a static polyline (replace, even D: n points, n-1 edge
                    # slots); all on one segment: leave out the last interior one
                    pts = pts[:rule.nanchors(n) - 1] + pts[-1:]
            res = pts + [None] * (max(rule.nanchors(n), len(pts)) - len(pts))
    memo[n] = res
    return res


def clamped_small(rule, n):
    D = rule.D
    if n >= D + 1:
        return clamped_masks(n, D)
    # too few points: the first level runs at degree n-1 (n+1 points), then D
    S = smatrix(n, 'bspline', D, False, 'clamped')
    n2 = len(S)
    assert n2 >= D + 1
    T = clamped_knots(n2, D)
    out = []
    for a in range(n):
        u = Fr(a, n - 1) * (n2 - D)
        pos, tan = {}, {}
        for j in range(n2):
            e = [Fr(0)] * n2
            e[j] = Fr(1)
            pos[j] = bspline_eval_knots(e, T, D, u)
            tan[j] = bspline_eval_knots(e, T, D, u, deriv=True)
        out.append((compose(strip(pos), S), compose(strip(tan), S)))
    return out


def slots_equal(a, b):
    if a is None or b is None or len(a) != len(b):
        return False
    for x, y in zip(a, b):
        if (x is None) != (y is None):
            return False
        if x is None:
            continue
        if x[0] != y[0] or not same_dir(x[1], y[1], Fr(1, 10 ** 15)):
            return False
    return True


def find_min_n(rule):
    memo = {}
    mn = N0
    for n in range(N0 - 1, 0, -1):
        if slots_equal(small_true(rule, n, memo), rule.standard(n)):
            mn = n
        else:
            break
    rule.min_n = mn
    rule.small = {n: small_true(rule, n, memo) for n in range(1, mn)}
    return mn


ALL_RULES = ([('bspline', D, True, None) for D in range(1, 8)] + [('dlg', 0, True, None)] +
             [('bspline', D, False, 'none') for D in range(1, 8)] +
             [('bspline', D, False, 'replace') for D in range(1, 8)] +
             [('bspline', D, False, 'clamped') for D in range(1, 4)] + [('dlg', 0, False, None)])


# --------------------------------------------------------------------------
# C tables.
# --------------------------------------------------------------------------

MAXLEN = 8
Q24 = 1 << 24


def lcm_den(vals):
    d = 1
    for v in vals:
        d = d * v.denominator // math.gcd(d, v.denominator)
    return d


def enc(m, anchor, irrational=False, primitive=False):
    """(first, len, den, [w]) of a functional relative to its anchor.
    primitive=True marks a tangent mask (normalised, see below)."""
    if m is None or not m:
        return (0, 0, 1, [])
    lo, hi = min(m), max(m)
    vals = [Fr(m.get(i, 0)) for i in range(lo, hi + 1)]
    if primitive and not irrational:
        # rational tangent: normalise to the derivative along the index, i.e.
        # exactly +1 on L_j = j; den is then that rational's denominator
        v1 = sum(v * (lo + k) for k, v in enumerate(vals))
        if v1 != 0:
            vals = [v / v1 for v in vals]
    if irrational:
        pos = sum(v for v in vals if v > 0)
        w = [int(round(v / pos * Q24)) for v in vals]
        k = max(range(len(w)), key=lambda i: abs(w[i]))
        w[k] -= sum(w)
        den = Q24
    else:
        den = lcm_den(vals)
        w = [int(v * den) for v in vals]
    assert len(w) <= MAXLEN, (m, anchor)
    assert all(abs(x) < 2 ** 31 for x in w) and 0 < den < 2 ** 31
    return (lo - anchor, len(w), den, w)


def c_mask(e):
    first, ln, den, w = e
    return '{%d, %d, %d, {%s}}' % (first, ln, den, ', '.join(str(x) for x in w) if w else '0')


def rule_key(r):
    scheme = 1 if r.scheme == 'dlg' else 0
    ends = {'clamped': 1, 'replace': 2, 'none': 3, None: 0}[r.ends]
    return scheme, r.D, 1 if r.closed else 0, ends


def all_rules(verbose=False):
    rules = []
    for args in ALL_RULES:
        r = Rule(*args)
        if r.closed:
            r.min_n = 1
            r.small = {}
        else:
            find_min_n(r)
        rules.append(r)
        if verbose:
            print('derived', r.name(), file=sys.stderr)
    return rules


def describe_rule(r):
    lines = []
    what = 'edges' if r.edge else 'vertices'
    lines.append('%s: anchors are %s; uniform position %s; tangent %s' % (
        r.name(), what, fmt_mask(r.upos), fmt_mask(r.utan) if r.utan else 'undefined (zero)'))
    if not r.closed:
        for a, e in enumerate(r.end):
            if e is None:
                why = ('no full uniform stencil: outside the curve' if r.ends == 'none' else
                       'its limit is the end point (duplicate) or it lies outside the curve')
                lines.append('    end anchor %d: dropped (%s)' % (a, why))
            else:
                lines.append('    end anchor %d: position %s; tangent %s%s' % (
                    a, fmt_mask(e[0]), fmt_mask(e[1], r.irrational[a]) if e[1] else 'undefined (zero)',
                    ' [irrational]' if r.irrational[a] else ''))
        lines.append('    min_n %d (per-n masks below that)' % r.min_n)
    for nm, E in r.spectra:
        sp = ', '.join('%.6g' % z.real if abs(z.imag) < 1e-12 else '%.6g%+.6gi' % (z.real, z.imag)
                       for z in E.spectrum)
        lines.append('    %s: spectrum {%s}; subdominant %s' % (nm, sp, E.lam1_text))
    return lines


def fmt_mask(m, irr=False):
    if m is None:
        return '-'
    if irr:
        return '(' + ', '.join('L%d:%.9f' % (i, float(v)) for i, v in sorted(m.items())) + ')'
    return '(' + ', '.join('L%d:%s' % (i, v) for i, v in sorted(m.items())) + ')'


HEADER_DOC = r"""/*
 * pk_masks.h -- limit-point (evaluation) and tangent masks of every
 * subdivision scheme of the refinement kernel, for its --limit/--tangents
 * stage. GENERATED FILE, do not edit: regenerate with
 *
 *     python3 tests/tools/derive_masks.py --emit firmware
 *
 * (the same script re-derives every mask exactly and verifies it by brute
 * force: python3 tests/tools/derive_masks.py --verify).
 *
 * Derivation. One level of refinement is a linear map S: new points = S *
 * old points (S depends on the polygon size near the ends of open curves).
 * Follow one "anchor" from level to level: a vertex (odd degree, DLG) or an
 * edge (even degree) maps to the anchor at the same curve parameter on the
 * next level, index a -> sigma(a) (uniform B-spline: 2a - (D-1)/2 for
 * vertices, 2a - (D/2-1) for edges; DLG: 2a).
 *  - Uniform region: the local subdivision matrix of a window closed under S
 *    has the eigenvalues 1, 1/2, 1/4, ... (B-splines; DLG: 1, 1/2, 1/4, 1/4,
 *    1/8). The left eigenvector of 1 (sum 1) is the evaluation mask: A^k ->
 *    1 l0, so every point of the window converges to l0.P. The left
 *    eigenvector of the subdominant 1/2 is the tangent mask: the window
 *    points approach l0.P along l1.P (error ~ (lambda2/lambda1)^k). For the
 *    B-splines these are the cardinal B-spline and its derivative sampled at
 *    the knots (cubic (1,4,1)/6 and (-1,0,1)/2; quadratic: edge midpoint and
 *    edge direction; quintic (1,26,66,26,1)/120 ...); DLG: the vertex itself
 *    (interpolating) and (1,-8,0,8,-1)/12.
 *  - End of an open curve, stationary anchor (sigma(a) = a; the end point):
 *    the same eigen-analysis on the smallest window [L0..Lw-1] that S maps
 *    into itself. The end rules make these spectra differ: replace D=3
 *    {1, (5+sqrt5)/8, (5-sqrt5)/8} -- the subdominant eigenvalue is
 *    irrational, so the tangent mask is too and is stored as integers over
 *    2^24 (far below the 0.05 degree requirement). Replace D >= 4 have
 *    subdominant eigenvalues very close to 1 (the curve creeps towards L0).
 *  - Anchors near an end that are not stationary are followed along sigma
 *    until they reach a uniform or stationary anchor and that mask is pulled
 *    back through S (mask_a = mask_sigma(a) * S), e.g. DLG vertex 1.
 *    Anchors whose sigma-chain collapses into the end point (replace: vertex
 *    1 of the cubic) converge to the same limit point as anchor 0 and are
 *    dropped (drop_mask).
 *  - Clamped ends: the limit curve is the clamped B-spline itself; anchor a
 *    is evaluated at its Greville abscissa (odd D; vertex 1 of the clamped
 *    cubic is not stationary under refinement, its Greville abscissa 1/3
 *    moves towards 0 -- the mask is C(1/3), a point on the curve) or, for the
 *    clamped quadratic, at the knot where the curve touches edge a (edge 0:
 *    L0, tangent along L0L1). Cross-checked against the eigen-analysis.
 *  - Open `none` is exactly the uniform B-spline restricted to the anchors
 *    whose uniform stencil lies inside the polygon; the others are dropped.
 *  - Right ends are mirror images of left ends (checked: every open S is
 *    reversal-symmetric): value = sum_r w[r] * L[n-1-(a+first+r)] for the
 *    anchor a counted from the right end (vertex n-1-a, or edge n-2-a joining
 *    L[n-2-a] and L[n-1-a]); tangent weights negated.
 *  - Short polygons (n < min_n) get their own per-n masks (pk_limit_small_get),
 *    derived by following the refinement (which may grow, keep or shrink
 *    such a polygon) until the standard rules apply or the polygon becomes
 *    stationary; their slots are output positions 0..A-1 in polygon order.
 *  - Degree 1: the limit is the polygon; the tangent at an interior vertex
 *    (a corner) is undefined and given as an empty mask (len 0: output a
 *    zero tangent); at an open end it is the one-sided L1-L0.
 *
 * Weight bounds: every |w| < 2^31 and sum |w| <= PK_MASK_ABS_SUM_MAX. The
 * kernel applies the masks to exact level-K points (pk_umf_t, N / 2^F) and
 * drops fraction bits first only where the sum could leave int64_t.
 * Position masks are exact (den > 0, sum w = den). Tangent masks sum to 0
 * exactly (straight lines give exact tangents); only their direction counts.
 * Rational tangent masks are normalised to give exactly +1 on L_j = j (the
 * derivative along the polygon index; uniform cubic (-1,0,1)/2), so den is
 * that rational's denominator; irrational ones have den = 2^24 and positive
 * weights summing to 2^24 (each rounded to nearest, the largest adjusted so
 * that the sum stays 0). Tangents point forward (towards higher indices).
 *
 * Per-rule summary (generated):
"""


def rule_guard(key):
    """The preprocessor condition under which rule `key` is built (pk_refine.h)."""
    scheme, D, closed, ends = key
    what = 'PK_BUILD_DLG' if scheme == 1 else '(PK_BUILD_DEGREES & 0x%02x)' % (1 << D)
    where = 'PK_BUILD_CLOSED' if closed else ('1' if scheme == 1 else '(PK_BUILD_ENDS & 0x%02x)' % (1 << ends))
    return '#if %s && %s' % (what, where)


def blob_mask(e):
    """The words of one encoded mask: header (first | len << 8 | den << 16,
    den 0 meaning 2^24), then the weights."""
    first, ln, den, w = e
    if den == Q24:
        d16 = 0
    else:
        assert 0 < den < 65536, den
        d16 = den
    assert -128 <= first < 128 and ln < 128
    h = (first & 0xFF) | (ln << 8) | (d16 << 16)
    if h >= 2 ** 31:
        h -= 2 ** 32
    return [h] + list(w)


def c_words(words):
    return ', '.join(str(x) if x != -2 ** 31 else '(-2147483647 - 1)' for x in words)


C_LOOKUPS = """/* Decode the mask whose header word is at p (program memory). */
static const int32_t *mask_decode(const int32_t *p, struct pk_mask *m)
{
    uint32_t h = (uint32_t)PK_ROM_I32(p);
    uint32_t den = h >> 16;
    m->first = (int8_t)(uint8_t)(h & 0xFFu);
    m->len = (uint8_t)((h >> 8) & 0xFFu);
    m->den = den ? (int32_t)den : (int32_t)PK_MASK_Q24;
    m->w = p + 1;
    return p + 1 + m->len;
}

const int32_t *pk_limit_rule_get(unsigned scheme, unsigned degree, unsigned closed, unsigned ends)
{
    if (scheme == 1u) {
        degree = 0u;
        ends = 0u;
    }
    closed = closed ? 1u : 0u;
    if (closed)
        ends = 0u;
    for (const struct pk_rule_entry *e = pk_rules; PK_ROM_U8(&e->scheme) != 255u; e++)
        if (PK_ROM_U8(&e->scheme) == scheme && PK_ROM_U8(&e->degree) == degree &&
            PK_ROM_U8(&e->closed) == closed && PK_ROM_U8(&e->ends) == ends)
            return pk_words + PK_ROM_U16(&e->off);
    return NULL;
}

void pk_limit_rule_info(const int32_t *rule, struct pk_rule_info *info)
{
    uint32_t w = (uint32_t)PK_ROM_I32(rule);
    info->edge_anchors = (uint8_t)(w & 0xFFu);
    info->nend = (uint8_t)((w >> 8) & 0xFFu);
    info->drop_mask = (uint8_t)((w >> 16) & 0xFFu);
    info->min_n = (uint8_t)(w >> 24);
}

void pk_limit_rule_mask(const int32_t *rule, unsigned which, struct pk_mask *m)
{
    const int32_t *p = rule + 1;
    do
        p = mask_decode(p, m);
    while (which-- > 0u);
}

int pk_limit_small_get(unsigned scheme, unsigned degree, unsigned ends, unsigned n, unsigned anchor,
                       unsigned tangent, struct pk_mask *m)
{
    if (scheme == 1u) {
        degree = 0u;
        ends = 0u;
    }
    for (const struct pk_small_entry *e = pk_smalls; PK_ROM_U8(&e->scheme) != 255u; e++) {
        if (PK_ROM_U8(&e->scheme) != scheme || PK_ROM_U8(&e->degree) != degree ||
            PK_ROM_U8(&e->ends) != ends || PK_ROM_U8(&e->n) != n)
            continue;
        const int32_t *p = pk_words + PK_ROM_U16(&e->off);
        if (anchor >= (uint32_t)PK_ROM_I32(p))
            return 0;
        p++;
        for (unsigned a = 0;; a++) {
            int dropped = PK_ROM_I32(p) == -1;
            if (a == anchor) {
                if (dropped)
                    return 0;
                p = mask_decode(p, m);
                if (tangent)
                    (void)mask_decode(p, m);
                return 1;
            }
            if (dropped) {
                p++;
            } else {
                p = mask_decode(p, m);
                p = mask_decode(p, m);
            }
        }
    }
    return 0;
}"""

H_API = """/** One mask, as read from the tables: value = sum_r w(r) * L[anchor + first + r] / den. */
struct pk_mask {
    int8_t first;              /**< index of w[0] relative to the anchor (e.g. -1) */
    uint8_t len;               /**< number of weights (0: undefined tangent: output zero) */
    int32_t den;               /**< > 0. Position masks: exact, sum w = den. Tangent masks:
                                    direction only (sum w = 0); den is the exact rational's
                                    denominator, or 1<<24 if irrational (w rounded) */
    const int32_t *w;          /**< the len weights, in program memory: read with pk_mask_w */
};

/** Weight k of mask m. */
static inline int32_t pk_mask_w(const struct pk_mask *m, unsigned k)
{
    return PK_ROM_I32(&m->w[k]);
}

/** The fixed part of a limit rule. */
struct pk_rule_info {
    uint8_t edge_anchors;      /**< 1: anchors are edges (even D), 0: vertices */
    uint8_t nend;              /**< anchors 0..nend-1 from each end use their own masks */
    uint8_t drop_mask;         /**< bit a set: end anchor a (from either end) is dropped (duplicate limit point) */
    uint8_t min_n;             /**< smallest polygon size for which uniform + end masks are valid without overlap */
};

/**
 * Limit rule lookup. scheme 0 = B-spline (degree 1..7), 1 = DLG (degree
 * ignored); ends 1 clamped, 2 replace, 3 none (open only; DLG ignores it);
 * closed ignores ends. Closed rules have nend 0 and min_n 1: apply the
 * uniform masks at every anchor with indices taken modulo n (weights of a
 * stencil wider than n wrap more than once).
 * @return the rule (an opaque table in program memory), or NULL if that
 *         combination does not exist or is not built (PK_BUILD_*).
 * Calling context: any (pure table lookup).
 */
const int32_t *pk_limit_rule_get(unsigned scheme, unsigned degree, unsigned closed, unsigned ends);

/** The rule's fixed part. */
void pk_limit_rule_info(const int32_t *rule, struct pk_rule_info *info);

/**
 * Mask `which` of a rule: 0 uniform position, 1 uniform tangent, 2 + a the
 * position mask of end anchor a (a < 4; the left end, the right end is its
 * mirror image), 6 + a its tangent mask.
 */
void pk_limit_rule_mask(const int32_t *rule, unsigned which, struct pk_mask *m);

/**
 * Masks for a short open polygon, n < min_n. Slots 0..A-1 (A = the anchor
 * count: n vertices, or n-1 edges for even D; but A = n when n <= 2, where
 * the polygon's end points are the outputs) are output positions in polygon
 * order; call for every slot and emit the ones that exist in order. first
 * is relative to the slot.
 * @param tangent 0: position mask, 1: tangent mask (len 0: zero tangent)
 * @return 1 with *m filled, or 0: slot dropped / not derived / not built.
 * Calling context: any (pure table lookup).
 */
int pk_limit_small_get(unsigned scheme, unsigned degree, unsigned ends, unsigned n, unsigned anchor,
                       unsigned tangent, struct pk_mask *m);

#endif"""


def emit(outdir, rules):
    rule_rows, small_rows = [], []
    abs_max = 0
    for r in rules:
        key = rule_key(r)
        up = enc(r.upos, 0)
        ut = enc(r.utan, 0, primitive=True)
        pe, te, drop = [], [], 0
        for a, e in enumerate(r.end):
            if e is None:
                drop |= 1 << a
                pe.append(enc(None, a))
                te.append(enc(None, a))
            else:
                pe.append(enc(e[0], a))
                te.append(enc(e[1], a, r.irrational[a], primitive=not r.irrational[a]))
        assert len(pe) <= 4
        while len(pe) < 4:
            pe.append(enc(None, 0))
            te.append(enc(None, 0))
        for e in [up, ut] + pe + te:
            abs_max = max(abs_max, sum(abs(x) for x in e[3]))
        info = (1 if r.edge else 0) | (len(r.end) << 8) | (drop << 16) | (r.min_n << 24)
        words = [info]
        for e in [up, ut] + pe + te:
            words += blob_mask(e)
        rule_rows.append((key, r, words))
        for n in sorted(r.small):
            slots = r.small[n]
            sw = [len(slots)]
            for a, sl in enumerate(slots):
                if sl is None:
                    sw.append(-1)
                    continue
                irr = sl[1] is not None and any(v.denominator > 2 ** 40 for v in sl[1].values())
                ep, et = enc(sl[0], a), enc(sl[1], a, irr, primitive=not irr)
                for e in (ep, et):
                    abs_max = max(abs_max, sum(abs(x) for x in e[3]))
                sw += blob_mask(ep) + blob_mask(et)
            small_rows.append((key, n, sw))
    # ---- header ----
    h = [HEADER_DOC.rstrip('\n')]
    for r in rules:
        for line in describe_rule(r):
            h.append(' *   ' + line)
    h.append(' */')
    h.append('#ifndef PLOTKIN_PK_MASKS_H\n#define PLOTKIN_PK_MASKS_H\n\n#include <stdint.h>\n#include "pk_rom.h"\n')
    h.append('/** Most weights in one mask. */\n#define PK_MASK_MAXLEN %d' % MAXLEN)
    h.append('/** Largest sum of |w| over any mask in the tables. */\n'
             '#define PK_MASK_ABS_SUM_MAX %dL' % abs_max)
    h.append('/** Denominator of the irrational (rounded) tangent masks. */\n'
             '#define PK_MASK_Q24 (1L << 24)\n')
    h.append(H_API)
    with open(os.path.join(outdir, 'pk_masks.h'), 'w') as f:
        f.write('\n'.join(h) + '\n')
    # ---- source ----
    c = ['/*', ' * pk_masks.c -- GENERATED by tests/tools/derive_masks.py --emit firmware;',
         ' * do not edit. Constant tables and their lookups (see pk_masks.h).', ' *',
         ' * All rules live in one array of 32-bit words in program memory (PK_ROM):',
         ' * per rule its fixed part, then its ten masks, each a header word (first,',
         ' * len, den) followed by its weights; per short-polygon set its slot count,',
         ' * then per slot its position and tangent masks (-1: dropped). A rule is',
         ' * compiled in only if its scheme, degree, end rule (or closed curves) and the',
         ' * table-driven limit stage are built (PK_BUILD_*, PK_LIMIT_TABLES in',
         ' * pk_refine.h): its PK_SZ_ is then its length, else 0, and the index tables',
         ' * hold word offsets (no pointers: nothing to relocate, nothing in RAM).',
         ' */', '#include <stddef.h>', '#include "pk_refine.h"', '#include "pk_masks.h"', '']
    blobs = []  # (guard, name, words, kind, key, n)
    for key, r, words in rule_rows:
        nm = r.name().replace(':', '').replace(' ', '_')
        blobs.append((rule_guard(key), nm, words, 'rule', key, 0))
    for key, n, sw in small_rows:
        nm = [b[1] for b in blobs if b[3] == 'rule' and b[4] == key][0] + '_n%d' % n
        blobs.append((rule_guard(key), nm, sw, 'small', key, n))
    for g, nm, words, kind, key, n in blobs:
        c.append('%s && PK_LIMIT_TABLES\n#define PK_SZ_%s %d\n#else\n#define PK_SZ_%s 0\n#endif' % (g, nm, len(words), nm))
    c.append('\nenum {')
    prev = None
    for g, nm, words, kind, key, n in blobs:
        c.append('    PK_OFF_%s = %s,' % (nm, '0' if prev is None else 'PK_OFF_%s + PK_SZ_%s' % (prev, prev)))
        prev = nm
    c.append('    PK_WORDS = PK_OFF_%s + PK_SZ_%s\n};\n' % (prev, prev))
    c.append('static const int32_t pk_words[PK_WORDS + 1] PK_ROM = {')
    for g, nm, words, kind, key, n in blobs:
        c.append('%s && PK_LIMIT_TABLES' % g)
        c.append('    /* %s */ %s,' % (nm, c_words(words)))
        c.append('#endif')
    c.append('    0 /* never empty */\n};\n')
    c.append('struct pk_rule_entry {\n    uint8_t scheme, degree, closed, ends;\n    uint16_t off;\n};\n')
    c.append('static const struct pk_rule_entry pk_rules[] PK_ROM = {')
    for g, nm, words, kind, key, n in blobs:
        if kind == 'rule':
            c.append('%s && PK_LIMIT_TABLES' % g)
            c.append('    {%d, %d, %d, %d, PK_OFF_%s},' % (key + (nm,)))
            c.append('#endif')
    c.append('    {255, 0, 0, 0, 0}\n};\n')
    c.append('struct pk_small_entry {\n    uint8_t scheme, degree, ends, n;\n    uint16_t off;\n};\n')
    c.append('static const struct pk_small_entry pk_smalls[] PK_ROM = {')
    for g, nm, words, kind, key, n in blobs:
        if kind == 'small':
            c.append('%s && PK_LIMIT_TABLES' % g)
            c.append('    {%d, %d, %d, %d, PK_OFF_%s},' % (key[0], key[1], key[3], n, nm))
            c.append('#endif')
    c.append('    {255, 0, 0, 0, 0}\n};\n')
    c.append(C_LOOKUPS)
    with open(os.path.join(outdir, 'pk_masks.c'), 'w') as f:
        f.write('\n'.join(c) + '\n')
    nwords = sum(len(b[2]) for b in blobs)
    assert nwords < 65536
    print('wrote %s/pk_masks.[ch]: %d rules, %d small sets, %d words of tables (%d bytes); max sum|w| %d' % (
        outdir, len(rule_rows), len(small_rows), nwords, 4 * nwords, abs_max))


# --------------------------------------------------------------------------
# Applying the emitted tables exactly as the kernel must (reference for the
# lead's code), and brute-force verification.
# --------------------------------------------------------------------------

def tables_of(r):
    """The encoded masks of rule r (what pk_masks.c holds)."""
    t = {'edge': r.edge, 'closed': r.closed, 'min_n': r.min_n,
         'up': enc(r.upos, 0),
         'ut': enc(r.utan, 0, primitive=True),
         'end': [], 'small': {}}
    for a, e in enumerate(r.end):
        if e is None:
            t['end'].append(None)
        else:
            t['end'].append((enc(e[0], a), enc(e[1], a, r.irrational[a], primitive=not r.irrational[a])))
    for n, slots in r.small.items():
        out = []
        for a, s in enumerate(slots):
            if s is None:
                out.append(None)
            else:
                irr = s[1] is not None and any(v.denominator > 2 ** 40 for v in s[1].values())
                out.append((enc(s[0], a), enc(s[1], a, irr, primitive=not irr)))
        t['small'][n] = out
    return t


def apply_enc(e, L, anchor, right=False, tangent=False, modn=None):
    """Sum of an encoded mask over the points L (tuples), exact Fractions."""
    first, ln, den, w = e
    dim = len(L[0])
    if ln == 0:
        return None
    n = len(L)
    acc = [Fr(0)] * dim
    for r in range(ln):
        i = anchor + first + r
        if modn:
            i %= modn
        elif right:
            i = n - 1 - i
        for k in range(dim):
            acc[k] += w[r] * Fr(L[i][k])
    if right and tangent:
        acc = [-v for v in acc]
    return tuple(v / den for v in acc)


def limit_outputs(t, L):
    """[(anchor or slot, point, tangent)] for the polygon L, kernel-style."""
    n = len(L)
    out = []
    if n == 0:
        return out
    if t['closed']:
        for a in range(n):
            out.append((a, apply_enc(t['up'], L, a, modn=n), apply_enc(t['ut'], L, a, tangent=True, modn=n)))
        return out
    if n < t['min_n']:
        for a, s in enumerate(t['small'][n]):
            if s is not None:
                out.append((a, apply_enc(s[0], L, a), apply_enc(s[1], L, a, tangent=True)))
        return out
    A = n - 1 if t['edge'] else n
    ne = len(t['end'])
    for a in range(A):
        if a < ne:
            e = t['end'][a]
            if e is not None:
                out.append((a, apply_enc(e[0], L, a), apply_enc(e[1], L, a, tangent=True)))
        elif A - 1 - a < ne:
            b = A - 1 - a
            e = t['end'][b]
            if e is not None:
                out.append((a, apply_enc(e[0], L, b, right=True), apply_enc(e[1], L, b, right=True, tangent=True)))
        else:
            out.append((a, apply_enc(t['up'], L, a), apply_enc(t['ut'], L, a, tangent=True)))
    return out


def seg_dist(p, a, b):
    ab = [y - x for x, y in zip(a, b)]
    ap = [y - x for x, y in zip(a, p)]
    l2 = sum(v * v for v in ab)
    s = 0.0 if l2 == 0 else max(0.0, min(1.0, sum(u * v for u, v in zip(ab, ap)) / l2))
    q = [x + s * v for x, v in zip(a, ab)]
    return math.dist(p, q)


def poly_dist(p, P, closed):
    if len(P) == 1:
        return math.dist(p, P[0]), 0
    best = (float('inf'), 0)
    m = len(P) if closed else len(P) - 1
    for i in range(m):
        d = seg_dist(p, P[i], P[(i + 1) % len(P)])
        if d < best[0]:
            best = (d, i)
    return best


def angle(u, v):
    nu, nv = math.hypot(*u), math.hypot(*v)
    if nu == 0 or nv == 0:
        return float('nan')
    u = [a / nu for a in u]
    v = [a / nv for a in v]
    dot = sum(a * b for a, b in zip(u, v))
    if len(u) == 2:
        cr2 = (u[0] * v[1] - u[1] * v[0]) ** 2
    else:
        cr2 = ((u[1] * v[2] - u[2] * v[1]) ** 2 + (u[2] * v[0] - u[0] * v[2]) ** 2 +
               (u[0] * v[1] - u[1] * v[0]) ** 2)
    return math.degrees(math.atan2(math.sqrt(cr2), dot))


def exact_parallel(u, v):
    """u and v (Fractions) point the same way exactly."""
    d = len(u)
    cross0 = all(u[i] * v[j] == u[j] * v[i] for i in range(d) for j in range(i + 1, d))
    return cross0 and sum(a * b for a, b in zip(u, v)) > 0


def chord_at(P, i, closed, p):
    """Direction of the refined polygon at its segment i (nearest to p)."""
    n = len(P)
    a, b = P[i], P[(i + 1) % n]
    return [y - x for x, y in zip(a, b)]


def rand_poly(rng, n, dim=2, lim=2 ** 20):
    return [tuple(rng.randint(-lim, lim) for _ in range(dim)) for _ in range(n)]


def verify_rule(r, rng, report):
    t = tables_of(r)
    sizes = [3, 4, 5, 9, 13] if r.closed else sorted(set(list(range(1, r.min_n + 3)) + [12]))
    worst_d = worst_a = 0.0
    ok = True
    cnt = 0
    for n in sizes:
        for trial in range(2):
            P = rand_poly(rng, n)
            outs = limit_outputs(t, P)
            Pf = [tuple(float(v) for v in p) for p in P]
            hist = [Pf]
            while len(hist) < 13 and len(hist[-1]) < 2000:
                hist.append(refine_pts(hist[-1], r.scheme, r.D, r.closed, r.ends))
            if len(hist[-1]) == len(hist[-2]) and len(hist[-1]) > 2:
                # a stationary short polygon: the limit is lim S^k (converges
                # slowly for replace D >= 4): take S^(2^48) by repeated squaring
                S = [[float(v) for v in row] for row in smatrix(len(hist[-1]), r.scheme, r.D, r.closed, r.ends)]
                for _ in range(48):
                    S = [[sum(S[i][k] * S[k][j] for k in range(len(S))) for j in range(len(S))] for i in range(len(S))]
                    S = [[v / sum(row) for v in row] for row in S]    # rows sum to 1 exactly
                Z = [tuple(sum(S[i][k] * hist[-1][k][c] for k in range(len(S))) for c in range(len(Pf[0])))
                     for i in range(len(S))]
                hist += [Z, Z, Z]
            levels = len(hist) - 1
            deep = {levels - 2: hist[-3], levels: hist[-1]}
            diam = max(math.dist(a, b) for a in Pf for b in Pf) or 1.0
            last_idx = -1
            for a, p, tg in outs:
                pf = [float(v) for v in p]
                d2, i2 = poly_dist(pf, deep[levels - 2], r.closed)
                d, i = poly_dist(pf, deep[levels], r.closed)
                good = d <= 1e-9 * diam or (d <= 1e-2 * diam and d <= d2 / 2.5)
                ang = ang2 = 0.0
                if tg is not None and len(deep[levels]) > 1:
                    tf = [float(v) for v in tg]
                    ang = angle(tf, chord_at(deep[levels], i, r.closed, pf))
                    ang2 = angle(tf, chord_at(deep[levels - 2], i2, r.closed, pf))
                    dd = deep[levels]
                    seglen = math.dist(dd[i], dd[(i + 1) % len(dd)])
                    if seglen > 1e-9 * diam:
                        tgood = ang < 1e-6 or (ang <= ang2 / 1.8 and ang < 15) or ang < 0.01
                        good = good and tgood
                        worst_a = max(worst_a, ang)
                if not r.closed:
                    # outputs in curve order
                    pos_along = i + (seg_dist(pf, dd[i], dd[i]) if False else 0)
                    if i < last_idx:
                        good = False
                    last_idx = i
                worst_d = max(worst_d, d / diam)
                cnt += 1
                if not good:
                    ok = False
                    report.append('  FAIL %s n=%d anchor %d: dist %.3g (prev %.3g) angle %.4g (prev %.4g) deg' % (
                        r.name(), n, a, d, d2, ang, ang2 if tg is not None else 0))
            if not r.closed and n >= 2 and outs:
                # the refined polygon's ends converge to the first / last output
                f0 = [float(v) for v in outs[0][1]]
                f1 = [float(v) for v in outs[-1][1]]
                e0 = math.dist(f0, deep[levels][0])
                e1 = math.dist(f1, deep[levels][-1])
                e0p = math.dist(f0, deep[levels - 2][0])
                if not (e0 <= 1e-9 * diam or (e0 < 1e-2 * diam and e0 < e0p / 1.5)) or \
                   not (e1 <= 1e-9 * diam or e1 < 1e-2 * diam):
                    ok = False
                    report.append('  FAIL %s n=%d: curve ends not covered (%.3g, %.3g)' % (r.name(), n, e0, e1))
    return ok, cnt, worst_d, worst_a


def verify_all(rules, seed=1):
    rng = random.Random(seed)
    report = []
    allok = True
    print('Brute force: random polygons of every short size and n=12, refined exactly in\n'
          'floating point to ~2000 points (stationary short polygons: lim S^k by squaring).\n'
          'dist: distance of each claimed limit point to the refined polygon / diameter, must\n'
          'shrink >= 2.5x per 2 levels; angle: claimed tangent vs the refined polygon\'s segment\n'
          'at that point, must shrink >= 1.8x per 2 levels (or be < 0.01 deg); outputs must be\n'
          'in curve order and the refined polygon\'s ends must converge to the first/last output.')
    print('%-22s %7s %5s %5s %5s %13s %13s  %s' % ('rule', 'checks', 'nend', 'drop', 'min_n',
                                                 'max dist/diam', 'chord angle', 'result'))
    for r in rules:
        ok, cnt, wd, wa = verify_rule(r, rng, report)
        allok &= ok
        print('%-22s %7d %5d %5s %5d %12.3g %10.4g deg  %s' % (
            r.name(), cnt, len(r.end), ''.join(str(a) for a, e in enumerate(r.end) if e is None) or '-',
            r.min_n, wd, wa, 'ok' if ok else 'FAIL'))
    for line in report:
        print(line)
    # mirror symmetry of every open S
    for r in rules:
        if not r.closed and not r.reversal_symmetric:
            print('  FAIL %s: S not reversal-symmetric' % r.name())
            allok = False
    return allok



# --------------------------------------------------------------------------
# Reference vectors, computed independently of the mask tables: de Boor
# evaluation of the (uniform, periodic or clamped) B-spline at the anchor's
# parameter, exact fixed points of stationary short polygons, and for the
# tangents that no closed form gives (DLG, replace end points) the direction
# of a chord of the polygon refined 50 levels deep around the anchor (exact
# refinement of a window; decimal output).
# --------------------------------------------------------------------------

DEEP_LEVELS = 50


def coord(L, k):
    return [p[k] for p in L]


def uniform_eval(ctrl, D, t, deriv=False):
    """Uniform B-spline, control values ctrl[0..], knots 0,1,2,..., at t."""
    z = 0 * ctrl[0]
    ctrl = [z] * (D + 1) + list(ctrl) + [z] * (D + 1)   # zero padding: no contribution
    T = [Fr(i) for i in range(len(ctrl) + D + 1)]
    return bspline_eval_knots(ctrl, T, D, Fr(t) + D + 1, deriv)


def ref_uniform(L, D, a, closed):
    """Exact (pos, tan) of the uniform degree-D spline at anchor a of L."""
    n = len(L)
    dim = len(L[0])
    if closed:
        R = D + 2
        ctrl = [L[(a + r) % n] for r in range(-R, R + 1)]
        idx = R
    else:
        ctrl = L
        idx = a
    t = idx + (Fr(D + 1, 2) if D % 2 else Fr(D, 2) + 1)
    pos = tuple(uniform_eval(coord(ctrl, k), D, t) for k in range(dim))
    tan = tuple(uniform_eval(coord(ctrl, k), D, t, True) for k in range(dim)) if D >= 2 else None
    return pos, tan


def ref_clamped(L, D, a):
    n = len(L)
    dim = len(L[0])
    if n <= D:      # too few points: one level at degree n-1 first
        L2 = refine_pts(L, 'bspline', D, False, 'clamped')
        T = clamped_knots(len(L2), D)
        u = Fr(a, n - 1) * (len(L2) - D)
        ctrl = L2
    else:
        T, par = clamped_params(n, D)
        u = par[a]
        ctrl = L
    pos = tuple(bspline_eval_knots(coord(ctrl, k), T, D, u) for k in range(dim))
    if D >= 2:
        tan = tuple(bspline_eval_knots(coord(ctrl, k), T, D, u, True) for k in range(dim))
    elif a == 0:
        tan = tuple(L[1][k] - L[0][k] for k in range(dim))
    elif a == n - 1:
        tan = tuple(L[-1][k] - L[-2][k] for k in range(dim))
    else:
        tan = None
    return pos, tan


def deep_chord(L, r, a, closed):
    """Tangent direction (floats) at vertex a of L, from a window refined
    DEEP_LEVELS levels exactly. DLG: symmetric chord around vertex a's
    descendant (2^J a); replace: the chord L1 - L0 at the end point."""
    n = len(L)
    R = 10
    if r.scheme == 'dlg':
        if closed:
            W = [L[(a + k) % n] for k in range(-R, R + 1)]
            lo, d = -R, 0   # window covers global index d+lo.. ; descendant at window index R
            c = R
            for _ in range(DEEP_LEVELS):
                W2 = refine_pts(W, 'dlg', 0, False, None)
                c = 2 * c
                W = W2[c - R:c + R + 1]
                c = R
            P0, P1 = W[c - 1], W[c + 1]
        else:
            o = max(0, a - R)
            W = L[o:a + R + 1]
            c = a - o
            genuine_l, genuine_r = o == 0, a + R + 1 >= n
            for _ in range(DEEP_LEVELS):
                W2 = refine_pts(W, 'dlg', 0, False, None)
                c2 = 2 * c
                lo = 0 if genuine_l else 3
                hi = len(W2) if genuine_r else len(W2) - 3
                s0 = max(lo, c2 - R)
                s1 = min(hi, c2 + R + 1)
                genuine_l = genuine_l and s0 == 0
                genuine_r = genuine_r and s1 == len(W2)
                W = W2[s0:s1]
                c = c2 - s0
            if c == 0:
                P0, P1 = W[0], W[1]
            elif c == len(W) - 1:
                P0, P1 = W[-2], W[-1]
            else:
                P0, P1 = W[c - 1], W[c + 1]
        return [float(y - x) for x, y in zip(P0, P1)]
    # replace end point: left end a == 0, right end via reversal
    assert r.ends == 'replace'
    if a == n - 1:
        t = deep_chord(list(reversed(L)), r, 0, closed)
        return [-v for v in t]
    assert a == 0
    W = L[:2 * R]
    for _ in range(DEEP_LEVELS):
        W = refine_pts(W, 'bspline', r.D, False, 'replace')[:2 * R]
    return [float(y - x) for x, y in zip(W[0], W[1])]


def static_fixed_point(L, r):
    """Limit points of a short replace polygon that refinement maps to the same
    size: the fixed point x = S x with both end points kept."""
    n = len(L)
    S = smatrix(n, r.scheme, r.D, False, r.ends)
    # interior unknowns 1..n-2: x_i - sum_{j interior} S_ij x_j = S_i0 x_0 + S_i,n-1 x_n-1
    M = [[(1 if i == j else 0) - S[i][j] for j in range(1, n - 1)] for i in range(1, n - 1)]
    out = [L[0]]
    cols = []
    for k in range(len(L[0])):
        rhs = [S[i][0] * L[0][k] + S[i][n - 1] * L[-1][k] for i in range(1, n - 1)]
        cols.append(solve(M, rhs))
    for i in range(n - 2):
        out.append(tuple(c[i] for c in cols))
    return out + [L[-1]]


def ref_limit(r, L):
    """Independent reference: list of (pos, tan, tan_is_decimal)."""
    n = len(L)
    dim = len(L[0]) if L else 2
    if n == 0:
        return []
    if n == 1:
        return [(L[0], None, False)]
    if r.closed:
        out = []
        for a in range(n):
            if r.scheme == 'dlg':
                out.append((L[a], deep_chord(L, r, a, True), True))
            else:
                p, t = ref_uniform(L, r.D, a, True)
                out.append((p, t, False))
        return out
    if n == 2:
        t = tuple(L[1][k] - L[0][k] for k in range(dim))
        return [(L[0], t, False), (L[1], t, False)]
    if r.ends == 'clamped':
        return [ref_clamped(L, r.D, a) + (False,) for a in range(r.nanchors(n) if n > r.D else n)]
    if r.scheme == 'dlg':
        return [(L[a], deep_chord(L, r, a, False), True) for a in range(n)]
    # none / replace
    n2 = len(refine1([0] * n, 'bspline', r.D, False, r.ends))
    if n2 < n:
        # shrinking: follow the exact refinement until it stops changing size
        return ref_limit(r, refine_pts(L, 'bspline', r.D, False, r.ends))
    if n2 == n and r.ends == 'replace':
        pts = static_fixed_point(L, r)
        uniq = []
        for p in pts:
            if p not in uniq:
                uniq.append(p)
        if len(uniq) > r.nanchors(n):       # even D: n-1 output slots (README)
            uniq = uniq[:r.nanchors(n) - 1] + uniq[-1:]
        out = []
        for k, p in enumerate(uniq):
            a, b = uniq[max(k - 1, 0)], uniq[min(k + 1, len(uniq) - 1)]
            out.append((p, tuple(y - x for x, y in zip(a, b)), False))
        return out
    out = []
    A = r.nanchors(n)
    h = (r.D - 1) // 2 if r.D % 2 else r.D // 2 - 1
    for a in range(A):
        full = h <= a <= A - 1 - h
        if r.ends == 'replace':
            if a == 0 or a == A - 1:
                v = 0 if a == 0 else n - 1
                if r.D == 1:
                    t = tuple(L[1][k] - L[0][k] for k in range(dim)) if a == 0 else \
                        tuple(L[-1][k] - L[-2][k] for k in range(dim))
                    out.append((L[v], t, False))
                else:
                    out.append((L[v], deep_chord(L, r, v, False), True))
                continue
            if not (h + 1 <= a <= A - 2 - h):
                continue
        elif not full:
            continue
        p, t = ref_uniform(L, r.D, a, False)
        if r.D == 1 and r.ends == 'none' and a in (0, A - 1):
            t = tuple(L[1][k] - L[0][k] for k in range(dim)) if a == 0 else \
                tuple(L[-1][k] - L[-2][k] for k in range(dim))
        out.append((p, t, False))
    return out


def fmt_fr(v):
    v = Fr(v)
    return str(v.numerator) if v.denominator == 1 else '%d/%d' % (v.numerator, v.denominator)


def fmt_dec(t):
    nrm = math.sqrt(sum(x * x for x in t))
    if nrm == 0:
        return ['0'] * len(t)
    return ['%.12g' % (x / nrm) for x in t]


VECTOR_CASES = (
    [(('bspline', D, False, e), m, k, 2 + (m + k) % 2)
     for D in (2, 3) for e in ('none', 'replace', 'clamped') for m in (2, 3, 4, 5, 7) for k in range(4)] +
    [(('dlg', 0, False, None), m, k, 2 + (m + k) % 2) for m in (2, 3, 4, 5, 7) for k in range(4)] +
    [(('dlg', 0, True, None), m, k, 2 + (m + k) % 2) for m in (3, 4, 5, 7) for k in range(4)] +
    [(('bspline', D, True, None), m, k, 2 + (m + k + D) % 2) for D in (1, 4, 5, 7) for m in (3, 4, 7)
     for k in range(4)] +
    # the rest of the table: every other open rule (replace D=7 left out: its end
    # tangent spans L0..L6, wider than the kernel's PK_LWIN = 8 window allows
    # together with the uniform stencil; derive_masks.py still derives it)
    [(('bspline', D, False, e), m, k, 2 + (m + k) % 2)
     for D in (1, 4, 5, 6, 7) for e in ('none', 'replace') if (D, e) != (7, 'replace')
     for m in (2, 3, 4, 5, 7, 9) for k in range(3)] +
    [(('bspline', 1, False, 'clamped'), m, k, 2) for m in (2, 3, 5) for k in range(3)] +
    [(('bspline', 6, True, None), m, k, 2 + (m + k) % 2) for m in (3, 4, 7) for k in range(3)])


def write_vectors(outdir, rules, seed=20261122):
    rng = random.Random(seed)
    byname = {(r.scheme, r.D, r.closed, r.ends): r for r in rules}
    os.makedirs(os.path.join(outdir, 'cases'), exist_ok=True)
    ok = True
    count = 0
    worst = 0.0
    for key, m, depth, dim in VECTOR_CASES:
        r = byname[key]
        P = rand_poly(rng, m, dim)
        L = refine_pts([tuple(Fr(v) for v in p) for p in P], r.scheme, r.D, r.closed, r.ends, depth)
        ref = ref_limit(r, L)
        # cross-check against the tables (the kernel's path)
        got = limit_outputs(tables_of(r), L)
        if len(got) != len(ref):
            print('VECTOR MISMATCH %s m=%d depth %d: %d outputs vs %d' % (r.name(), m, depth, len(got), len(ref)))
            ok = False
        else:
            def canon(seq):
                return [p for p in seq]
            gp = [g[1] for g in got]
            rp = [tuple(Fr(v) for v in x[0]) for x in ref]
            if not (rot_equal(gp, rp) if r.closed else gp == rp):
                print('VECTOR MISMATCH %s m=%d depth %d: positions differ' % (r.name(), m, depth))
                ok = False
            for g, x in zip(got, ref):
                if (g[2] is None) != (x[1] is None):
                    print('VECTOR MISMATCH %s m=%d depth %d: tangent presence' % (r.name(), m, depth))
                    ok = False
                elif g[2] is not None and not x[2]:
                    if not exact_parallel(g[2], x[1]):
                        print('VECTOR MISMATCH %s m=%d depth %d: exact tangent differs' % (r.name(), m, depth))
                        ok = False
                elif g[2] is not None:
                    an = angle([float(v) for v in g[2]], [float(v) for v in x[1]])
                    worst = max(worst, an)
                    if not an < 1e-5:   # irrational masks are rounded to 2^-24
                        print('VECTOR MISMATCH %s m=%d depth %d: tangent %.3g deg' % (r.name(), m, depth, an))
                        ok = False
        dec = any(x[2] for x in ref)
        sname = 'dlg' if r.scheme == 'dlg' else ('chaikin' if r.D == 2 else 'bspline%d' % r.D)
        ends = 'closed' if r.closed else (r.ends or 'open')
        fn = 'limit_%s_%s_m%d_d%d.txt' % (sname, ends, m, depth)
        lines = ['scheme %s' % ('dlg' if r.scheme == 'dlg' else ('chaikin' if r.D == 2 else 'bspline:%d' % r.D)),
                 'ends %s' % (r.ends or 'clamped'), 'closed %d' % (1 if r.closed else 0),
                 'depth %d' % depth, 'dim %d' % dim, 'limit 1']
        if dec:
            lines.append('tangent_decimal 1')
        lines.append('input %d' % m)
        lines += [' '.join(str(v) for v in p) for p in P]
        lines.append('output %d' % len(ref))
        for p, t, isdec in ref:
            if t is None:
                ts = ['0'] * dim
            elif dec:
                ts = fmt_dec([float(v) for v in t])
            else:
                ts = [fmt_fr(v) for v in t]
            lines.append(' '.join(fmt_fr(v) for v in p) + '  ' + ' '.join(ts))
        with open(os.path.join(outdir, 'cases', fn), 'w') as f:
            f.write('\n'.join(lines) + '\n')
        count += 1
    print('wrote %d limit vectors to %s/cases; tables vs independent reference: worst tangent angle %.3g deg%s' % (
        count, outdir, worst, '' if ok else ' -- MISMATCHES'))
    return ok



def nonzero(t):
    """A zero tangent (closed polygons of 1-2 points, a turning point) is no tangent."""
    return None if t is None or all(v == 0 for v in t) else t


def crosscheck_all(rules, seed=7):
    """Tables vs the independent reference (de Boor / fixed points / 50-level
    deep chords) for every rule, on random polygons of every short size and a
    long one: positions must be identical, exact tangents exactly parallel,
    deep-chord tangents within 1e-5 degrees (2^-24 rounding of irrational masks)."""
    rng = random.Random(seed)
    allok = True
    print('\n%-22s %6s %6s %14s  %s' % ('rule', 'polys', 'points', 'worst angle', 'tables vs independent reference'))
    for r in rules:
        t = tables_of(r)
        sizes = [1, 2, 3, 4, 5, 9] if r.closed else sorted(set(range(1, r.min_n + 3)) | {12})
        npts = 0
        worst = 0.0
        ok = True
        for n in sizes:
            L = [tuple(Fr(v) for v in p) for p in rand_poly(rng, n, 2 + n % 2)]
            ref = ref_limit(r, L)
            got = limit_outputs(t, L)
            gp = [g[1] for g in got]
            rp = [tuple(Fr(v) for v in x[0]) for x in ref]
            if gp != rp:
                ok = False
                print('  MISMATCH %s n=%d: positions (%d vs %d outputs)' % (r.name(), n, len(gp), len(rp)))
                continue
            for g, x in zip(got, ref):
                npts += 1
                g = (g[0], g[1], nonzero(g[2]))
                x = (x[0], nonzero(x[1]), x[2])
                if (g[2] is None) != (x[1] is None):
                    ok = False
                    print('  MISMATCH %s n=%d: tangent presence' % (r.name(), n))
                elif g[2] is None:
                    continue
                elif not x[2]:
                    if not exact_parallel(g[2], x[1]):
                        ok = False
                        print('  MISMATCH %s n=%d: exact tangent' % (r.name(), n))
                else:
                    an = angle([float(v) for v in g[2]], [float(v) for v in x[1]])
                    worst = max(worst, an)
                    if not an < 1e-5:
                        ok = False
                        print('  MISMATCH %s n=%d: tangent off by %.3g deg' % (r.name(), n, an))
        allok &= ok
        print('%-22s %6d %6d %10.3g deg  %s' % (r.name(), len(sizes), npts, worst, 'ok' if ok else 'FAIL'))
    return allok


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--check-shared', metavar='DIR', help='check the rules against shared vectors')
    ap.add_argument('--verify', action='store_true', help='brute-force verification table')
    ap.add_argument('--emit', metavar='DIR', help='write pk_masks.h/.c into DIR')
    ap.add_argument('--vectors', metavar='DIR', help='write limit reference vectors into DIR')
    ap.add_argument('--summary', action='store_true', help='print the derivation summary')
    a = ap.parse_args()
    ok = True
    if a.check_shared:
        ok &= check_shared(a.check_shared)
    rules = None
    if a.verify or a.emit or a.summary or a.vectors:
        rules = all_rules()
    if a.summary:
        for r in rules:
            print('\n'.join(describe_rule(r)))
    if a.emit:
        emit(a.emit, rules)
    if a.verify:
        ok &= verify_all(rules)
        ok &= crosscheck_all(rules)
    if a.vectors:
        ok &= write_vectors(a.vectors, rules)
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
