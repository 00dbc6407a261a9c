#!/usr/bin/env bash
# board_refusals.sh — what a board image leaves out is refused with an error,
# never silently done less. Runs `plotkin sim` built with each AVR board's
# knobs (BUILD/firmware/<board>/host/plotkin: the same firmware/ sources and
# PK_* knobs as the image; only a host C compiler is needed) on programs that
# use G2/G3 arcs, G5/G5.1 splines, the FIXED smoothing mode ($200=1) and a
# line longer than Grbl's 79-byte line buffer on the ATmega328P.
# Uno (PK_BUILD_ARCS=0 PK_BUILD_G5=0 PK_STROKE_FIXED=0 PK_GRBL_LINE_MAX=79):
#   each such line is answered error:20 / error:11 / a refused setting, and
#   every other line still runs: the final position equals the run of the
#   same program without the refused lines, step for step.
# Mega (every scheme, 255-byte lines): the same program runs with no error.
# Every run must finish (a machine that stalls fails after 120 s).
set -uo pipefail
cd "$(dirname "$0")/../.."
BUILD=${PLOTKIN_BUILD:-build}
boards=$(ls -d hal/avr/*/board.mk 2>/dev/null | xargs -n1 dirname | xargs -n1 basename)
targets=""
for b in $boards; do targets="$targets $BUILD/firmware/$b/host/plotkin"; done
if ! out=$(${MAKE:-make} --no-print-directory -s BUILD="$BUILD" $targets 2>&1); then
  printf '%s\n' "$out" | tail -n 20
  echo "not ok the host tools with the boards' knobs build"; echo "0 passed, 1 failed"; exit 1
fi
exec /usr/bin/python3 - "$BUILD" $boards <<'PY'
import json, os, subprocess, sys, tempfile
BUILD, BOARDS = sys.argv[1], sys.argv[2:]
res = []
def check(name, cond, detail=''):
    res.append(bool(cond)); print(('ok ' if cond else 'not ok ') + name)
    if not cond and detail: print('  ' + str(detail)[:800])
def sim(tool, prog, td, name, *extra):
    path = os.path.join(td, name)
    open(path, 'w').write(prog)
    try:
        p = subprocess.run([tool, 'sim', path, '--json', '--axes', '2'] + list(extra),
                           capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        return None, None, 'plotkin sim did not finish within 120 s (a stalled machine)'
    try:
        return p.returncode, json.loads(p.stdout), p.stderr
    except ValueError:
        return p.returncode, None, p.stdout + p.stderr
# 89 significant bytes (Grbl drops blanks before counting)
LONG = 'G1 X12.' + '0' * 40 + ' Y3.' + '0' * 40 + ' F2000'
assert len(LONG.replace(' ', '')) > 79
# (line, expected Uno error); None: a line every build runs
PROG = [('G21 G90 G17 G64 P0.05', None), ('G1 X5 Y0 F3000', None), ('M3 S1000', None),
        ('G2 X10 Y0 I2.5 J0', 20), ('G1 X10 Y2', None), ('G3 X12 Y4 R2', 20),
        ('G1 X14 Y1', None), ('G5 I1 J1 P-1 Q1 X16 Y3', 20), ('G5.1 I1 J1 X18 Y0', 20),
        ('G1 X20 Y5', None), (LONG, 11), ('G1 X22 Y6', None), ('M5', None), ('G0 X0 Y0', None)]
text = ''.join(l + '\n' for l, _ in PROG)
kept = ''.join(l + '\n' for l, e in PROG if e is None)
want = {i + 1: e for i, (_, e) in enumerate(PROG) if e is not None}
with tempfile.TemporaryDirectory() as td:
    for b in BOARDS:
        tool = os.path.join(BUILD, 'firmware', b, 'host', 'plotkin')
        defs = open(os.path.join('hal/avr', b, 'board.mk')).read()
        small = '-DPK_BUILD_ARCS=0' in defs
        rc, j, err = sim(tool, text, td, b + '.gcode')
        if j is None:
            check(f'{b}: plotkin sim ran', False, err); continue
        got = {e['line']: e['error'] for e in j['error_lines']}
        if small:
            check(f'{b}: G2/G3, G5/G5.1 and an over-long line are refused (error:20, error:11)',
                  got == want and rc != 0, f'errors {got}, want {want}, exit {rc}')
            rk, jk, err = sim(tool, kept, td, b + '-kept.gcode')
            check(f'{b}: every other line still runs, smoothed (final position = the program without them)',
                  jk is not None and jk['errors'] == 0 and j['final_steps'] == jk['final_steps']
                  and j['steps'] == jk['steps'] and j['alarms'] == 0,
                  f"{j['final_steps']} {j['steps']} vs {jk and (jk['final_steps'], jk['steps'])}")
            rs, js, err = sim(tool, '$200=1\n$200=2\nG1 X3 Y1 F2000\n', td, b + '-set.gcode')
            check(f'{b}: $200=1 (FIXED smoothing, not built) is refused with an error, $200=2 accepted',
                  js is not None and [e['line'] for e in js['error_lines']] == [1]
                  and js['error_lines'][0]['error'] != 0 and js['final_steps'] != [0, 0],
                  js and js['error_lines'])
            cfg = os.path.join(td, b + '.conf')
            open(cfg, 'w').write('$200=1\n')
            p = subprocess.run([tool, 'sim', os.path.join(td, b + '-kept.gcode'), '--config', cfg],
                               capture_output=True, text=True, timeout=300)
            check(f'{b}: a machine configured with $200=1 does not start',
                  p.returncode != 0 and 'init failed' in p.stdout + p.stderr, p.stdout[-300:] + p.stderr)
        else:
            check(f'{b}: the same program runs with no error (every scheme built in)',
                  rc == 0 and j['errors'] == 0 and j['alarms'] == 0, f'errors {got}, exit {rc}')
print(f'{sum(res)} passed, {len(res) - sum(res)} failed')
sys.exit(0 if all(res) else 1)
PY
