#!/usr/bin/python3
"""avr_bench.py — plotkin's speed on the chip: the board images under simavr.

usage: avr_bench.py BUILD BOARD...

Every figure is measured on the very image `make firmware` builds (its HEX,
run by `plotkin avrsim`, cycle-exact at 16 MHz; the ELF gives the symbols), so
it is what the board does, HAL and interrupts included. Per board:

  1. a smoothed pen drawing (tests/avr/strokes.gcode) and the bundled example:
     step-interrupt cycles per step (all step-timer interrupt cycles / steps,
     the nested serial interrupts excluded), the longest interrupt, the
     callback pk_machine_timer_cb per call (mean, worst), where the interrupt's
     cycles go (flat profile by function), the main loop's cost per chunk
     (pk_sg_prep cycles / chunks published: changes of the ring's head index),
     per planned block and per G-code line, the kernel's pk_refine_pull per
     call, underruns (step-timer restarts beyond the first), and the motion
     time on the chip against `plotkin sim` (built with the board's knobs);
  2. the highest sustained step rate: one long X move at increasing rates
     (80 steps/mm, 50,000 mm/s^2 so that the cruise dominates), bisected; a
     rate is sustained when the chip has no underrun and its motion time is
     within 1 % of the planned one;
  3. the bundled example at F6000 (80 steps/mm), on-chip vs planned time, and
     the stalls while moving in the chip's pin trace (the ring ran dry at
     speed), against the same count on `plotkin sim`'s trace;
  4. a dense drawing, as SVG-to-G-code tools write them: the corpus file
     bench/corpus/files/svg2gcode-smooth-curves.gcode (4,741 moves of about
     0.2 mm) at F6000, smoothed within 0.02 mm and exact (G61): on-chip vs
     planned time, step-timer restarts, the main loop's cycles per G-code line
     and where they go (the functions that cost most, inclusive).

PK_BENCH_ONLY=dense runs section 4 alone (a quicker loop while working on
the main loop's cost). Prints tables; never a pass/fail verdict on timing. Exits 1, after printing
what it could, if a measurement was impossible (an image that does not fit
its part, a run that did not finish, a symbol missing from the ELF).
"""
import json
import os
import re
import subprocess
import sys
import tempfile

BUILD = sys.argv[1]
BOARDS = sys.argv[2:]
PLOTKIN = os.path.join(BUILD, 'plotkin')
F_CPU = 16e6
GRBL_LINE_CYCLES = 6483
GRBL_ISR = (306, 545)
BOARD_CONFIG = {'uno-cnc-shield': ['$202=2'], 'mega-ramps': []}
impossible = []


def nm_syms(elf):
    out = subprocess.run(['avr-nm', '-S', elf], capture_output=True, text=True, check=True).stdout
    res = {}
    for ln in out.splitlines():
        f = ln.split()
        if len(f) == 4:
            res[f[3]] = (int(f[0], 16), int(f[1], 16))
    return res


def avrsim(board, prog, conf_lines, tmp, extra=(), timeout=900):
    hexf = os.path.join(BUILD, 'firmware', board, board + '.hex')
    gc = os.path.join(tmp, 'p.gcode')
    cf = os.path.join(tmp, 'c.conf')
    open(gc, 'w').write(prog)
    open(cf, 'w').write('\n'.join(BOARD_CONFIG.get(board, []) + conf_lines) + '\n')
    p = subprocess.run([PLOTKIN, 'avrsim', hexf, '--board', board, '--config', cf, '--run', gc, '--json',
                        '--timeout', '600'] + list(extra), capture_output=True, text=True, timeout=timeout)
    try:
        d = json.loads(p.stdout)
    except ValueError:
        return None, p.stderr[-400:]
    if d.get('status') != 'finished':
        return None, 'run did not finish: %s (chip %s)' % (d.get('status'), d.get('chip'))
    return d, None


def hostsim(board, prog, conf_lines, tmp, extra=()):
    host = os.path.join(BUILD, 'firmware', board, 'host', 'plotkin')
    gc = os.path.join(tmp, 'h.gcode')
    cf = os.path.join(tmp, 'h.conf')
    open(gc, 'w').write(prog)
    open(cf, 'w').write('\n'.join(BOARD_CONFIG.get(board, []) + conf_lines) + '\n')
    p = subprocess.run([host, 'sim', gc, '--config', cf, '--json'] + list(extra), capture_output=True, text=True)
    try:
        return json.loads(p.stdout)
    except ValueError:
        return None


def stalls(trace_csv):
    """Stalls while moving, from a pin trace (every axis's step edges
    merged): a step interval over 4 times the median of the 8 intervals
    before it and of the 8 after it, and over 1 ms, with no pen change in it
    (a planned stop). A ring that runs dry at speed stops the steps at once
    and starts them again at the same rate: such a gap between equal
    intervals. A planned motion has a few (a corner where one axis stops and
    the other starts): the same detector on `plotkin sim`'s trace counts
    those. Returns (count, total ms, longest ms)."""
    import bisect
    import statistics
    ev, pen = [], []
    for ln in open(trace_csv):
        if ln.startswith('#') or ln.startswith('tick'):
            continue
        f = ln.rstrip().split(',')
        if f[2].endswith('.step') and f[3] == '1':
            ev.append(float(f[1]))
        elif f[2] == 'pen':
            pen.append(float(f[1]))
    ev.sort()
    pen.sort()
    gaps = []
    for i in range(9, len(ev) - 9):
        d = ev[i] - ev[i - 1]
        if d <= 0.001:
            continue
        k = bisect.bisect_left(pen, ev[i - 1])
        if k < len(pen) and pen[k] < ev[i]:
            continue
        mb = statistics.median([ev[j] - ev[j - 1] for j in range(i - 8, i)])
        ma = statistics.median([ev[j + 1] - ev[j] for j in range(i, i + 8)])
        if d > 4 * max(mb, ma):
            gaps.append(d)
    return len(gaps), 1e3 * sum(gaps), 1e3 * max(gaps or [0.0])


def fnc(d, name):
    f = d['functions'].get(name)
    return (f['calls'], f['cycles'], f['max']) if f else (0, 0, 0)


def line_profile(elf, histf, syms, fn, steps, top=10):
    """Cycles of the step interrupt inside fn, by source line (addr2line)."""
    if fn not in syms:
        return
    lo, size = syms[fn]
    rows = []
    for ln in open(histf):
        a, c = ln.split()
        a = int(a, 16)
        if lo <= a < lo + size:
            rows.append((a, int(c)))
    if not rows:
        return
    out = subprocess.run(['avr-addr2line', '-e', elf] + ['0x%x' % a for a, _ in rows],
                         capture_output=True, text=True).stdout.split('\n')
    per = {}
    for (a, c), loc in zip(rows, out):
        loc = re.sub(r' \(discriminator \d+\)', '', loc.strip())
        per[loc] = per.get(loc, 0) + c
    tot = sum(per.values())
    print('  %s by source line (%% of its %d cycles; the lines that cost most):' % (fn, tot))
    for loc, c in sorted(per.items(), key=lambda kv: -kv[1])[:top]:
        src = ''
        m = re.match(r'(.*):(\d+)$', loc)
        if m and os.path.exists(m.group(1)):
            lines = open(m.group(1)).read().split('\n')
            k = int(m.group(2))
            if 0 < k <= len(lines):
                src = lines[k - 1].strip()[:60]
        print('    %5.1f%% %6.0f cyc/step  %-28s %s' % (100.0 * c / tot, c / steps,
                                                       os.path.relpath(loc) if m else loc, src))


def drawing(board, name, prog, conf, tmp, elf, syms):
    app = syms.get('app')
    histf = os.path.join(tmp, 'hist.txt')
    extra = ['--elf', elf, '--profile', '--hist', histf, '--poll-status', '5']
    if app is not None:
        base = app[0] & 0xFFFF
        extra += ['--watch', 'chunks:%d' % (base + OFFS['sg_head']),
                  '--peek', 'lines_planned:%d:4' % (base + OFFS['lines_planned'])]
    d, err = avrsim(board, prog, conf, tmp, extra)
    if d is None:
        impossible.append('%s, %s: %s' % (board, name, err))
        return None
    h = hostsim(board, prog, conf, tmp)
    steps = sum(d['steps'])
    st = d['isr'][str(STEP_VECTOR[board])]
    cb = fnc(d, 'pk_machine_timer_cb')
    prep = fnc(d, 'pk_sg_prep')
    chunks = d['watches'].get('chunks', 0)
    lines = d['lines']
    blocks = d['peeks'].get('lines_planned', 0)
    gp = fnc(d, 'pk_grbl_poll')
    parse = fnc(d, 'pk_gcode_parse')
    interp = fnc(d, 'pk_gcode_interp')
    add = fnc(d, 'pk_planner_add_line')
    rep = fnc(d, 'pk_planner_replan')
    mp = fnc(d, 'pk_machine_poll')
    pull = fnc(d, 'pk_refine_pull')
    spull = fnc(d, 'pk_stroke_pull')
    print('\n%s, %s: %d lines, %d steps, %d planned line blocks, %d chunks' % (board, name, lines, steps,
                                                                               blocks, chunks))
    print('  %-52s %12s' % ('measurement', 'value'))
    row = lambda k, v: print('  %-52s %12s' % (k, v))
    row('step ISR cycles per step (mean, all its calls)', '%.0f' % (st['cycles'] / steps))
    # (absent: no compare B interrupt ran, every pulse was timed inside the
    # step ISR, PK_AVR_PULSE_SPIN)
    pe = d['isr'].get(str(PULSE_VECTOR[board]), {'cycles': 0})
    row('pulse-end ISR (compare B) cycles per step', '%.0f' % (pe['cycles'] / steps))
    row('  both: cycles per step (30 kHz at 16 MHz: < 533)', '%.0f' % ((st['cycles'] + pe['cycles']) / steps))
    row('longest step ISR (cycles, nested serial excluded)', '%d' % st['max'])
    if cb[0]:
        row('pk_machine_timer_cb per call: mean / worst cycles', '%.0f / %d' % (cb[1] / cb[0], cb[2]))
        row('  callbacks per step', '%.2f' % (cb[0] / steps))
    else:
        row('pk_machine_timer_cb per call', 'inline in ISR')
    row('pk_sg_prep cycles per chunk / calls per chunk', '%.0f / %.1f' % (prep[1] / chunks, prep[0] / chunks)
        if chunks else 'n/a')
    row('pk_planner_add_line cycles per call', '%.0f' % (add[1] / max(add[0], 1)))
    row('pk_planner_replan cycles per call / calls per line', '%.0f / %.1f' % (rep[1] / max(rep[0], 1),
                                                                              rep[0] / max(lines, 1)))
    row('pk_machine_poll cycles per line (all main-loop motion)', '%.0f' % (mp[1] / max(lines, 1)))
    row('pk_grbl_poll cycles per line (engine, I/O included)', '%.0f' % (gp[1] / max(lines, 1)))
    row('parse + interpret cycles per line (Grbl: %d)' % GRBL_LINE_CYCLES,
        '%.0f' % ((parse[1] + interp[1]) / max(lines, 1)))
    row('pk_refine_pull cycles per call / pk_stroke_pull', '%.0f / %.0f' % (pull[1] / max(pull[0], 1),
                                                                          spull[1] / max(spull[0], 1)))
    row('underruns (step-timer restarts beyond the first)', '%d' % (d['timer_starts'] - 1))
    lat = d.get('status_latency_ms')
    if lat is None or not d.get('status_polls'):
        impossible.append('%s, %s: no status latency measured' % (board, name))
    else:
        row('longest pk_machine_poll (ms)', '%.1f' % (mp[2] / 16e3))
        row('"?" at 5 Hz -> whole report: p50 / p99 / max (ms)', '%.1f / %.1f / %.1f' % (
            lat['p50'], lat['p99'], lat['max']))
    if h is not None:
        row('motion time: chip / plotkin sim (s)', '%.2f / %.2f' % (d['motion_s'], h['sim_time_s']))
        row('  ratio', '%.2f' % (d['motion_s'] / h['sim_time_s']))
    row('deepest stack (B)', '%d' % d['stack_bytes'])
    prof = d.get('step_isr_profile', {})
    tot = sum(prof.values())
    if tot:
        print('  where the step ISR cycles go (flat profile, %% of %d cycles):' % tot)
        for k, v in sorted(prof.items(), key=lambda kv: -kv[1])[:12]:
            if k.startswith('__vector_'):
                k += ' (HAL: the step-timer ISR, with what it inlines)'
            print('    %5.1f%%  %-46s %8.0f cycles/step' % (100.0 * v / tot, k, v / steps))
        # by source line: the function that holds the step path (pk_sg_isr,
        # or the vector itself on a board that compiles it in)
        hot = max((k for k in prof if k == 'pk_sg_isr' or k.startswith('__vector_')), key=lambda k: prof[k],
                  default=None)
        if hot is not None:
            line_profile(elf, histf, syms, hot, steps, top=int(os.environ.get('PK_BENCH_LINES', '10')))
    return d


def max_rate(board, tmp):
    conf = ['$100=80', '$110=30000', '$120=50000', '$200=0']

    def trial(rate):
        f = rate / 80.0 * 60.0
        length = rate / 80.0 * 0.5 + 0.5
        prog = 'G21 G91 G61\nG1 X%.3f F%.1f\nM2\n' % (length, f)
        d, err = avrsim(board, prog, conf, tmp)
        h = hostsim(board, prog, conf, tmp)
        if d is None or h is None:
            return None, err or 'plotkin sim (host, board knobs) failed on the same program'
        under = d['timer_starts'] - 1
        ratio = d['motion_s'] / h['sim_time_s'] if h['sim_time_s'] else 0
        ok = under == 0 and ratio <= 1.01 and sum(d['steps']) == sum(h['steps'])
        return (ok, under, ratio, d['isr'][str(STEP_VECTOR[board])]['max']), None

    print('\n%s: sustained step rate, one X move (80 steps/mm, $120=50000, G61)' % board)
    print('  %10s %10s %10s %14s %10s' % ('steps/s', 'underruns', 'chip/plan', 'longest ISR', 'sustained'))
    best, worst_fail = None, None
    for rate in (250, 500, 1000, 2000, 4000, 8000, 16000, 20000, 25000, 30000):
        r, err = trial(rate)
        if r is None:
            impossible.append('%s, step rate %d: %s' % (board, rate, err))
            return
        print('  %10d %10d %10.3f %14d %10s' % (rate, r[1], r[2], r[3], 'yes' if r[0] else 'no'))
        if r[0]:
            best = rate
        else:
            worst_fail = rate
            break
    if best is None:
        print('  highest sustained step rate: below 250 steps/s (no rate tried was sustained)')
        return
    lo, hi = best, worst_fail
    while hi is not None and hi - lo > max(lo // 20, 50):
        mid = (lo + hi) // 2
        r, err = trial(mid)
        if r is None:
            impossible.append('%s, step rate %d: %s' % (board, mid, err))
            return
        print('  %10d %10d %10.3f %14d %10s' % (mid, r[1], r[2], r[3], 'yes' if r[0] else 'no'))
        if r[0]:
            lo = mid
        else:
            hi = mid
    print('  highest sustained step rate: %s steps/s (Grbl 1.1h: 30,000 claimed; its step ISR %d cycles,'
          ' worst %d)' % ('{:,}'.format(lo) + ('' if hi is not None else '+'), GRBL_ISR[0], GRBL_ISR[1]))


DENSE = 'bench/corpus/files/svg2gcode-smooth-curves.gcode'
DENSE_FNS = ('pk_stroke_pull', 'pk_stroke_add', 'pk_refine_pull', 'pk_sg_prep', 'pk_planner_add_line',
             'pk_planner_replan', 'pk_gcode_parse', 'pk_gcode_interp', 'pk_isqrt64', 'pk_frac_q30')


def dense(board, tmp, elf):
    """A dense drawing at F6000 (section 4 of the docstring)."""
    body = re.sub(r'F300\b', 'F6000', open(DENSE).read())
    print('\n%s: a dense drawing (%s, F300 made F6000: 4,741 moves of ~0.2 mm, 500 lines/s at speed)'
          % (board, DENSE))
    print('  %-22s %9s %9s %7s %9s %14s' % ('mode', 'chip s', 'plan s', 'x', 'restarts', 'cycles/line'))
    prof = None
    for mode, head in (('smoothed 0.02 mm', 'G64 P0.02\n'), ('exact (G61)', 'G61\n')):
        fns = [a for f in DENSE_FNS for a in ('--fn', f)] if prof is None else []
        d, err = avrsim(board, head + body, [], tmp, ['--elf', elf] + fns)
        h = hostsim(board, head + body, [], tmp)
        if d is None or h is None or not h.get('sim_time_s'):
            impossible.append('%s, dense drawing %s: %s' % (board, mode, err or 'plotkin sim failed'))
            continue
        if fnc(d, 'pk_machine_poll')[0] == 0 or (prof is None and fnc(d, 'pk_stroke_pull')[0] == 0):
            impossible.append('%s, dense drawing %s: the main-loop functions were not measured' % (board, mode))
            continue
        mp = fnc(d, 'pk_machine_poll')[1] + fnc(d, 'pk_grbl_poll')[1]
        print('  %-22s %9.2f %9.2f %7.2f %9d %14s' % (mode, d['motion_s'], h['sim_time_s'],
                                                     d['motion_s'] / h['sim_time_s'], d['timer_starts'] - 1,
                                                     '{:,}'.format(int(mp / d['lines']))))
        if prof is None:
            prof = d
    if prof is not None:
        tot = prof['cycles']
        print('  smoothed: main-loop functions, inclusive (%% of all %s cycles; calls; cycles a call;'
              ' a share includes what the function calls: pk_refine_pull and most pk_isqrt64 and pk_frac_q30'
              ' calls are inside pk_stroke_pull):' % '{:,}'.format(tot))
        for f in DENSE_FNS:
            calls, c = fnc(prof, f)[:2]
            print('    %5.1f%%  %-22s %8d calls %8d' % (100.0 * c / tot, f, calls, c // max(1, calls)))


# PK_BENCH_ONLY=dense runs section 4 alone (for iterating on the main loop's cost).
ONLY = os.environ.get('PK_BENCH_ONLY', '')
if ONLY not in ('', 'dense'):
    sys.exit('bench-avr: PK_BENCH_ONLY must be empty or "dense", not %r' % ONLY)
STEP_VECTOR = {'uno-cnc-shield': 11, 'mega-ramps': 32}
# compare B of the step timer: the end of each step pulse (hal/avr/pk_avr_timer.c)
PULSE_VECTOR = {'uno-cnc-shield': 12, 'mega-ramps': 33}
OFFS = {}


def main():
    flower = open('host-sim/examples/flower.gcode').read()
    strokes = open('tests/avr/strokes.gcode').read()
    with tempfile.TemporaryDirectory() as tmp:
        for b in BOARDS:
            hexf = os.path.join(BUILD, 'firmware', b, b + '.hex')
            elf = os.path.join(BUILD, 'firmware', b, b + '.elf')
            if not os.path.exists(hexf):
                impossible.append('%s: the image does not fit its part (see `make firmware`)' % b)
                continue
            syms = nm_syms(elf)
            so = nm_syms(os.path.join(BUILD, 'firmware', b, 'obj', 'fw_structs.o'))
            for k in ('sg_head', 'lines_planned'):
                OFFS[k] = so['pk_offsetof_' + k][1] - 1
            for need in ('app', 'pk_machine_timer_cb', 'pk_sg_prep', 'pk_grbl_poll'):
                if need not in syms:
                    impossible.append('%s: symbol %s missing from %s' % (b, need, elf))
            print('=' * 100)
            print('%s (%s), image %s' % (b, 'ATmega328P' if b.startswith('uno') else 'ATmega2560', hexf))
            if ONLY == 'dense':
                dense(b, tmp, elf)
                continue
            drawing(b, 'smoothed pen strokes (tests/avr/strokes.gcode)', strokes, [], tmp, elf, syms)
            drawing(b, 'the bundled example (host-sim/examples/flower.gcode)', flower, [], tmp, elf, syms)
            max_rate(b, tmp)
            f6 = re.sub(r'F3000', 'F6000', flower)
            ct, ht = os.path.join(tmp, 'f6chip.csv'), os.path.join(tmp, 'f6host.csv')
            d, err = avrsim(b, f6, [], tmp, ['--trace', ct])
            h = hostsim(b, f6, [], tmp, ['--trace', ht])
            if d is None or h is None:
                impossible.append('%s, flower at F6000: %s' % (b, err))
            else:
                print('\n%s: the bundled example at F6000, 80 steps/mm, smoothed: chip %.2f s, planned %.2f s'
                      ' (x%.3f), %d underruns' % (b, d['motion_s'], h['sim_time_s'], d['motion_s'] / h['sim_time_s'],
                                                   d['timer_starts'] - 1))
                sc, sh = stalls(ct), stalls(ht)
                print('  stalls while moving (pin trace: a step gap over 4x the intervals around it, > 1 ms, no pen'
                      ' change): chip %d (%.1f ms in all, longest %.1f ms), plotkin sim %d (%.1f ms, longest %.1f ms)'
                      % (sc + sh))
            dense(b, tmp, elf)
    if impossible:
        print('\nbench-avr: these measurements were impossible:')
        for m in impossible:
            print('  FAIL ' + m)
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())
