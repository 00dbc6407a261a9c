#!/usr/bin/python3
"""run_bench.py — `make bench`: plotkin's kernel against a double-precision C
baseline and three npm peers, on the same input, in one run.

Implementations (each prints outputs, seconds, maxrss_kb, checksum):
  kernel          build/bench/bench_refine N D chaikin point   (one pk_refine_pull per point)
  block           build/bench/bench_refine N D chaikin block   (pk_refine_pull_block into the
                                                                whole output array)
  write           build/bench/bench_refine N D chaikin write   (no kernel: one memset of that
                                                                array = the bound for "block")
  double          build/bench/baseline_double N D  (bench/baseline_double.c)
  chaikin-smooth, thing (@thi.ng/geom-subdiv-curve), turf (@turf/polygon-smooth)
                  node bench/peers.mjs PEER N D
  and the kernel on the cubic B-spline and DLG (point and block; no peer has them).

Method (the machine is shared and noisy):
  * wall clock: every cell runs each implementation REPS times, interleaved
    (rotating the order); the table shows the fastest run (least disturbed).
    Throughput = output points / seconds of the smoothing call alone (input
    generation and process start excluded, except that the kernel generates
    its input on the fly inside the timed loop).
  * instructions: valgrind --tool=callgrind --toggle-collect=<the smoothing
    function>, which is repeatable; run where N * 2^D <= CG_MAX outputs
    (per-point cost does not depend on N for these linear algorithms).
  * peers only where N * 2^D <= PEER_MAX (their arrays of [x, y] objects
    need ~130 B per point and ~0.5-1.5 us per point), plus one run of the
    fastest peer at the goal point (1e6 points, depth 5) unless --quick.
  * memory: peak resident set (VmHWM) of each process, so it includes the
    runtime (Node ~45 MB at rest) and, for block/write, the output array.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
PEERS = ['chaikin-smooth', 'thing', 'turf']
KMODES = {'kernel': 'point', 'block': 'block', 'write': 'write'}


def parse(line):
    res = {}
    for kv in line.split():
        k, v = kv.split('=', 1)
        res[k] = float(v) if k in ('seconds',) else int(v)
    return res


class Bench:
    def __init__(self, build):
        self.build = os.path.abspath(build)

    def cmd(self, impl, n, d, big=False, scheme='chaikin'):
        if impl in KMODES:
            return [os.path.join(self.build, 'bench_refine'), str(n), str(d), scheme, KMODES[impl]]
        if impl == 'double':
            return [os.path.join(self.build, 'baseline_double'), str(n), str(d)]
        node = ['node']
        if big:
            node.append('--max-old-space-size=12000')
        return node + [os.path.join(HERE, 'peers.mjs'), impl, str(n), str(d)]

    def run(self, impl, n, d, big=False, scheme='chaikin'):
        out = subprocess.run(self.cmd(impl, n, d, big, scheme), check=True, capture_output=True, text=True,
                             cwd=HERE).stdout
        return parse(out.strip().splitlines()[-1])

    def instructions(self, impl, n, d, scheme='chaikin'):
        fn = 'baseline_chaikin' if impl == 'double' else 'bench_kernel_run'
        with tempfile.TemporaryDirectory() as tmp:
            cg = os.path.join(tmp, 'cg.out')
            out = subprocess.run(['valgrind', '--tool=callgrind', '--callgrind-out-file=' + cg,
                                  '--toggle-collect=' + fn] + self.cmd(impl, n, d, scheme=scheme),
                                 check=True, capture_output=True, text=True).stdout
            res = parse(out.strip().splitlines()[-1])
            with open(cg) as f:
                for ln in f:
                    if ln.startswith(('totals:', 'summary:')):
                        return int(ln.split()[1]) / res['outputs']
        return None


def fmt(v, spec='%.1f', none='-'):
    return none if v is None else spec % v


def mpts(r):
    return r['outputs'] / r['seconds'] / 1e6 if r and r['seconds'] > 0 else None


def best_of(b, impls, n, d, reps, scheme='chaikin'):
    best = {}
    for rep in range(reps):
        order = impls[rep % len(impls):] + impls[:rep % len(impls)]
        for impl in order:
            r = b.run(impl, n, d, scheme=scheme)
            cur = best.get(impl)
            if cur is None or r['seconds'] < cur['seconds']:
                keep = dict(r)
                keep['maxrss_kb'] = max(r['maxrss_kb'], cur['maxrss_kb']) if cur else r['maxrss_kb']
                best[impl] = keep
            else:
                cur['maxrss_kb'] = max(cur['maxrss_kb'], r['maxrss_kb'])
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--build', default='build/bench')
    ap.add_argument('--sizes', default='10000,100000,1000000')
    ap.add_argument('--depths', default='1,3,5,6')
    ap.add_argument('--reps', type=int, default=3)
    ap.add_argument('--cg-max', type=float, default=4e6)
    ap.add_argument('--peer-max', type=float, default=2e6)
    ap.add_argument('--quick', action='store_true', help='skip the goal-point runs of the peer')
    a = ap.parse_args()
    b = Bench(a.build)
    sizes = [int(s) for s in a.sizes.split(',')]
    depths = [int(s) for s in a.depths.split(',')]
    t_start = time.time()
    print('plotkin host benchmark: Chaikin, open 2-D random walk (bench/bench_common.h), %s; load %s'
          % (os.uname().machine, ' '.join('%.2f' % x for x in os.getloadavg())))
    cells = {}
    for n in sizes:
        for d in depths:
            outs = n * 2 ** d
            impls = ['kernel', 'block', 'write', 'double'] + ([p for p in PEERS] if outs <= a.peer_max else [])
            best = best_of(b, impls, n, d, a.reps)
            ir = {}
            if outs <= a.cg_max:
                for impl in ('kernel', 'block', 'double'):
                    ir[impl] = b.instructions(impl, n, d)
            cells[(n, d)] = {'best': best, 'ir': ir}
            sys.stderr.write('.')
            sys.stderr.flush()
    others = {}
    for scheme in ('cubic', 'dlg'):
        for n in sizes:
            d = 5
            best = best_of(b, ['kernel', 'block'], n, d, a.reps, scheme)
            ir = {}
            if n * 2 ** d <= a.cg_max:
                for impl in ('kernel', 'block'):
                    ir[impl] = b.instructions(impl, n, d, scheme)
            others[(scheme, n, d)] = {'best': best, 'ir': ir}
            sys.stderr.write('.')
            sys.stderr.flush()
    sys.stderr.write('\n')

    print()
    print('Throughput, million output points per second (fastest of %d interleaved runs), and instructions per '
          'output point (callgrind; "-": not run, see --cg-max/--peer-max). kernel: one pk_refine_pull per '
          'point; block: pk_refine_pull_block into the output array; write: memset of that array (the bound '
          'for block)' % a.reps)
    print('%8s %2s %9s | %7s %5s | %7s %5s | %7s | %6s %5s | %6s %6s %6s | %6s %7s %7s'
          % ('N', 'd', 'outputs', 'kernel', 'Ir/pt', 'block', 'Ir/pt', 'write', 'double', 'Ir/pt',
             'chaik-', 'thi.ng', 'turf', 'k/dbl', 'k/peer', 'blk/wr'))
    print('%8s %2s %9s | %7s %5s | %7s %5s | %7s | %6s %5s | %6s %6s %6s | %6s %7s %7s'
          % ('', '', '', 'Mpt/s', '', 'Mpt/s', '', 'Mpt/s', 'Mpt/s', '', 'smooth', '', '', '', '', ''))
    for (n, d), c in cells.items():
        bb, ir = c['best'], c['ir']
        k, bl, wr, dd = mpts(bb['kernel']), mpts(bb['block']), mpts(bb['write']), mpts(bb['double'])
        peers = [mpts(bb.get(p)) for p in PEERS]
        bestp = max([p for p in peers if p is not None], default=None)
        print('%8d %2d %9d | %7.1f %5s | %7.1f %5s | %7.1f | %6.1f %5s | %6s %6s %6s | %6.1f %7s %7.2f'
              % (n, d, bb['kernel']['outputs'], k, fmt(ir.get('kernel')), bl, fmt(ir.get('block')), wr, dd,
                 fmt(ir.get('double')), fmt(peers[0], '%.2f'), fmt(peers[1], '%.2f'), fmt(peers[2], '%.2f'),
                 k / dd, fmt(k / bestp if bestp else None, '%.0f'), bl / wr))
    print()
    print('The kernel on the other schemes, depth 5 (open, default end rules: clamped cubic; DLG ghost points)')
    print('%-7s %8s %9s | %7s %5s | %7s %5s' % ('scheme', 'N', 'outputs', 'kernel', 'Ir/pt', 'block', 'Ir/pt'))
    for (scheme, n, d), c in others.items():
        bb, ir = c['best'], c['ir']
        print('%-7s %8d %9d | %7.1f %5s | %7.1f %5s' % (scheme, n, bb['kernel']['outputs'], mpts(bb['kernel']),
                                                       fmt(ir.get('kernel')), mpts(bb['block']),
                                                       fmt(ir.get('block'))))
    print()
    print('Peak memory, maximum resident set in MB (whole process; block/write hold the output array)')
    print('%8s %2s | %8s %8s %8s %8s %9s %8s %8s' % ('N', 'd', 'kernel', 'block', 'write', 'double', 'chaikin-s',
                                                     'thi.ng', 'turf'))
    for (n, d), c in cells.items():
        row = [c['best'].get(i, {}).get('maxrss_kb') for i in ['kernel', 'block', 'write', 'double'] + PEERS]
        print('%8d %2d | %s' % (n, d, ' '.join('%8s' % fmt(v / 1024 if v else None, '%.1f') for v in row)))

    # ---- the goals (issue 14) -------------------------------------------------
    print()
    print('Goals (issue 14)')
    gn, gd = 1000000, 5
    pairs, blk = [], []
    for _ in range(5):
        rk, rd = b.run('kernel', gn, gd), b.run('double', gn, gd)
        pairs.append((rd['seconds'] / rd['outputs']) / (rk['seconds'] / rk['outputs']))
        rb, rw = b.run('block', gn, gd), b.run('write', gn, gd)
        blk.append((rw['seconds'] / rw['outputs']) / (rb['seconds'] / rb['outputs']))
        kr = rk
    print('  kernel (one point per pull) vs double baseline at N=1e6, depth 5: 5 interleaved pairs, per-point '
          'speed ratio median %.2fx (min %.2f, max %.2f); goal >= 5x: %s'
          % (statistics.median(pairs), min(pairs), max(pairs), 'met' if statistics.median(pairs) >= 5 else 'MISSED'))
    for n in sizes:
        if (n, gd) in cells:
            c = cells[(n, gd)]['best']
            print('    at N=%g, depth 5 (fastest of %d): kernel %.1f, double %.1f Mpt/s = %.2fx'
                  % (n, a.reps, mpts(c['kernel']), mpts(c['double']), mpts(c['kernel']) / mpts(c['double'])))
    print('  block pull vs writing the output (memset of the same array) at N=1e6, depth 5: 5 interleaved pairs, '
          'speed ratio median %.2f (min %.2f, max %.2f); goal >= 0.5 (within 2x): %s'
          % (statistics.median(blk), min(blk), max(blk), 'met' if statistics.median(blk) >= 0.5 else 'MISSED'))
    for n in sizes:
        if (n, gd) in cells:
            c = cells[(n, gd)]['best']
            print('    at N=%g, depth 5 (fastest of %d): block %.1f, write %.1f Mpt/s = %.2f'
                  % (n, a.reps, mpts(c['block']), mpts(c['write']), mpts(c['block']) / mpts(c['write'])))
    for n in sizes:
        if (n, gd) in cells and cells[(n, gd)]['ir'].get('kernel'):
            c = cells[(n, gd)]['ir']
            print('  instructions per output point at N=%g, depth 5: block pull %.1f (goal <= 15: %s), one-point '
                  'pull %.1f, double %.1f' % (n, c['block'], 'met' if c['block'] <= 15 else 'MISSED', c['kernel'],
                                              c['double']))
            break
    common = [key for key, c in cells.items() if all(p in c['best'] for p in PEERS)]
    if common:
        key = max(common, key=lambda k: (k[0] * 2 ** k[1], k[0]))
        c = cells[key]
        fastest = max(PEERS, key=lambda p: mpts(c['best'][p]))
        print('  fastest npm peer (at N=%d, depth %d): %s, %.2f Mpt/s; kernel there %.1f Mpt/s = %.0fx'
              % (key[0], key[1], fastest, mpts(c['best'][fastest]), mpts(c['best']['kernel']),
                 mpts(c['best']['kernel']) / mpts(c['best'][fastest])))
        if not a.quick:
            k1 = b.run('kernel', gn, gd)
            rp = b.run(fastest, gn, gd, big=True)
            k2 = b.run('kernel', gn, gd)
            ks = statistics.median([k1['seconds'] / k1['outputs'], k2['seconds'] / k2['outputs'],
                                    kr['seconds'] / kr['outputs']])
            ratio = (rp['seconds'] / rp['outputs']) / ks
            print('  kernel vs %s at N=1e6, depth 5 (peer once, kernel before and after): %.0fx; '
                  'peer %.2f Mpt/s, %.0f MB; goal >= 100x: %s'
                  % (fastest, ratio, rp['outputs'] / rp['seconds'] / 1e6, rp['maxrss_kb'] / 1024,
                     'met' if ratio >= 100 else 'MISSED'))
    ks = [(n, cells[(n, d)]['best']['kernel']['maxrss_kb']) for (n, d) in cells if d == max(depths)]
    dbl = [(n, cells[(n, d)]['best']['double']['maxrss_kb']) for (n, d) in cells if d == max(depths)]
    print('  memory vs input size at depth %d: kernel %s; double %s'
          % (max(depths), ', '.join('N=%g: %.1f MB' % (n, kb / 1024) for n, kb in ks),
             ', '.join('N=%g: %.0f MB' % (n, kb / 1024) for n, kb in dbl)))
    print('  (kernel state: see `make bench-sizes`, sizeof(struct pk_refine) per build and target)')
    print('bench: %.0f s; load %s' % (time.time() - t_start, ' '.join('%.2f' % x for x in os.getloadavg())))
    with open(os.path.join(a.build, 'results.json'), 'w') as f:
        json.dump({'%d,%d' % k: v for k, v in cells.items()}, f, indent=1)


if __name__ == '__main__':
    main()
