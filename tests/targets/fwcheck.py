#!/usr/bin/python3
"""fwcheck.py — the gate of `make targets`: what the cross-compiled firmware
objects may reference, plus the size table.

The project promises a core with no heap, no stdio, no floating point and no
software divide on the step path. The compiler is the only reliable witness of
that promise on each instruction set, so this script reads the *objects* the
cross compilers produced (never the sources) and fails the build when one of
them

  * references an allocator (malloc/free/calloc/realloc/...) or stdio
    (printf family, puts, ...),
  * references a soft-float helper (__aeabi_f*/__aeabi_d* on Arm, __addsf3,
    __mulsf3, __fixsfsi, ... on AVR) or a libm function,
  * contains a floating-point instruction (targets built with a hardware FPU:
    any v* mnemonic in Thumb code on a Cortex-M4 is a VFP instruction). GCC
    also uses the FPU registers as scratch for 64-bit integer moves (vldr,
    vstr, vpush, vpop, vmov): those are not float operations and are only
    noted (they need the FPU enabled, and cost lazy stacking in an ISR;
    -mgeneral-regs-only removes them),
  * owns mutable static storage (.data/.bss: the core keeps its state in
    caller-owned context structs),
  * or, for the step path (objects given with --step-obj, functions given with
    --step-func, followed through their direct calls across the objects),
    references a software divide helper (__aeabi_idiv, __aeabi_uldivmod,
    __divmodsi4, __udivdi3, ...).

Board images (hal/firmware.mk) are checked with the same rules, their HAL and
board objects included: the step path then starts at the board's step-timer
interrupt handler too, and mutable static storage is allowed only for the
symbols named with --allow-static OBJ.o:SYMBOL (the image's one controller
and its backend instance, which interrupt handlers reach without an
argument); any other static in any object still fails.

Usage (see tests/targets/module.mk, hal/firmware.mk):
  fwcheck.py [--step-obj NAME.o]... [--step-func FN]... [--allow-static OBJ.o:SYM]...
             --target NAME:TOOLPREFIX:FPU(yes|no):OBJ...  (one per target)
Exit status: 0 clean, 1 a rule was broken (each violation is listed).
It also prints the size table: flash = text + rodata, RAM = data + bss, per
object and per target (bytes; -ffunction-sections objects, before linking,
so the figures are upper bounds of what a --gc-sections link keeps).
"""
import os
import re
import subprocess
import sys

HEAP = re.compile(r'^_?(malloc|free|calloc|realloc|reallocarray|aligned_alloc|posix_memalign|'
                  r'memalign|valloc|sbrk|_malloc_r|_free_r|_calloc_r|_realloc_r|_sbrk_r)$')
STDIO = re.compile(r'^_?_?(v?(s|sn|f|d|as)?i?printf(_r|_chk)?|puts|putchar|fputs|fputc|putc|'
                   r'fwrite|fflush|fopen|perror)$')
FLOAT = re.compile(r'^__aeabi_(f[a-z0-9]+|d[a-z0-9]+|u?[il]2[fd]|ul2[fd])$'
                   r'|^__(add|sub|mul|div|neg|cmp|eq|ne|lt|le|gt|ge|unord|pow)[sdtx]f[23]$'
                   r'|^__(fix|fixuns)[sdtx]f[sdt]i$|^__float(un)?[sdt]i[sdtx]f$'
                   r'|^__(extend|trunc)[sdtx]f[sdtx]f2$|^__fp_[a-z0-9_]+$'
                   r'|^(sqrt|cbrt|hypot|sin|cos|tan|asin|acos|atan|atan2|sinh|cosh|tanh|exp|exp2|'
                   r'log|log2|log10|pow|floor|ceil|round|lround|llround|trunc|rint|lrint|fmod|'
                   r'fabs|fmin|fmax|modf|frexp|ldexp)[fl]?$')
DIVIDE = re.compile(r'^__aeabi_(u?idiv(mod)?|u?ldivmod)$|^__(u?div|u?mod)[qhsdt]i3$'
                    r'|^__u?divmod[qhsdt]i4$|^__udivmoddi4$|^__gnu_u?ldivmod_helper$')
# A Thumb-2 FPU instruction line in `objdump -d`: "  1c:\tee07 0a90 \tvmov\ts14, r0".
FPU_INSN = re.compile(r'^\s*[0-9a-f]+:\s+[0-9a-f ]+\s+(v[a-z0-9.]+)\b')
FPU_MOVES = {'vldr', 'vstr', 'vpush', 'vpop', 'vmov', 'vldm', 'vstm', 'vldmia', 'vstmia', 'vldmdb',
             'vstmdb', 'vmrs', 'vmsr'}


def run(cmd):
    return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout


def undefined(prefix, obj):
    out = run([prefix + 'nm', '-u', obj])
    return [ln.split()[-1] for ln in out.splitlines() if ln.strip()]


def sections(prefix, obj):
    """{section name: size} for the allocated sections of an object."""
    out = run([prefix + 'size', '-A', obj])
    res = {}
    for ln in out.splitlines():
        f = ln.split()
        if len(f) >= 2 and f[0].startswith('.') and f[1].isdigit():
            res[f[0]] = res.get(f[0], 0) + int(f[1])
    return res


def classify(name):
    for key, pfx in (('text', ('.text',)), ('rodata', ('.rodata', '.progmem')),
                     ('data', ('.data', '.sdata')), ('bss', ('.bss', '.sbss', '.noinit'))):
        if name == pfx[0] or any(name.startswith(p + '.') or name == p for p in pfx):
            return key
    return None


def relocs_by_section(prefix, obj):
    """{'.text.fn': [target symbol, ...]} from `objdump -r`."""
    out = run([prefix + 'objdump', '-r', obj])
    res, cur = {}, None
    for ln in out.splitlines():
        m = re.match(r'^RELOCATION RECORDS FOR \[(.*)\]:', ln)
        if m:
            cur = m.group(1)
            res.setdefault(cur, [])
            continue
        f = ln.split()
        if cur and len(f) >= 3 and re.match(r'^[0-9a-f]+$', f[0]):
            res[cur].append(re.sub(r'[+-]0x[0-9a-f]+$', '', f[2]))
    return res


def text_sections(prefix, obj):
    return {n for n in sections(prefix, obj) if n.startswith('.text.')}


def global_functions(prefix, obj):
    out = run([prefix + 'nm', '--defined-only', '-g', obj])
    return {ln.split()[-1] for ln in out.splitlines() if len(ln.split()) == 3 and ln.split()[1] in 'TW'}


def step_closure(prefix, objs, roots):
    """Walk the direct calls from the root functions, across the objects of
    one target (static functions stay inside their object; calls through
    function pointers, e.g. the HAL ops, cannot be followed).
    Returns ({external symbol: call chain}, [roots not found])."""
    rel = {o: relocs_by_section(prefix, o) for o in objs}
    secs = {o: text_sections(prefix, o) for o in objs}
    owner = {}
    for o in objs:
        for fn in global_functions(prefix, o):
            owner.setdefault(fn, o)
    seen, ext, missing, stack = set(), {}, [], []
    for r in roots:
        if r in owner:
            stack.append((owner[r], r, [r]))
        else:
            missing.append(r)
    while stack:
        obj, fn, chain = stack.pop()
        if (obj, fn) in seen:
            continue
        seen.add((obj, fn))
        for tgt in rel[obj].get('.text.' + fn, []):
            name = tgt[len('.text.'):] if tgt.startswith('.text.') else tgt
            if '.text.' + name in secs[obj]:
                stack.append((obj, name, chain + [name]))
            elif name in owner:
                stack.append((owner[name], name, chain + [name]))
            else:
                ext.setdefault(name, chain + [name])
    return ext, missing


def static_symbols(prefix, obj):
    """Symbols defined in .data/.bss (nm types d D b B)."""
    out = run([prefix + 'nm', '--defined-only', obj])
    return {ln.split()[-1] for ln in out.splitlines() if len(ln.split()) == 3 and ln.split()[1] in 'dDbB'}


def main(argv):
    targets, step_objs, step_funcs = [], [], []
    allowed = {}
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == '--allow-static':
            o, sym = argv[i + 1].split(':')
            allowed.setdefault(o, set()).add(sym)
            i += 2
        elif a == '--step-obj':
            step_objs.append(argv[i + 1]); i += 2
        elif a == '--step-func':
            step_funcs.append(argv[i + 1]); i += 2
        elif a == '--target':
            name, prefix, fpu = argv[i + 1].split(':')
            objs = []
            i += 2
            while i < len(argv) and not argv[i].startswith('--'):
                objs.append(argv[i]); i += 1
            targets.append((name, prefix, fpu == 'yes', objs))
        else:
            print('fwcheck: unknown argument ' + a, file=sys.stderr)
            return 2
    bad, notes = [], []
    table = []  # (target, object, text, rodata, data, bss)
    for name, prefix, fpu, objs in targets:
        for obj in objs:
            base = os.path.basename(obj)
            for sym in undefined(prefix, obj):
                for rx, what in ((HEAP, 'heap allocator'), (STDIO, 'stdio'),
                                 (FLOAT, 'floating point (soft-float helper or libm)')):
                    if rx.match(sym):
                        bad.append('%s %s: references %s: %s' % (name, base, what, sym))
            if fpu:
                moves = 0
                for ln in run([prefix + 'objdump', '-d', obj]).splitlines():
                    m = FPU_INSN.match(ln)
                    if m and m.group(1).split('.')[0] in FPU_MOVES:
                        moves += 1
                    elif m:
                        bad.append('%s %s: floating-point instruction: %s' % (name, base, ln.strip()))
                if moves:
                    notes.append('%s %s: %d FPU-register moves (64-bit integer data through d-registers;'
                                 ' no float arithmetic)' % (name, base, moves))
            secs = sections(prefix, obj)
            sz = {'text': 0, 'rodata': 0, 'data': 0, 'bss': 0}
            for s, n in secs.items():
                k = classify(s)
                if k:
                    sz[k] += n
            if sz['data'] or sz['bss']:
                syms = static_symbols(prefix, obj)
                extra = sorted(syms - allowed.get(base, set()))
                if extra or not syms:
                    bad.append('%s %s: mutable static storage (data %d B, bss %d B%s): firmware state '
                               'belongs in caller-owned context structs'
                               % (name, base, sz['data'], sz['bss'],
                                  ': ' + ', '.join(extra) if extra else ''))
                else:
                    notes.append('%s %s: static storage allowed for %s (data %d B, bss %d B)'
                                 % (name, base, ', '.join(sorted(syms)), sz['data'], sz['bss']))
            table.append((name, base, sz['text'], sz['rodata'], sz['data'], sz['bss']))
            if base in step_objs:
                for sym in undefined(prefix, obj):
                    if DIVIDE.match(sym):
                        bad.append('%s %s: software divide in a step-path object: %s' % (name, base, sym))
        for o in allowed:
            if not any(os.path.basename(x) == o for x in objs):
                bad.append('%s: --allow-static names %s, which is not among the objects' % (name, o))
        for so in step_objs:
            if not any(os.path.basename(o) == so for o in objs):
                bad.append('%s: step-path object %s not built (renamed? update TARGETS_STEP_OBJS)' % (name, so))
        if step_funcs:
            ext, missing = step_closure(prefix, objs, step_funcs)
            for sym, chain in sorted(ext.items()):
                if DIVIDE.match(sym) or FLOAT.match(sym):
                    bad.append('%s: step path calls %s: %s' % (name, sym, ' -> '.join(chain)))
            for fn in missing:
                bad.append('%s: step-path function %s not found (renamed? update TARGETS_STEP_FUNCS)'
                           % (name, fn))

    print('Firmware size per object (bytes; flash = text+rodata, RAM = data+bss; before --gc-sections)')
    print('%-10s %-24s %7s %7s %7s %7s %7s' % ('target', 'object', 'text', 'rodata', 'flash', 'RAM', ''))
    for name, _, _, objs in targets:
        tot = [0, 0, 0, 0]
        for t, base, tx, ro, da, bs in table:
            if t != name:
                continue
            print('%-10s %-24s %7d %7d %7d %7d' % (t, base, tx, ro, tx + ro, da + bs))
            tot = [tot[0] + tx, tot[1] + ro, tot[2] + da, tot[3] + bs]
        print('%-10s %-24s %7d %7d %7d %7d' % (name, '= total', tot[0], tot[1], tot[0] + tot[1],
                                               tot[2] + tot[3]))
    if step_objs or step_funcs:
        print('step path checked for software divide: objects %s, functions %s'
              % (' '.join(step_objs) or '-', ' '.join(step_funcs) or '-'))
    else:
        print('step path: none declared yet (TARGETS_STEP_OBJS / TARGETS_STEP_FUNCS empty)')
    for n in notes:
        print('note: ' + n)
    for b in bad:
        print('FWCHECK FAIL: ' + b)
    if bad:
        print('fwcheck: %d violation(s)' % len(bad))
        return 1
    print('fwcheck: no heap, no stdio, no floating point, %s%s'
          % ('no mutable statics but those allowed' if allowed else 'no mutable statics',
             ', no software divide on the step path' if (step_objs or step_funcs) else ''))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
