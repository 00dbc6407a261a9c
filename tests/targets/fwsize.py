#!/usr/bin/python3
"""fwsize.py — the size table of `make firmware`, and its fit check.

  fwsize.py [--plotkin BUILD/plotkin] [--workload FILE] [--detail] [--hex-only]
            --board NAME:ARCH:BINPREFIX:FLASH_MAX:RAM_MAX:ELF[:STRUCTS.o] ...

(--hex-only: only write the HEX of the images that fit, print nothing, exit 0.)

For every board image (linked with relaxed memory regions, so that an image
that does not fit is still measured) it reads from the ELF and its linker map:
  flash = .text (+ .rodata, .ARM.exidx) + .data (what the bootloader writes),
  RAM   = .data + .bss + the stack measured at its deepest while the image
          runs the workload and the bundled example on an emulated chip
          (`plotkin avrsim`, simavr; only for images that fit their part),
and writes the Intel HEX next to the ELF when the image fits its flash and its
static RAM. It prints the table beside Grbl 1.1h's figures (same compiler),
then per image the flash and RAM of every module (from the map), the largest
symbols, the calls to 64-bit libgcc helpers per module, and the size of the
structs that hold the state (STRUCTS.o: tests/targets/fw_structs.c compiled
with the board's flags). In an image linked with link-time optimisation the
map names only the linker's partitions, so the modules are then those of the
symbols' source files (the debug information; code inlined across files
counts in the file of the function it went into).

Exit status 1 if any image does not fit (the table says by how much), or a
measurement that should have been possible failed.
"""
import json
import os
import re
import subprocess
import sys
import tempfile

GRBL = ('Grbl 1.1h', 29864, 1633)

SEC1 = re.compile(r'^ (\.[A-Za-z0-9_.$]+)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$')
SEC_NAME = re.compile(r'^ (\.[A-Za-z0-9_.$]+)$')
SEC2 = re.compile(r'^\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$')
OUT_SEC = re.compile(r'^(\.[A-Za-z0-9_.]+)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)')
HELPER64 = re.compile(r'^__\w*di[0-9]?(_s8)?$|^__u?divmod64|^__u?mulsidi3$'
                      r'|^__aeabi_(u?ldivmod|lmul|llsl|llsr|lasr|u?lcmp)$')
DIV64 = re.compile(r'^__(u?div|u?mod)di3$|^__u?divmod64|^__aeabi_u?ldivmod$')


def run(cmd):
    return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout


def module_of(path):
    m = re.search(r'\(([^)]+)\.o\)$', path)
    if m:  # library member: libgcc.a(_divdi3.o)
        lib = os.path.basename(path.split('(')[0])
        return lib.replace('.a', '')
    return os.path.basename(path).replace('.o', '')


def map_sections(path):
    """[(out_section, in_section, size, module)] of the map's allocated sections."""
    res, out, pending = [], None, None
    with open(path) as f:
        for ln in f:
            ln = ln.rstrip('\n')
            m = OUT_SEC.match(ln)
            if m:
                out = m.group(1)
                pending = None
                continue
            if out not in ('.text', '.data', '.bss', '.rodata', '.noinit'):
                continue
            m = SEC1.match(ln)
            if m:
                res.append((out, m.group(1), int(m.group(3), 16), module_of(m.group(4))))
                pending = None
                continue
            m = SEC_NAME.match(ln)
            if m:
                pending = m.group(1)
                continue
            m = SEC2.match(ln)
            if m and pending:
                res.append((out, pending, int(m.group(2), 16), module_of(m.group(3))))
                pending = None
    return [r for r in res if r[2] > 0]


def sections(binp, elf):
    sz = {}
    for ln in run([binp + 'size', '-A', elf]).splitlines():
        f = ln.split()
        if len(f) >= 2 and f[0].startswith('.') and f[1].isdigit():
            sz[f[0]] = int(f[1])
    return sz


def helper_calls(binp, elf):
    """{function: {helper: count}} from the disassembly."""
    calls, cur = {}, None
    for ln in run([binp + 'objdump', '-d', elf]).splitlines():
        m = re.match(r'^[0-9a-f]+ <([^>]+)>:$', ln)
        if m:
            cur = m.group(1)
            continue
        m = re.search(r'\s(?:r?call|jmp|rjmp|bl|b\.w)\s.*<([A-Za-z0-9_]+)>', ln)
        if m and cur and HELPER64.match(m.group(1)) and not HELPER64.match(cur):
            calls.setdefault(cur, {}).setdefault(m.group(1), 0)
            calls[cur][m.group(1)] += 1
    return calls


def symbols(binp, elf):
    res = []
    for ln in run([binp + 'nm', '-S', '--size-sort', elf]).splitlines():
        f = ln.split()
        if len(f) == 4:
            res.append((int(f[1], 16), f[2], f[3]))
    return res


def struct_sizes(binp, obj):
    res = {}
    for ln in run([binp + 'nm', '-S', obj]).splitlines():
        f = ln.split()
        if len(f) == 4 and f[3].startswith('pk_sizeof_'):
            res[f[3][len('pk_sizeof_'):]] = int(f[1], 16)
    return res


def func_module(mapsecs):
    res = {}
    for out, sec, size, mod in mapsecs:
        if out == '.text' and sec.startswith('.text.'):
            res[sec[len('.text.'):]] = mod
    return res


LTRANS = re.compile(r'\.ltrans\d*(\.ltrans)?$|^ltrans')


def base_name(name):
    """A symbol's name without the suffixes LTO and local statics add."""
    return re.sub(r'(\.(lto_priv|constprop|isra|part)\.\d+|\.\d+)+$', '', name)


def source_modules(binp, elf):
    """[(size, type, name, module, section kind)] of the image's symbols by source file: code
    from the line table (nm -l); data from the image's objects (the fat
    objects next to the ELF, obj/**.o), whose symbol tables name them."""
    objsyms = {}
    objdir = os.path.join(os.path.dirname(elf), 'obj')
    for root, _, files in os.walk(objdir):
        for fn in files:
            if not fn.endswith('.o') or fn == 'fw_structs.o' or 'tests' in root:
                continue
            for ln in run([binp + 'objdump', '-t', os.path.join(root, fn)]).splitlines():
                g = ln.split()
                if len(g) >= 5 and 'O' in g[1:-3] and re.match(r'\.(data|bss|rodata)', g[-3]):
                    sec = '.rodata' if g[-3].startswith('.rodata') else g[-3].split('.')[1]
                    objsyms.setdefault(base_name(g[-1]), set()).add((fn[:-2], sec))
    res = []
    for ln in run([binp + 'nm', '-l', '-S', '--defined-only', elf]).splitlines():
        f = ln.split('\t')
        g = f[0].split()
        if len(g) != 4:
            continue
        sec = '.text'
        if g[2] in 'tTwW':
            if len(f) < 2:
                continue
            mod = os.path.splitext(os.path.basename(f[1].rsplit(':', 1)[0]))[0]
        else:
            mods = objsyms.get(base_name(g[3]), set())
            if len(mods) != 1:
                continue
            mod, sec = next(iter(mods))
        res.append((int(g[1], 16), g[2], g[3], mod, sec))
    return res


def lto_modules(mapsecs, srcsyms):
    """Split the map's link-time-optimised partitions into source modules."""
    kind = {'.text': 'tTwW', '.data': 'dD', '.rodata': 'rR', '.bss': 'bB', '.noinit': 'bB'}
    res, lto_total = [], {}
    for out, sec, size, mod in mapsecs:
        if LTRANS.search(mod):
            lto_total[out] = lto_total.get(out, 0) + size
        else:
            res.append((out, sec, size, mod))
    for out, total in lto_total.items():
        got = 0
        for size, t, name, mod, sec in srcsyms:
            if t in kind.get(out, ''):
                res.append((out, sec + '.' + name, size, mod))
                got += size
        if total > got:
            res.append((out, out, total - got, '(LTO, no source)'))
    return res


def measure_stack(plotkin, hexf, board, workload, tmpdir):
    """Run the image on the emulated chip: the workload (every kind of line,
    realtime reports, a hold) and the bundled example (the deepest smoothing,
    at 10 steps/mm to keep it short; the geometry and so the kernel's work are
    the same). The deepest stack of the two, or an error text."""
    conf = os.path.join(tmpdir, 'stack.conf')
    with open(conf, 'w') as f:
        f.write('$100=10\n$101=10\n$102=10\n' + ('$202=2\n' if board.startswith('uno') else ''))
    runs = [[workload, '--at', '0.02:status', '--at', '0.3:status', '--at', '0.6:hold', '--at', '0.7:status',
             '--at', '1.5:resume'],
            ['host-sim/examples/flower.gcode', '--config', conf]]
    deepest = 0
    for r in runs:
        try:
            p = subprocess.run([plotkin, 'avrsim', hexf, '--board', board, '--json', '--timeout', '300', '--run'] + r,
                               capture_output=True, text=True, timeout=900)
            d = json.loads(p.stdout)
        except (OSError, ValueError, subprocess.TimeoutExpired) as e:
            return None, 'plotkin avrsim failed on %s: %s' % (r[0], e)
        if d.get('status') != 'finished':
            return None, 'the %s did not finish on the chip (%s, chip %s)' % (r[0], d.get('status'), d.get('chip'))
        deepest = max(deepest, d['stack_bytes'])
    return deepest, None


def fmt(n):
    return '{:,}'.format(n)


def main(argv):
    boards, plotkin, workload, detail, hex_only = [], None, None, False, False
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == '--board':
            f = argv[i + 1].split(':')
            boards.append(dict(name=f[0], arch=f[1], bin=f[2], flash_max=int(f[3]), ram_max=int(f[4]),
                               elf=f[5], structs=f[6] if len(f) > 6 else None))
            i += 2
        elif a == '--plotkin':
            plotkin = argv[i + 1]
            i += 2
        elif a == '--workload':
            workload = argv[i + 1]
            i += 2
        elif a == '--detail':
            detail = True
            i += 1
        elif a == '--hex-only':
            hex_only = True
            i += 1
        else:
            sys.exit('fwsize.py: unknown argument %s' % a)
    bad = 0
    rows, notes = [], []
    for b in boards:
        elf, binp = b['elf'], b['bin']
        sz = sections(binp, elf)
        text = sz.get('.text', 0) + sz.get('.ARM.exidx', 0) + sz.get('.rodata', 0)
        data, bss = sz.get('.data', 0), sz.get('.bss', 0) + sz.get('.noinit', 0)
        flash = text + data
        static = data + bss
        hexf = elf[:-4] + '.hex'
        fits_flash = flash <= b['flash_max']
        fits_static = static <= b['ram_max']
        if os.path.exists(hexf):
            os.remove(hexf)
        stack, why = None, None
        if fits_flash and fits_static:
            run([binp + 'objcopy', '-O', 'ihex', '-R', '.eeprom', '-R', '.fuse', '-R', '.lock',
                 '-R', '.signature', elf, hexf])
            if b['arch'] == 'avr' and not hex_only:
                if plotkin and workload:
                    with tempfile.TemporaryDirectory() as td:
                        stack, why = measure_stack(plotkin, hexf, b['name'], workload, td)
                else:
                    why = 'no plotkin avrsim given'
        verdict = []
        if not fits_flash:
            verdict.append('flash %s B over' % fmt(flash - b['flash_max']))
        if stack is not None:
            ram = static + stack
            if ram > b['ram_max']:
                verdict.append('RAM %s B over' % fmt(ram - b['ram_max']))
            ramtxt = '%s + %s + %s = %s / %s' % (fmt(data), fmt(bss), fmt(stack), fmt(ram), fmt(b['ram_max']))
        else:
            if not fits_static:
                verdict.append('static RAM %s B over' % fmt(static - b['ram_max']))
            ramtxt = '%s + %s + ? = %s+ / %s' % (fmt(data), fmt(bss), fmt(static), fmt(b['ram_max']))
            if why is None:
                why = 'stack not measured: the image cannot run on its part' if b['arch'] == 'avr' else \
                      'stack not measured (no emulator run for this arch)'
            if fits_flash and fits_static and b['arch'] == 'avr':
                verdict.append('stack not measured')
            notes.append('%s: %s' % (b['name'], why))
        fits = 'yes' if not verdict else 'no: ' + ', '.join(verdict)
        if verdict:
            bad = 1
        rows.append((b['name'], '%s / %s' % (fmt(flash), fmt(b['flash_max'])), ramtxt, fits))
        b.update(text=text, data=data, bss=bss, flash=flash, stack=stack)
    if hex_only:
        return 0
    print('make firmware: flash = .text + .data; RAM = .data + .bss + deepest stack (measured under simavr)')
    w = [max(len(r[k]) for r in rows + [('image', 'flash B (used / budget)', 'RAM B (data + bss + stack = total / budget)', 'fits')]) for k in range(4)]
    hdr = ('image', 'flash B (used / budget)', 'RAM B (data + bss + stack = total / budget)', 'fits')
    print('  '.join(h.ljust(w[k]) for k, h in enumerate(hdr)))
    for r in rows:
        print('  '.join(c.ljust(w[k]) for k, c in enumerate(r)))
    print('  '.join([GRBL[0].ljust(w[0]), fmt(GRBL[1]).ljust(w[1]), ('%s (data + bss)' % fmt(GRBL[2])).ljust(w[2]), '-']))
    print('  (Grbl 1.1h: gnea/grbl v1.1h.20190825 built with the same avr-gcc 5.4 for the ATmega328P)')
    for n in notes:
        print('  note: ' + n)
    for b in boards:
        if not detail:
            continue
        mapf = b['elf'][:-4] + '.map'
        secs = map_sections(mapf)
        srcsyms = None
        if any(LTRANS.search(m) for _, _, _, m in secs):
            srcsyms = source_modules(b['bin'], b['elf'])
            secs = lto_modules(secs, srcsyms)
        mods = {}
        for out, sec, size, mod in secs:
            e = mods.setdefault(mod, {'flash': 0, 'data': 0, 'bss': 0, 'const_ram': 0})
            if out == '.text':
                e['flash'] += size
            elif out in ('.data', '.rodata'):
                e['data'] += size
                e['flash'] += size
                if sec.startswith('.rodata'):
                    e['const_ram'] += size
            else:
                e['bss'] += size
        calls = helper_calls(b['bin'], b['elf'])
        fmod = func_module(secs)
        if srcsyms is not None:
            fmod.update({name: mod for _, t, name, mod, _ in srcsyms if t in 'tTwW'})
        mcalls = {}
        for fn, hs in calls.items():
            m = fmod.get(fn, '?')
            e = mcalls.setdefault(m, [0, 0])
            e[0] += sum(hs.values())
            e[1] += sum(v for h, v in hs.items() if DIV64.match(h))
        print('\n%s: flash %s B (.text %s + .data %s), static RAM %s B; per module (from %s%s):'
              % (b['name'], fmt(b['flash']), fmt(b['text']), fmt(b['data']), fmt(b['data'] + b['bss']),
                 os.path.basename(mapf), '' if srcsyms is None else
                 ' and the debug information: link-time optimised, code inlined across files counts in its caller'))
        print('  %-22s %8s %8s %10s %8s %12s' % ('module', 'flash', 'data', '(const)', 'bss', '64-bit calls'))
        for m, e in sorted(mods.items(), key=lambda kv: -(kv[1]['flash'] + kv[1]['data'] + kv[1]['bss'])):
            c = mcalls.get(m, [0, 0])
            print('  %-22s %8d %8d %10d %8d %6d (%d div)' % (m, e['flash'], e['data'], e['const_ram'], e['bss'],
                                                          c[0], c[1]))
        syms = symbols(b['bin'], b['elf'])
        print('  largest functions (flash B, 64-bit helper calls):')
        funcs = [s for s in syms if s[1] in 'tTwW']
        for size, _, name in sorted(funcs, reverse=True)[:16]:
            hs = calls.get(name, {})
            print('    %6d  %-28s %-10s %s' % (size, name, fmod.get(name, ''), ' '.join(
                '%s x%d' % (h, v) for h, v in sorted(hs.items(), key=lambda kv: -kv[1]))))
        print('  largest RAM objects (B):')
        objs = [s for s in syms if s[1] in 'dDbBrR']
        for size, t, name in sorted(objs, reverse=True)[:12]:
            print('    %6d  %-28s %s' % (size, name, 'const data copied to RAM' if t in 'dD' else 'zeroed'))
        if b['structs']:
            ss = struct_sizes(b['bin'], b['structs'])
            print('  struct sizes (B): ' + ', '.join('%s %d' % (k, v) for k, v in
                                                    sorted(ss.items(), key=lambda kv: -kv[1])))
    return bad


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
