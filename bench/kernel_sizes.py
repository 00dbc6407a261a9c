#!/usr/bin/python3
"""kernel_sizes.py — flash and state of every kernel build the README offers,
on the Cortex-M0+ and AVR (ATmega2560: the full build does not fit a 328P) (`make bench-sizes`, part of `make bench`).

    kernel_sizes.py --build build/kernel-sizes

For each build (PK_BUILD_* etc., the table below) and target it compiles the
kernel's sources (firmware/pk_refine*.c, pk_limit.c, pk_masks.c, pk_fixed.c;
-Os, -ffunction-sections) and links bench/kernel_image.c, a program that uses
the kernel as a library with its configuration read from volatile objects,
with --gc-sections: the M0+ image with tests/targets' start-up and linker
script, the AVR one with avr-libc's. The flash is read from the linker map
(tests/targets/report.py's accounting: the kernel's objects, text + rodata,
plus the libgcc helpers they pull in; start-up, the driver and memcpy/memset
not counted), the state as sizeof(struct pk_refine) from the image's symbol
table (the target's ABI). pk_refine_pull_block is not called by the driver,
so not linked (a product that uses it pays its size on top).
"""
import argparse
import importlib.util
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
KSRC = ['pk_refine.c', 'pk_refine_span.c', 'pk_refine_cascade.c', 'pk_refine_chaikin.c', 'pk_limit.c',
        'pk_masks.c', 'pk_fixed.c']
CHAIKIN = '-DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 -DPK_BUILD_CLOSED=0'
# name, flags, what it is (the README's build table)
BUILDS = [
    ('full', '', 'every scheme, end rule, closed curves, limit/tangents (default)'),
    ('full-2ax', '-DPK_AXES=2', 'the same, 2 axes'),
    ('full-nolimit', '-DPK_BUILD_LIMIT=0', 'every scheme, no limit stage'),
    ('splines', '-DPK_BUILD_DEGREES=0x0E -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x0A',
     'B-splines 1..3, clamped/no ends, closed, limit (no cascade)'),
    ('chaikin-limit', '-DPK_AXES=2 ' + CHAIKIN, 'Chaikin, clamped, limit/tangents, 2 axes'),
    ('chaikin-limit-d5', '-DPK_AXES=2 -DPK_MAX_DEPTH=5 ' + CHAIKIN,
     'the same to depth 5 (32-bit values)'),
    ('chaikin', '-DPK_AXES=2 -DPK_BUILD_LIMIT=0 ' + CHAIKIN, 'Chaikin, clamped, no limit, 2 axes'),
    ('chaikin-d5', '-DPK_AXES=2 -DPK_MAX_DEPTH=5 -DPK_BUILD_LIMIT=0 ' + CHAIKIN,
     'the same to depth 5 (32-bit values)'),
]
TARGETS = {
    'm0plus': {'cc': 'arm-none-eabi-gcc', 'nm': 'arm-none-eabi-nm',
               'flags': '-mcpu=cortex-m0plus -mthumb -mfloat-abi=soft'},
    'avr': {'cc': 'avr-gcc', 'nm': 'avr-nm', 'flags': '-mmcu=atmega2560 -DF_CPU=16000000UL'},
}
COMMON = ('-std=c11 -Os -g -ffreestanding -ffunction-sections -fdata-sections -fno-common -Wall -Wextra '
          '-Werror -Ifirmware -Ihal -Itests')


def load_report():
    spec = importlib.util.spec_from_file_location('report', os.path.join(ROOT, 'tests/targets/report.py'))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def sh(cmd):
    r = subprocess.run(cmd, shell=True, cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError('%s\n%s' % (cmd, r.stderr[-2000:]))
    return r.stdout


def build_one(out, name, flags, tgt, report):
    t = TARGETS[tgt]
    d = os.path.join(out, name, tgt)
    fw = os.path.join(d, 'firmware')  # '/firmware/' in the path: counted as kernel
    os.makedirs(fw, exist_ok=True)
    objs = []
    for src in KSRC:
        o = os.path.join(fw, src[:-2] + '.o')
        sh('%s %s %s %s -c firmware/%s -o %s' % (t['cc'], t['flags'], COMMON, flags, src, o))
        objs.append(o)
    drv = os.path.join(d, 'kernel_image.o')
    sh('%s %s %s %s -c bench/kernel_image.c -o %s' % (t['cc'], t['flags'], COMMON, flags, drv))
    elf, mp = os.path.join(d, 'image.elf'), os.path.join(d, 'image.map')
    if tgt == 'm0plus':
        extra = []
        for src in ('cm_start.c', 'cm_mini_libc.c'):
            o = os.path.join(d, src[:-2] + '.o')
            sh('%s %s %s -fno-builtin -fno-tree-loop-distribute-patterns -c tests/targets/%s -o %s'
               % (t['cc'], t['flags'], COMMON, src, o))
            extra.append(o)
        sh('%s %s -nostdlib -nostartfiles -Wl,--gc-sections -T tests/targets/cortexm.ld -Wl,-Map=%s -o %s %s %s '
           '-lgcc' % (t['cc'], t['flags'], mp, elf, ' '.join(extra + [drv]), ' '.join(objs)))
    else:
        sh('%s %s -Wl,--gc-sections -Wl,-Map=%s -o %s %s %s' % (t['cc'], t['flags'], mp, elf, drv, ' '.join(objs)))
    rows = {}
    for (who, kind), n in report.contributions(mp).items():
        g = report.group(who)
        if g.startswith(('kernel/', 'libgcc')) and kind in ('text', 'rodata'):
            rows[g] = rows.get(g, 0) + n
    kernel = sum(v for g, v in rows.items() if g.startswith('kernel/'))
    helpers = sum(v for g, v in rows.items() if g.startswith('libgcc'))
    state = None
    for ln in sh('%s -S %s' % (t['nm'], elf)).splitlines():
        f = ln.split()
        if len(f) == 4 and f[3] == 'pk_size_refine':
            state = int(f[1], 16)
    return kernel, helpers, state


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--build', default='build/kernel-sizes')
    a = ap.parse_args()
    report = load_report()
    out = os.path.abspath(a.build)
    print('Kernel builds: flash linked with --gc-sections (kernel text+rodata + the libgcc helpers it pulls in; '
          'start-up and memcpy/memset not counted) and state (sizeof(struct pk_refine)), bytes')
    print('%-17s %-58s | %14s %6s | %14s %6s' % ('build', 'carries', 'M0+ flash', 'state', 'AVR flash',
                                                  'state'))
    goal = []
    for name, flags, what in BUILDS:
        cells = []
        for tgt in ('m0plus', 'avr'):
            try:
                k, h, st = build_one(out, name, flags, tgt, report)
                cells.append((k, h, st))
            except RuntimeError as e:
                sys.stderr.write('kernel_sizes: %s/%s failed:\n%s\n' % (name, tgt, e))
                return 1
        (mk, mh, ms), (ak, ah, as_) = cells
        print('%-17s %-58s | %6d (%5d) %6d | %6d (%5d) %6d' % (name, what, mk + mh, mk, ms, ak + ah, ak, as_))
        if name.startswith('chaikin-limit'):
            goal.append((name, mk + mh))
    print('  (flash: total (of which kernel objects; the rest is libgcc); flags: PK_BUILD_*, PK_AXES, '
          'PK_MAX_DEPTH as in bench/kernel_sizes.py and the README)')
    for name, b in goal:
        print('  goal: Cortex-M0+ Chaikin + clamped + limit kernel <= 2048 B: %s %d B: %s'
              % (name, b, 'met' if b <= 2048 else 'MISSED by %d B' % (b - 2048)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
