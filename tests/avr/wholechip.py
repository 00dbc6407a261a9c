#!/usr/bin/python3
"""The firmware images on emulated chips, against `plotkin sim` (whole-chip tests).

usage: wholechip.py BUILD BOARD...

For each board whose image fits its part (BUILD/firmware/<board>/<board>.hex
exists; `make firmware-images` writes it only then), the very HEX that would be
flashed runs under simavr (`plotkin avrsim`, which feeds the serial port with
Grbl character counting and decodes the board's pins), and the same program
with the same settings runs through `plotkin sim` built with the board's size
knobs (BUILD/firmware/<board>/host/plotkin). Checked per run:
  - every line answered ok, no alarm (except after the reset asked for);
  - the same number of steps per axis and the same final position, exactly;
  - 0 driver timing violations (DRV8825), no step while a driver is disabled;
  - the firmware's own final report (MPos) equals the position decoded from
    the pins, exactly; the deepest stack stays clear of .data + .bss;
  - the pen servo's frame and pulse widths are the board's;
  - feed hold: the machine stops, reports exactly where the pins say it is,
    does not move until resumed, and then ends exactly where the unheld run
    ends; soft reset in motion: ALARM:3, the greeting again, and the reported
    position equals the decoded one.
On a board with input lines (INPUT_BOARDS): homing, a hard limit tripping
mid-move and a probe cycle with switches along the decoded axes, against
`plotkin sim` with the same switches; settings kept in the EEPROM across two
runs of the chip (a power cycle).
Every board's backend also runs alone (tests/avr/hal_selftest.c: step timer,
pins, serial line, servo), so a board whose full image does not fit its part
yet is still exercised on its chip.
A smoothed run's step counts are exact only while the chip keeps up: the
motion core ends a stroke early when its queue runs empty (pk_machine_poll),
so an image whose main loop underruns the step timer draws a slightly
different curve. For those runs the counts are compared exactly when the
chip had no underrun, and otherwise the difference is printed (the final
position must still be exact).
Prints "ok ..." / "not ok ..." per check and "N passed, N failed" last.
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
# Settings each board's build needs beside the defaults: the Uno's kernel
# holds Chaikin only (PK_WIN=2), i.e. B-spline degree 2.
BOARD_CONFIG = {'uno-cnc-shield': ['$202=2'], 'mega-ramps': []}
# Pen servo as hal/avr/<board>/board.h makes it: frame ms, pulse us at 0 and full.
SERVO = {'uno-cnc-shield': (20.48, 1000.0, 2000.0, 16.0), 'mega-ramps': (20.0, 1000.0, 2000.0, 0.5)}

results = []


def check(name, cond, detail=''):
    results.append(bool(cond))
    print(('ok ' if cond else 'not ok ') + name)
    if not cond and detail:
        print('  ' + str(detail)[:600])


def run(cmd, timeout=600):
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    try:
        return json.loads(p.stdout), p
    except ValueError:
        return None, p


def static_ram(board):
    elf = os.path.join(BUILD, 'firmware', board, board + '.elf')
    out = subprocess.run(['avr-size', '-A', elf], capture_output=True, text=True, check=True).stdout
    sz = {f[0]: int(f[1]) for f in (ln.split() for ln in out.splitlines()) if len(f) >= 2 and f[1].isdigit()}
    return sz.get('.data', 0) + sz.get('.bss', 0) + sz.get('.noinit', 0)


def write(tmp, name, text):
    path = os.path.join(tmp, name)
    with open(path, 'w') as f:
        f.write(text)
    return path


def hal_selftest(board, tmp):
    """The board's backend alone (tests/avr/hal_selftest.c) on its part: runs
    even while the full image does not fit."""
    hexf = os.path.join(BUILD, 'firmware', board, 'hal_selftest.hex')
    conf = write(tmp, 'st.conf', '$100=100\n')
    gc = write(tmp, 'st.gcode', 'S0\nX300\nS65535\nX200\nS32768\nX100\nS0\n')
    got, cp = run([PLOTKIN, 'avrsim', hexf, '--board', board, '--config', conf, '--run', gc, '--json'])
    tag = '%s: the backend alone (HAL self-test image)' % board
    if got is None:
        check(tag + ': avrsim reports', False, cp.stderr[-300:])
        return
    check(tag + ': 600 X steps from the step timer, exactly, with no timing violation',
          got['status'] == 'finished' and got['steps'] == [600, 0, 0] and got['final_steps'] == [600, 0, 0] and
          got['timing_violations'] == 0 and got['steps_while_disabled'] == 0 and got['stopped_exact'] == 1,
          {k: got[k] for k in ('status', 'steps', 'final_steps', 'violations', 'status_report')})
    frame, w0, w1, res = SERVO[board]
    sv = got['servo']
    want = [w0, w1, (w0 + w1) / 2, w0]
    check(tag + ': servo values 0, full, half, 0 give %s us pulses every %.2f ms' % (want, frame),
          len(sv['widths_us']) == 4 and all(abs(a - b) <= res for a, b in zip(sv['widths_us'], want)) and
          abs(sv['period_ms'][0] - frame) < 0.01 and abs(sv['period_ms'][1] - frame) < 0.01 and
          got['pen_changes'] == 2, sv)


def one_board(board, tmp):
    hal_selftest(board, tmp)
    hexf = os.path.join(BUILD, 'firmware', board, board + '.hex')
    host = os.path.join(BUILD, 'firmware', board, 'host', 'plotkin')
    if not os.path.exists(hexf):
        print('# %s: the image does not fit its part (see `make firmware`): not run' % board)
        return
    cfg = BOARD_CONFIG.get(board, [])
    strokes = open('tests/avr/strokes.gcode').read()
    runs = [
        # (name, program, extra settings, --at events, smoothed)
        ('the bundled example (10 steps/mm)', open('host-sim/examples/flower.gcode').read(),
         ['$100=10', '$101=10', '$102=10'], [], True),
        ('pen strokes, smoothed within 0.05 mm', strokes, [], [], True),
        ('pen strokes, exact path (G61)', re.sub(r'G64 P[0-9.]+', 'G61', strokes), [], [], False),
    ]
    square = open('tests/avr/realtime.gcode').read()
    for name, prog, extra, at, smoothed in runs:
        conf = write(tmp, 'conf', '\n'.join(cfg + extra) + '\n')
        gc = write(tmp, 'prog.gcode', prog)
        want, hp = run([host, 'sim', gc, '--config', conf, '--json'])
        got, cp = run([PLOTKIN, 'avrsim', hexf, '--board', board, '--config', conf, '--run', gc, '--json',
                       '--timeout', '300'])
        tag = '%s: %s' % (board, name)
        if want is None or got is None:
            check(tag + ': both simulators report', False, (hp.stderr[-300:], cp.stderr[-300:]))
            continue
        check(tag + ': runs to the end, every line ok, no alarm',
              got['status'] == 'finished' and got['errors'] == 0 and got['config_errors'] == 0 and
              got['alarms'] == 0 and got['ok'] == got['lines'] and want['status'] == 'finished',
              {k: got[k] for k in ('status', 'chip', 'errors', 'error_lines', 'alarms', 'lines', 'ok')})
        axes = len(want['steps'])
        underruns = got['timer_starts'] - 1
        same_steps = got['steps'][:axes] == want['steps']
        if smoothed and underruns > 0 and not same_steps:
            print('# %s: the chip underran %d times; steps %s vs plotkin sim %s (timing-dependent stroke'
                  ' ends, see the file comment)' % (tag, underruns, got['steps'][:axes], want['steps']))
        else:
            check(tag + ': the same steps per axis as plotkin sim', same_steps,
                  (got['steps'], want['steps'], 'underruns %d' % underruns))
        check(tag + ': the same final position as plotkin sim, exactly',
              got['final_steps'][:axes] == want['final_steps'], (got['final_steps'], want['final_steps']))
        check(tag + ': 0 timing violations, no step with a driver disabled',
              got['timing_violations'] == 0 and got['steps_while_disabled'] == 0 and
              want['timing_violations'] == 0, got['violations'])
        check(tag + ': the firmware reports the position the pins show',
              got['stopped_reports'] == 1 and got['stopped_exact'] == 1, got['status_report'])
        frame, w0, w1, res = SERVO[board]
        sv = got['servo']
        check(tag + ': the pen servo pulses every %.2f ms, %g..%g us' % (frame, w0, w1),
              sv['pulses'] > 0 and abs(sv['period_ms'][0] - frame) < 0.01 and
              abs(sv['period_ms'][1] - frame) < 0.01 and abs(sv['width_us'][0] - w0) <= res and
              abs(sv['width_us'][1] - w1) <= res and got['pen_changes'] >= 2, (sv, got['pen_changes']))
        static = static_ram(board)
        check(tag + ': the deepest stack stays clear of .data + .bss (%d B)' % static,
              static + got['stack_bytes'] <= got['ram_bytes'], (static, got['stack_bytes'], got['ram_bytes']))
        print('# %s: motion %.2f s on the chip, plotkin sim %.2f s; %d underruns; stack %d B'
              % (tag, got['motion_s'], want['sim_time_s'], underruns, got['stack_bytes']))
    # realtime bytes on the chip
    conf = write(tmp, 'conf', '\n'.join(cfg) + '\n')
    gc = write(tmp, 'square.gcode', square)
    want, _ = run([host, 'sim', gc, '--config', conf, '--json'])
    got, cp = run([PLOTKIN, 'avrsim', hexf, '--board', board, '--config', conf, '--run', gc, '--json',
                   '--at', '1.0:hold', '--at', '1.6:resume'])
    tag = '%s: feed hold and resume' % board
    if want is None or got is None:
        check(tag + ': both simulators report', False, cp.stderr[-300:])
    else:
        check(tag + ': ! stops the machine where the pins say, and it stays stopped',
              got['hold_checks'] == 1 and got['hold_exact'] == 1 and got['hold_still'] == 1,
              {k: got[k] for k in ('hold_checks', 'hold_exact', 'hold_still')})
        check(tag + ': ~ resumes and ends exactly as the unheld run',
              got['status'] == 'finished' and got['steps'][:len(want['steps'])] == want['steps'] and
              got['final_steps'][:len(want['steps'])] == want['final_steps'] and got['stopped_exact'] == 1
              and got['timing_violations'] == 0, (got['steps'], want['steps'], got['status_report']))
    got, cp = run([PLOTKIN, 'avrsim', hexf, '--board', board, '--config', conf, '--run', gc, '--json',
                   '--at', '1.0:reset'])
    tag = '%s: soft reset in motion' % board
    if got is None:
        check(tag + ': avrsim reports', False, cp.stderr[-300:])
    else:
        check(tag + ': ctrl-X raises ALARM:3 and greets again',
              got['alarm'] == 3 and got['greetings'] == 2 and got['final_state'] == 'Alarm',
              {k: got[k] for k in ('alarm', 'greetings', 'final_state', 'status_report')})
        check(tag + ': the machine stops where the firmware says it is, exactly',
              got['stopped_exact'] == 1 and got['timing_violations'] == 0 and
              any(got['final_steps']) and got['final_steps'] != want['final_steps'],
              (got['final_steps'], got['status_report']))
    # the pen servo follows M3 S (Grbl's $30 = 1000): down at S250 = a quarter
    # of the range, up, down at S1000 = the far end, up
    conf = write(tmp, 'conf', '\n'.join(cfg) + '\n')
    gc = write(tmp, 'servo.gcode', 'G21\nM3 S250\nG1 X2 F1000\nM5\nM3 S1000\nG1 X0\nM5\n')
    got, cp = run([PLOTKIN, 'avrsim', hexf, '--board', board, '--config', conf, '--run', gc, '--json'])
    frame, w0, w1, res = SERVO[board]
    want_w = [w0, w0 + (w1 - w0) / 4, w0, w1, w0]
    ws = got['servo']['widths_us'] if got else []
    check('%s: the pen servo goes down at the M3 S width and up at M5' % board,
          got is not None and got['status'] == 'finished' and len(ws) == len(want_w) and
          all(abs(a - b) <= res + 0.2 for a, b in zip(ws, want_w)), (ws, want_w))
    # faster than the chip keeps up: one X move at 17,000 steps/s underruns
    # the step ring, and every step must still come out, exactly (the step
    # interrupt once ran its callback inside itself under this load and lost
    # 189 of these 8,540 steps, the firmware's own position short as well)
    conf = write(tmp, 'conf', '\n'.join(cfg + ['$100=80', '$110=30000', '$120=50000', '$200=0']) + '\n')
    gc = write(tmp, 'fast.gcode', 'G21 G91 G61\nG1 X106.75 F12750\nM2\n')
    want, hp = run([host, 'sim', gc, '--config', conf, '--json'])
    got, cp = run([PLOTKIN, 'avrsim', hexf, '--board', board, '--config', conf, '--run', gc, '--json'])
    tag = '%s: one X move at 17,000 steps/s' % board
    if want is None or got is None:
        check(tag + ': both simulators report', False, (hp.stderr[-300:], cp.stderr[-300:]))
    else:
        axes = len(want['steps'])
        check(tag + ': every step, the same final position as plotkin sim and the firmware\'s report,'
              ' exactly, 0 timing violations',
              got['status'] == 'finished' and got['alarms'] == 0 and got['steps'][:axes] == want['steps']
              and got['final_steps'][:axes] == want['final_steps'] and got['stopped_exact'] == 1
              and got['timing_violations'] == 0,
              (got['steps'], want['steps'], got['status_report'], 'underruns %d' % (got['timer_starts'] - 1)))
    if board in INPUT_BOARDS:
        inputs_and_store(board, tmp, hexf, host, cfg)


# Boards whose image reads input lines (board.h PK_BOARD_INPUTS; the harness
# drives the same pins: host-sim/avr_chip.c).
INPUT_BOARDS = {'mega-ramps'}


def inputs_and_store(board, tmp, hexf, host, cfg):
    """Switches, probe and EEPROM on the chip: the images read the board's
    input pins (edges through INTn / pin change) and keep their settings in
    the EEPROM. The same switches go to `plotkin sim` (--switch), which must
    agree step for step."""
    def both(name, prog, conf_lines, switches, extra=()):
        conf = write(tmp, 'conf', '\n'.join(cfg + conf_lines) + '\n')
        gc = write(tmp, 'prog.gcode', prog)
        sw = [x for w in switches for x in ('--switch', w)]
        want, hp = run([host, 'sim', gc, '--config', conf, '--json'] + sw)
        got, cp = run([PLOTKIN, 'avrsim', hexf, '--board', board, '--config', conf, '--run', gc, '--json',
                       '--timeout', '120'] + sw + list(extra))
        tag = '%s: %s' % (board, name)
        if want is None or got is None:
            check(tag + ': both simulators report', False, (hp.stderr[-300:], cp.stderr[-300:]))
            return tag, None, None
        axes = len(want['steps'])
        check(tag + ': the same steps and final position as plotkin sim with the same switches',
              got['steps'][:axes] == want['steps'] and got['final_steps'][:axes] == want['final_steps'],
              (got['steps'], want['steps'], got['final_steps'], want['final_steps']))
        return tag, got, want
    travel = ['$130=300', '$131=300', '$132=50', '$27=1']
    tag, got, want = both('homing ($H) on the RAMPS min end stops',
                          '$H\nG0 X10 Y10\nG1 X20 Y12 F3000\n', travel + ['$22=1', '$23=7'],
                          ['limit-x:x:-0.5:-', 'limit-y:y:-0.5:-', 'limit-z:z:-0.5:-'])
    if got is not None:
        check(tag + ': every line ok, no alarm, MPos Z = -$132 + $27 = -49 after homing (Grbl)',
              got['status'] == 'finished' and got['ok'] == got['lines'] and got['alarms'] == 0 and
              got['status_report'].startswith('<Idle|MPos:20.000,12.000,-49.000'),
              {k: got[k] for k in ('status', 'ok', 'lines', 'alarms', 'status_report')})
    # at 5,657 steps/s per axis: a switch seen only by the main loop's polling
    # instead of its edge interrupt would stop steps late (the Y limit is
    # PJ1, the pin-change group the harness raises itself)
    for ax, other in (('x', 'Y'), ('y', 'X')):
        tag, got, want = both('hard limit ($21=1) on %s trips mid-move at F6000' % ax.upper(),
                              'G1 X100 Y100 F6000\n', ['$21=1', '$110=6000', '$111=6000'],
                              ['limit-%s:%s:50' % (ax, ax)])
        if got is None:
            continue
        i = 'xy'.index(ax)
        check(tag + ': ALARM:1, the report says Pn:%s and the position the pins show' % ax.upper(),
              got['alarm'] == 1 and want['alarm'] == 'hard limit' and got['final_state'] == 'Alarm' and
              '|Pn:%s' % ax.upper() in got['status_report'] and got['stopped_exact'] == 1 and
              got['final_steps'][i] == 4000,
              {k: got[k] for k in ('alarm', 'final_state', 'status_report', 'stopped_exact', 'final_steps')})
    tag, got, want = both('probe (G38.2) on the Z max end stop', 'G38.2 Z-10 F100\nG0 Z0\n', [],
                          ['probe:z:-3:-'])
    if got is not None:
        check(tag + ': [PRB:0.000,0.000,-3.000:1] and back at Z0',
              '[PRB:0.000,0.000,-3.000:1]' in got['messages'] and got['ok'] == got['lines'] and
              got['status_report'].startswith('<Idle|MPos:0.000,0.000,0.000'),
              (got['messages'], got['status_report']))
    # the EEPROM survives a power cycle: two runs of the chip on one EEPROM file
    ee = os.path.join(tmp, 'eeprom.bin')
    if os.path.exists(ee):
        os.remove(ee)
    tag = '%s: settings in the EEPROM' % board
    runs = []
    for prog in ('$110=1234\n$27=2.5\nG10 L2 P1 X7\n', '$$\n$#\n'):
        gc = write(tmp, 'prog.gcode', prog)
        got, cp = run([PLOTKIN, 'avrsim', hexf, '--board', board, '--run', gc, '--json', '--eeprom', ee,
                       '--timeout', '60'])
        runs.append(got)
        if got is None:
            check(tag + ': avrsim reports', False, cp.stderr[-300:])
            return
    first, second = runs
    check(tag + ': a blank EEPROM is restored to defaults, once',
          '[MSG:Restoring defaults]' in first['messages'] and
          '[MSG:Restoring defaults]' not in second['messages'], (first['messages'], second['messages']))
    check(tag + ': $110, $27 and G54 set before the power cycle are there after it',
          second['settings'].get('110') == '1234.000' and second['settings'].get('27') == '2.500' and
          '[G54:7.000,0.000,0.000]' in second['messages'],
          (second['settings'].get('110'), second['settings'].get('27'), second['messages']))


def main():
    if not os.path.exists(PLOTKIN):
        print('not ok %s exists' % PLOTKIN)
        print('0 passed, 1 failed')
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        for b in BOARDS:
            one_board(b, tmp)
    passed = sum(results)
    print('%d passed, %d failed' % (passed, len(results) - passed))
    return 0 if all(results) else 1


if __name__ == '__main__':
    sys.exit(main())
