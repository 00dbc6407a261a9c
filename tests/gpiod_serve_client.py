#!/usr/bin/python3
"""A Grbl sender for `plotkin-gpiod serve --link PTY` (the board binary's
test variant on the mock chip, in real time): what cncjs / UGS / stream.py do
on a Raspberry Pi, with the sender class of tests/serve_client.py (pyserial).

Character counting against the 128-byte receive buffer, '?' while streaming,
'!' / '~' in the middle of a stroke, Ctrl-X in motion, and a client that
vanishes with lines in flight. Every wait has a deadline. Positions are on a
0.025 mm grid (whole steps at 80 steps/mm) so every expected end is exact.

usage: gpiod_serve_client.py PTY_PATH
Prints "ok <name>" / "not ok <name>", then "END x y" (the final programmed
position, mm, for the trace decoder) and "N passed, N failed" last.
"""
import os
import sys
import time

# The sender of tests/serve_client.py (pyserial, Debian's python3-serial):
# its Grbl class, checks and status parsers; its main() does not run here.
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from serve_client import Grbl, check, mpos, near, results  # noqa: E402

PTY = sys.argv[1]
RX_BUFFER = 128


def moving(g, timeout=10.0):
    """Wait until the board runs and its position has left where it was."""
    st0 = g.wait_state({"Run"}, timeout)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        st = g.status()
        if st.startswith("<Run|") and mpos(st) != mpos(st0):
            return st
        time.sleep(0.01)
    raise TimeoutError("the board never moved (last %s)" % st)


def program(n, seed):
    """n G1 lines: a walk of short moves on the 0.025 mm grid."""
    lines, x, y = [], 1200, 1200
    for i in range(n):
        x += ((seed + i * 37) % 41) - 20
        y += ((seed * 3 + i * 53) % 39) - 19
        lines.append("G1 X%.3f Y%.3f F%d" % (x * 0.025, y * 0.025, 4000 + (i % 4) * 500))
    return lines, (x * 0.025, y * 0.025, 0.0)


def main():
    g = Grbl(PTY)
    g.write(b"\x18")
    banner, _ = g.wait_for(lambda l: l.startswith("Grbl "), 10)
    check("the board greets as Grbl 1.1 and names plotkin",
          banner.startswith("Grbl 1.1h [plotkin") and "'$' for help]" in banner, banner)
    g.write(b"$I\n")
    opt, _ = g.wait_for(lambda l: l.startswith("[OPT:"), 5)
    g.answer()
    check("$I advertises the 128-byte receive buffer", opt.endswith(",128]"), opt)

    # 1. Character counting, with '?' written between lines while streaming.
    t0 = time.monotonic()
    lines, end = program(150, 5)
    inflight, acks, i, reports = [], [], 0, []
    deadline = time.monotonic() + 60
    while len(acks) < len(lines):
        while i < len(lines) and sum(inflight) + len(lines[i]) + 1 <= RX_BUFFER:
            g.write((lines[i] + "\n").encode())
            inflight.append(len(lines[i]) + 1)
            i += 1
            if i % 25 == 0:
                g.write(b"?")  # realtime: takes no room in the 128 bytes
        line, _ = g.wait_for(lambda l: l == "ok" or l.startswith("error:") or l.startswith("<"),
                             max(1.0, deadline - time.monotonic()))
        if line.startswith("<"):
            reports.append(line)
            continue
        acks.append(0 if line == "ok" else int(line[6:]))
        inflight.pop(0)
    print("# 150 lines acknowledged in %.2f s" % (time.monotonic() - t0))
    check("150 character-counted lines are each acknowledged once with ok",
          len(acks) == 150 and all(a == 0 for a in acks), [a for a in acks if a][:10])
    check("'?' while streaming answers with a status report each time, out of band",
          len(reports) >= 5 and all(r.startswith(("<Run|", "<Idle|")) for r in reports), reports)
    st = g.wait_state({"Idle"}, 60)
    check("after the counted stream the board reports the programmed end exactly",
          near(mpos(st), end), (st, end))
    g.write(b"?")
    time.sleep(0.1)
    extra = g.s.read(g.s.in_waiting) + g.buf
    g.buf = b""
    check("no stray acknowledgement after the stream", b"ok" not in extra, extra)

    # 2. Feed hold and resume in the middle of a smoothed stroke.
    g.write(b"G64 P0.05\n")
    g.answer()
    stroke = ["G1 X%.3f Y%.3f F3000" % (10 + 2.5 * k, 10 + (15 if k % 2 else 0)) for k in range(1, 9)]
    for ln in stroke:
        g.write((ln + "\n").encode())
        g.answer()
    hold_end = (10 + 2.5 * 8, 10.0, 0.0)
    moving(g)
    g.write(b"!")
    st1 = g.wait_state({"Hold:0"}, 20)
    time.sleep(0.15)
    st2 = g.status()
    check("! brings the stroke to a stop on the board and it stays stopped",
          st2.startswith("<Hold:0|") and mpos(st1) == mpos(st2) and not near(mpos(st1), hold_end),
          (st1, st2))
    g.write(b"~")
    st = g.wait_state({"Idle"}, 60)
    check("~ resumes and the stroke ends exactly on its last point", near(mpos(st), hold_end),
          (st, hold_end))

    # 3. Ctrl-X in motion: alarm, unlock, then a move to an exact point.
    g.write(b"G61\nG1 X5 Y40 F600\n")
    g.answer()
    g.answer()
    moving(g)
    g.write(b"\x18")
    _, before = g.wait_for(lambda l: l.startswith("Grbl 1.1h"), 10)
    st1 = g.status()
    time.sleep(0.15)
    st2 = g.status()
    check("Ctrl-X in motion raises ALARM:3 and the board stands still",
          "ALARM:3" in before and st1.startswith("<Alarm|") and mpos(st1) == mpos(st2),
          (before, st1, st2))
    g.write(b"G0 X1\n")
    locked = g.answer()
    g.write(b"$X\n")
    g.answer()
    check("G-code is refused with error:9 until $X", locked == 9, locked)

    # 4. A client that vanishes with lines in flight loses none of them.
    vanish_end = (17.5, 22.25, 0.0)
    g.write(b"G1 X12.5 Y30 F3000\nG1 X%.3f Y%.3f\n" % vanish_end[:2])
    g.close()
    time.sleep(1.5)
    g = Grbl(PTY)
    st = g.wait_state({"Idle"}, 30)
    check("lines sent by a client that then vanished all run: the board ends on the last",
          near(mpos(st), vanish_end), (st, vanish_end))

    # 5. A Z move on this X/Y board (no Z lines): an alarm, never a move no
    # motor makes; Ctrl-X and $X bring it back where it was.
    g.write(b"G0 Z1\n")
    a = g.answer()
    _, seen = g.wait_for(lambda l: l.startswith("ALARM:"), 10)
    st = g.status()
    g.write(b"\x18")
    g.wait_for(lambda l: l.startswith("Grbl 1.1h"), 10)
    g.write(b"$X\n")
    g.answer()
    st2 = g.wait_state({"Idle"}, 10)
    check("a Z move on a board that wires no Z raises an alarm; reset and $X recover it",
          a == 0 and st.startswith("<Alarm|") and near(mpos(st), vanish_end) and
          near(mpos(st2), vanish_end), (a, seen, st, st2))
    g.close()
    print("END %.3f %.3f" % vanish_end[:2])
    passed = sum(results)
    print("%d passed, %d failed" % (passed, len(results) - passed))
    return 0 if passed == len(results) else 1


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Exception as e:  # a timeout is a failure, not a crash
        print("not ok client aborted: %r" % (e,))
        passed = sum(results)
        print("%d passed, %d failed" % (passed, len(results) - passed + 1))
        sys.exit(1)
