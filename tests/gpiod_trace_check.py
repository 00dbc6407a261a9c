#!/usr/bin/python3
"""Decode the mock chip's edge trace of plotkin-gpiod-mock (board_mock.h's
format: `t_ns due_ns line level initial`, real-clock times) into steps, on
its own (no plotkin code): every rising edge of an axis' step line is one
step, + when its direction line is high (dir_invert 0), - when low. Checks
the driver's timing on the real times (DRV8825: step high >= 1.9 us, low >=
1.9 us, direction set-up and hold >= 650 ns around a rising step edge) and
that every step edge was written by a step-timer callback.

usage: gpiod_trace_check.py TRACE STEP_X,STEP_Y DIR_X,DIR_Y STEPS_PER_MM X_MM Y_MM
Prints "ok ..."/"not ok ..." lines and "STEPS x y".
"""
import sys
from fractions import Fraction

trace, steps_s, dirs_s, spmm, x_mm, y_mm = sys.argv[1:7]
step_l = [int(v) for v in steps_s.split(",")]
dir_l = [int(v) for v in dirs_s.split(",")]
spmm = Fraction(spmm)
want = [Fraction(x_mm) * spmm, Fraction(y_mm) * spmm]
HIGH_NS, LOW_NS, SETUP_NS, HOLD_NS = 1900, 1900, 650, 650

level, last_change, pos = {}, {}, [0] * len(step_l)
last_rise = [None] * len(step_l)
viol, outside, edges, prev_t = [], 0, 0, -1
for row in open(trace):
    if row.startswith("#"):
        continue
    t, due, line, v, initial = (int(f) for f in row.split())
    if t < prev_t:
        viol.append(("time goes back", t))
    prev_t = t
    old = level.get(line)
    level[line] = v
    if initial:
        last_change[line] = t
        continue
    if old == v:
        continue
    if line in step_l:
        a = step_l.index(line)
        edges += 1
        if due < 0:
            outside += 1
        since = t - last_change.get(line, -10**18)
        if v == 1:
            if since < LOW_NS:
                viol.append(("step low", a, t, since))
            d_since = t - last_change.get(dir_l[a], -10**18)
            if d_since < SETUP_NS:
                viol.append(("dir setup", a, t, d_since))
            pos[a] += 1 if level.get(dir_l[a], 0) else -1
            last_rise[a] = t
        elif since < HIGH_NS:
            viol.append(("step high", a, t, since))
    elif line in dir_l:
        a = dir_l.index(line)
        if last_rise[a] is not None and t - last_rise[a] < HOLD_NS:
            viol.append(("dir hold", a, t, t - last_rise[a]))
    last_change[line] = t

print("STEPS " + " ".join(str(p) for p in pos))
ok = pos == want
print(("ok " if ok else "not ok ") +
      "the steps decoded from the mock's edges are the programmed end x steps/mm exactly")
if not ok:
    print("  decoded %s, programmed %s" % (pos, [str(w) for w in want]))
ok = edges > 0 and outside == 0
print(("ok " if ok else "not ok ") + "every step edge (%d) was written by a step-timer callback" % edges)
ok = not viol
print(("ok " if ok else "not ok ") + "no driver timing violation on the real clock (DRV8825 limits)")
if not ok:
    print("  %d violations, first: %s" % (len(viol), viol[:5]))
