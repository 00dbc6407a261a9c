#!/usr/bin/python3
"""run_bench.py — `make bench`: plotkin's kernel against a double-precision C
baseline and three npm peers, on the same input, in one run.

Implementations (each prints outputs, seconds, maxrss_kb, checksum):
  kernel          build/bench/bench_refine N D     (Chaikin, streaming, fixed point)
  double          build/bench/baseline_double N D  (bench/baseline_double.c)
  chaikin-smooth, thing (@thi.ng/geom-subdiv-curve), turf (@turf/polygon-smooth)
                  node bench/peers.mjs PEER N D

Method (the machine is shared and noisy):
  * wall clock: every cell runs each implementation REPS times, interleaved
    (kernel, double, peers, then again in rotated order); the table shows the
    fastest run (least disturbed). Throughput = output points / seconds of the
    smoothing call alone (input generation and process start excluded, except
    that the kernel generates its input on the fly inside the timed loop).
  * instructions: valgrind --tool=callgrind --toggle-collect=<the smoothing
    function>, which is repeatable; run where N * 2^D <= CG_MAX outputs
    (per-point cost does not depend on N for these linear algorithms).
  * peers only where N * 2^D <= PEER_MAX (their arrays of [x, y] objects
    need ~130 B per point and ~0.5-1.5 us per point), plus one run of the
    fastest peer at the goal point (1e6 points, depth 5) unless --quick.
  * memory: peak resident set (VmHWM) of each process, so it includes the runtime (Node ~45 MB at rest).
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


def parse(line):
    res = {}
    for kv in line.split():
        k, v = kv.split('=', 1)
        res[k] = float(v) if k in ('seconds',) else int(v)
    return res


class Bench:
    def __init__(self, build):
        self.build = os.path.abspath(build)

    def cmd(self, impl, n, d, big=False):
        if impl == 'kernel':
            return [os.path.join(self.build, 'bench_refine'), str(n), str(d)]
        if impl == 'double':
            return [os.path.join(self.build, 'baseline_double'), str(n), str(d)]
        node = ['node']
        if big:
            node.append('--max-old-space-size=12000')
        return node + [os.path.join(HERE, 'peers.mjs'), impl, str(n), str(d)]

    def run(self, impl, n, d, big=False):
        out = subprocess.run(self.cmd(impl, n, d, big), check=True, capture_output=True, text=True,
                             cwd=HERE).stdout
        return parse(out.strip().splitlines()[-1])

    def instructions(self, impl, n, d):
        fn = {'kernel': 'bench_kernel_run', 'double': 'baseline_chaikin'}[impl]
        with tempfile.TemporaryDirectory() as tmp:
            cg = os.path.join(tmp, 'cg.out')
            out = subprocess.run(['valgrind', '--tool=callgrind', '--callgrind-out-file=' + cg,
                                  '--toggle-collect=' + fn] + self.cmd(impl, n, d),
                                 check=True, capture_output=True, text=True).stdout
            res = parse(out.strip().splitlines()[-1])
            with open(cg) as f:
                for ln in f:
                    if ln.startswith(('totals:', 'summary:')):
                        return int(ln.split()[1]) / res['outputs']
        return None


def fmt(v, spec='%.1f', none='-'):
    return none if v is None else spec % v


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--build', default='build/bench')
    ap.add_argument('--sizes', default='10000,100000,1000000')
    ap.add_argument('--depths', default='1,2,3,4,5,6')
    ap.add_argument('--reps', type=int, default=3)
    ap.add_argument('--cg-max', type=float, default=2e6)
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
            impls = ['kernel', 'double'] + ([p for p in PEERS] if outs <= a.peer_max else [])
            best = {}
            for rep in range(a.reps):
                order = impls[rep % len(impls):] + impls[:rep % len(impls)]
                for impl in order:
                    r = b.run(impl, n, d)
                    cur = best.get(impl)
                    if cur is None or r['seconds'] < cur['seconds']:
                        keep = dict(r)
                        keep['maxrss_kb'] = max(r['maxrss_kb'], cur['maxrss_kb']) if cur else r['maxrss_kb']
                        best[impl] = keep
                    else:
                        cur['maxrss_kb'] = max(cur['maxrss_kb'], r['maxrss_kb'])
            ir = {}
            if outs <= a.cg_max:
                for impl in ('kernel', 'double'):
                    ir[impl] = b.instructions(impl, n, d)
            cells[(n, d)] = {'best': best, 'ir': ir}
            sys.stderr.write('.')
            sys.stderr.flush()
    sys.stderr.write('\n')

    def mpts(c, impl):
        r = c['best'].get(impl)
        return r['outputs'] / r['seconds'] / 1e6 if r else None

    print()
    print('Throughput, million output points per second (fastest of %d interleaved runs), and '
          'instructions per output point (callgrind; "-": not run, see --cg-max/--peer-max)' % a.reps)
    hdr = ('%8s %2s %10s | %8s %7s | %8s %7s | %7s %6s | %8s %8s %8s | %9s'
           % ('N', 'd', 'outputs', 'kernel', 'Ir/pt', 'double', 'Ir/pt', 'k/d wall', 'k/d Ir',
              'chaikin-', 'thi.ng', 'turf', 'k/best'))
    print(hdr)
    print('%8s %2s %10s | %8s %7s | %8s %7s | %7s %6s | %8s %8s %8s | %9s'
          % ('', '', '', 'Mpt/s', '', 'Mpt/s', '', '', '', 'smooth', '', '', 'peer'))
    for (n, d), c in cells.items():
        k, dd = mpts(c, 'kernel'), mpts(c, 'double')
        peers = [mpts(c, p) for p in PEERS]
        bestp = max([p for p in peers if p is not None], default=None)
        ki, di = c['ir'].get('kernel'), c['ir'].get('double')
        print('%8d %2d %10d | %8.2f %7s | %8.2f %7s | %7.2f %6s | %8s %8s %8s | %9s'
              % (n, d, c['best']['kernel']['outputs'], k, fmt(ki), dd, fmt(di), k / dd,
                 fmt(di / ki if ki and di else None, '%.2f'),
                 fmt(peers[0], '%.2f'), fmt(peers[1], '%.2f'), fmt(peers[2], '%.2f'),
                 fmt(k / bestp if bestp else None, '%.0f')))
    print()
    print('Peak memory, maximum resident set in MB (whole process)')
    print('%8s %2s | %8s %8s %9s %8s %8s' % ('N', 'd', 'kernel', 'double', 'chaikin-s', 'thi.ng', 'turf'))
    for (n, d), c in cells.items():
        row = [c['best'].get(i, {}).get('maxrss_kb') for i in ['kernel', 'double'] + PEERS]
        print('%8d %2d | %s' % (n, d, ' '.join('%8s' % fmt(v / 1024 if v else None, '%.1f') for v in row)))

    # ---- the goals -----------------------------------------------------------
    print()
    print('Goals (issue 6)')
    gn, gd = 1000000, 5
    pairs = []
    for _ in range(5):
        rk, rd = b.run('kernel', gn, gd), b.run('double', gn, gd)
        pairs.append((rd['seconds'] / rd['outputs']) / (rk['seconds'] / rk['outputs']))
        kr = rk
    print('  kernel vs double baseline at N=1e6, depth 5: 5 interleaved pairs, per-point speed ratio '
          'median %.2fx (min %.2f, max %.2f); goal >= 5x: %s'
          % (statistics.median(pairs), min(pairs), max(pairs),
             'met' if statistics.median(pairs) >= 5 else 'MISSED'))
    if (100000, 5) in cells and cells[(100000, 5)]['ir'].get('kernel'):
        c = cells[(100000, 5)]['ir']
        print('  instructions per point at N=1e5, depth 5: kernel %.1f, double %.1f (ratio %.2fx)'
              % (c['kernel'], c['double'], c['double'] / c['kernel']))
    # the fastest peer: at the largest cell where all peers ran
    common = [key for key, c in cells.items() if all(p in c['best'] for p in PEERS)]
    if common:
        key = max(common, key=lambda k: (k[0] * 2 ** k[1], k[0]))
        c = cells[key]
        fastest = max(PEERS, key=lambda p: mpts(c, p))
        print('  fastest npm peer (at N=%d, depth %d): %s, %.2f Mpt/s; kernel there %.2f Mpt/s = %.0fx'
              % (key[0], key[1], fastest, mpts(c, fastest), mpts(c, 'kernel'),
                 mpts(c, 'kernel') / mpts(c, fastest)))
        if not a.quick:
            k1 = b.run('kernel', gn, gd)
            rp = b.run(fastest, gn, gd, big=True)
            k2 = b.run('kernel', gn, gd)
            ks = statistics.median([k1['seconds'] / k1['outputs'], k2['seconds'] / k2['outputs'],
                                    kr['seconds'] / kr['outputs']])
            ratio = (rp['seconds'] / rp['outputs']) / ks
            print('  kernel vs %s at N=1e6, depth 5 (peer once, kernel before and after): %.0fx; '
                  'peer %.2f Mpt/s, %.0f MB; goal >= 50x: %s'
                  % (fastest, ratio, rp['outputs'] / rp['seconds'] / 1e6, rp['maxrss_kb'] / 1024,
                     'met' if ratio >= 50 else 'MISSED'))
    ks = [(n, cells[(n, d)]['best']['kernel']['maxrss_kb']) for (n, d) in cells if d == max(depths)]
    dbl = [(n, cells[(n, d)]['best']['double']['maxrss_kb']) for (n, d) in cells if d == max(depths)]
    print('  memory vs input size at depth %d: kernel %s; double %s'
          % (max(depths), ', '.join('N=%g: %.1f MB' % (n, kb / 1024) for n, kb in ks),
             ', '.join('N=%g: %.0f MB' % (n, kb / 1024) for n, kb in dbl)))
    print('  (kernel state: %s)' % 'see `make targets`, sizeof(struct pk_refine)')
    print('bench: %.0f s' % (time.time() - t_start))
    with open(os.path.join(a.build, 'results.json'), 'w') as f:
        json.dump({'%d,%d' % k: v for k, v in cells.items()}, f, indent=1)


if __name__ == '__main__':
    main()
