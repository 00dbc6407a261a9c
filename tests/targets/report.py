#!/usr/bin/python3
"""report.py — the figures `make targets` prints besides fwcheck's size table.

  report.py state OBJ...   kernel state size per target and configuration,
                           from the objects compiled from state_size.c
                           (named TARGET-CONFIG.o; arrays sized by sizeof)
  report.py image LABEL=MAP...
                           flash of a --gc-sections image per contributor
                           (kernel objects, libgcc helpers, start-up), read
                           from the GNU ld map file: only what was linked.
"""
import os
import re
import subprocess
import sys

NM = {'host': 'nm', 'm0plus': 'arm-none-eabi-nm', 'm4': 'arm-none-eabi-nm',
      'm3': 'arm-none-eabi-nm', 'avr': 'avr-nm'}
DEPTH = 8  # PK_MAX_DEPTH default; state_size.c does not override it
GOAL_PER_LEVEL = 32


def sym_sizes(nm, obj):
    out = subprocess.run([nm, '-S', obj], check=True, capture_output=True, text=True).stdout
    res = {}
    for ln in out.splitlines():
        f = ln.split()
        if len(f) == 4:
            res[f[3]] = int(f[1], 16)
    return res


def state(objs):
    print('Kernel state (sizeof, bytes; PK_MAX_DEPTH=%d; "level" = sizeof(struct pk_level), "stream/%d" ='
          ' the whole stream amortised over its %d levels; goal <= %d B/level/stream for 3 axes, judged on'
          ' both)' % (DEPTH, DEPTH, DEPTH, GOAL_PER_LEVEL))
    print('%-8s %-9s %8s %8s %8s %10s  %s' % ('target', 'config', 'stream', 'level', 'limit', 'stream/8', 'goal'))
    for obj in objs:
        tgt, cfg = os.path.basename(obj)[:-2].split('-', 1)
        s = sym_sizes(NM[tgt], obj)
        whole, lvl, lim = s['pk_size_refine'], s['pk_size_level'], s['pk_size_limit']
        per = whole / DEPTH
        verdict = ''
        if cfg.startswith('ax3'):
            v = ['met' if x <= GOAL_PER_LEVEL else 'missed by %g B' % (x - GOAL_PER_LEVEL) for x in (lvl, per)]
            verdict = 'level: %s; stream/%d: %s' % (v[0], DEPTH, v[1])
        win = 'PK_WIN=2' if 'win2' in cfg else 'PK_WIN=5'
        print('%-8s %-9s %8d %8d %8d %10.1f  %s' % (tgt, cfg.split('-')[0] + ' ' + win, whole, lvl, lim,
                                                   per, verdict))


SEC1 = re.compile(r'^ (\.[A-Za-z0-9_.$]+)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$')
SEC_NAME = re.compile(r'^ (\.[A-Za-z0-9_.$]+)$')
SEC2 = re.compile(r'^\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$')


def contributions(path, per_section=None):
    """{(file, kind): bytes} for the text/rodata/data input sections linked;
    per_section (a list), if given, receives (bytes, section, file)."""
    res = {}
    started = False
    pending = None
    with open(path) as f:
        for ln in f:
            ln = ln.rstrip('\n')
            if not started:
                started = ln.startswith('Linker script and memory map')
                continue
            name = size = who = None
            m = SEC1.match(ln)
            if m:
                name, size, who = m.group(1), int(m.group(3), 16), m.group(4)
            elif pending:
                m2 = SEC2.match(ln)
                if m2:
                    name, size, who = pending, int(m2.group(2), 16), m2.group(3)
            m3 = SEC_NAME.match(ln)
            pending = m3.group(1) if m3 else None
            if name is None or size == 0:
                continue
            if name.startswith(('.text', '.vectors')):
                kind = 'text'
            elif name.startswith('.rodata'):
                kind = 'rodata'
            elif name.startswith('.data'):
                kind = 'data'
            else:
                continue
            res[(who.strip(), kind)] = res.get((who.strip(), kind), 0) + size
            if per_section is not None:
                per_section.append((size, name, who.strip()))
    return res


def group(who):
    m = re.search(r'\(([^)]+)\)$', who)
    member = m.group(1) if m else os.path.basename(who)
    if 'libplotkin_fw.a' in who or '/firmware/' in who:
        return 'kernel/firmware ' + member
    if 'libgcc' in who:
        return 'libgcc ' + member
    return 'image ' + member


def image(specs):
    for spec in specs:
        label, path = spec.rsplit('=', 1)
        secs = []
        c = contributions(path, secs)
        rows = {}
        for (who, kind), n in c.items():
            g = group(who)
            rows.setdefault(g, {'text': 0, 'rodata': 0, 'data': 0})[kind] += n
        print('%s (flash bytes actually linked, %s)' % (label, os.path.basename(path)))
        fw = [0, 0]
        helpers = 0
        for g in sorted(rows):
            r = rows[g]
            print('  %-40s text %6d  rodata %5d  data %4d' % (g, r['text'], r['rodata'], r['data']))
            if g.startswith('kernel/'):
                fw[0] += r['text']
                fw[1] += r['rodata']
            if g.startswith('libgcc'):
                helpers += r['text'] + r['rodata']
        tot = fw[0] + fw[1]
        print('  kernel flash: text %d + rodata %d = %d B; with the libgcc helpers it pulls: %d B '
              '(goal <= 2048 B: %s)' % (fw[0], fw[1], tot, tot + helpers,
                                       'met' if tot + helpers <= 2048 else
                                       'MISSED by %d B' % (tot + helpers - 2048)))
        big = sorted((x for x in secs if group(x[2]).startswith('kernel/')), reverse=True)[:8]
        print('  largest kernel sections: ' + ', '.join('%s %d' % (n.split('.', 2)[-1], sz)
                                                        for sz, n, _ in big))


def main(argv):
    if len(argv) >= 1 and argv[0] == 'state':
        state(argv[1:])
        return 0
    if len(argv) >= 1 and argv[0] == 'image':
        image(argv[1:])
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
