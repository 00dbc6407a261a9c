#!/usr/bin/python3
"""avr_profile.py — where the main loop's cycles go on the chip, by function and source line.

usage: avr_profile.py [--build DIR] [--board NAME] [--top N] [--charge FN]... [PROGRAM.gcode [CONFIG]]

Runs a board image (default mega-ramps, as `make firmware` built it) under
`plotkin avrsim --hist-main` on PROGRAM (default: bench-avr's dense drawing,
bench/corpus/files/svg2gcode-smooth-curves.gcode at F6000, smoothed within
0.02 mm) and maps every cycle spent outside interrupts to the function and
source line of its flash address (avr-addr2line on the ELF). The cycles of a
library routine (libgcc's 64-bit multiply and divide, memcpy, ...) are charged
by the simulator to the call in plotkin's code that entered it, so a line
that divides shows the division's cost. Cycle counts are exact (simavr), so
before/after comparisons hold on a noisy machine.

--charge FN charges the function FN's cycles to its callers as well (e.g.
pk_isqrt64: which lines take square roots, and what they cost).

Prints two tables: functions (self cycles, libgcc folded in), then source
lines. A tool for working on the main loop's cost, not a pass/fail check.
"""
import collections
import os
import re
import subprocess
import sys
import tempfile

DENSE = 'bench/corpus/files/svg2gcode-smooth-curves.gcode'


def main():
    args = sys.argv[1:]
    build, board, top = 'build', 'mega-ramps', 30
    pos, charge = [], []
    while args:
        a = args.pop(0)
        if a == '--build':
            build = args.pop(0)
        elif a == '--board':
            board = args.pop(0)
        elif a == '--charge':
            charge += ['--charge-caller', args.pop(0)]
        elif a == '--top':
            top = int(args.pop(0))
        else:
            pos.append(a)
    elf = os.path.join(build, 'firmware', board, board + '.elf')
    hexf = os.path.join(build, 'firmware', board, board + '.hex')
    if not os.path.exists(hexf):
        sys.exit('avr_profile: %s missing (run `make firmware-build`)' % hexf)
    with tempfile.TemporaryDirectory() as tmp:
        if pos:
            prog = pos[0]
        else:
            prog = os.path.join(tmp, 'dense.gcode')
            open(prog, 'w').write('G64 P0.02\n' + re.sub(r'F300\b', 'F6000', open(DENSE).read()))
        hist = os.path.join(tmp, 'main.hist')
        cmd = [os.path.join(build, 'plotkin'), 'avrsim', hexf, '--board', board, '--run', prog, '--json',
               '--timeout', '900', '--elf', elf, '--hist-main', hist] + charge
        if len(pos) > 1:
            cmd += ['--config', pos[1]]
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode != 0 or not os.path.exists(hist):
            sys.exit('avr_profile: %s failed (rc %d): %s' % (' '.join(cmd), p.returncode, p.stderr[-400:]))
        rows = [ln.split() for ln in open(hist)]
    addrs = [r[0] for r in rows]
    cyc = [int(r[1]) for r in rows]
    out = subprocess.run(['avr-addr2line', '-f', '-a', '-e', elf] + addrs, capture_output=True, text=True,
                         check=True).stdout.splitlines()
    where = {}  # (avr-addr2line -a -f: address, function, file:line per address)
    for i in range(0, len(out) - 2, 3):
        a, fn, loc = out[i], out[i + 1], out[i + 2]
        where[int(a, 16)] = (fn, os.path.basename(loc.split(' ')[0]))
    tot = sum(cyc)
    if tot == 0:
        sys.exit('avr_profile: no main-loop cycles measured')
    fns, lines = collections.Counter(), collections.Counter()
    for a, c in zip(addrs, cyc):
        fn, loc = where.get(int(a, 16), ('?', '?'))
        fns[fn] += c
        lines[(fn, loc)] += c
    print('%s: main-loop cycles outside interrupts: %s (libgcc charged to its callers)' % (board, '{:,}'.format(tot)))
    print('  %6s %14s  %s' % ('share', 'cycles', 'function'))
    for f, c in fns.most_common(top):
        print('  %5.2f%% %14s  %s' % (100.0 * c / tot, '{:,}'.format(c), f))
    print('  %6s %14s  %s' % ('share', 'cycles', 'source line'))
    for (f, loc), c in lines.most_common(top):
        print('  %5.2f%% %14s  %s (%s)' % (100.0 * c / tot, '{:,}'.format(c), loc, f))
    return 0


if __name__ == '__main__':
    sys.exit(main())
