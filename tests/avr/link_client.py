#!/usr/bin/python3
"""A Grbl sender against `plotkin avrsim --link` (an emulated board on a pty).

usage: link_client.py PTY_PATH

What a real sender does, with Debian's python3-serial: reset and wait for the
greeting, $I, character counting against the 128-byte buffer, '?' in the
middle of a line, feed hold and resume, soft reset in motion (ALARM:3, $X),
and the final position exactly where the program ends. Every wait has a
deadline. Prints "ok ..." / "not ok ..." and "N passed, N failed" last.
"""
import os
import sys
import time

# The sender of the `plotkin serve` tests (pyserial, with deadlines): the
# same client, pointed at the emulated board.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
from serve_client import Grbl, check, mpos, near, results  # noqa: E402


def main():
    g = Grbl(sys.argv[1])
    g.write(b'\x18')
    banner, _ = g.wait_for(lambda l: l.startswith('Grbl '), 20)
    check('the emulated board greets as Grbl 1.1 and names plotkin',
          banner.startswith('Grbl 1.1h [plotkin'), banner)
    g.write(b'$I\n')
    opt, _ = g.wait_for(lambda l: l.startswith('[OPT:'), 10)
    g.answer()
    check('$I advertises the 128-byte receive buffer', opt.endswith(',128]'), opt)

    # character counting: a walk of short moves, at most 128 bytes in flight
    lines, x, y = ['G21 G90 G61'], 2000, 2000
    for i in range(60):
        x += ((7 + i * 37) % 41) - 20
        y += ((21 + i * 53) % 39) - 19
        lines.append('G1 X%.3f Y%.3f F%d' % (x * 0.025, y * 0.025, 3000 + (i % 5) * 500))
    end = (x * 0.025, y * 0.025, 0.0)
    inflight, acks, i = [], [], 0
    while len(acks) < len(lines):
        while i < len(lines) and sum(inflight) + len(lines[i]) + 1 <= 128:
            g.write((lines[i] + '\n').encode())
            inflight.append(len(lines[i]) + 1)
            i += 1
        acks.append(g.answer(60))
        inflight.pop(0)
    check('61 character-counted lines are each acknowledged with ok',
          len(acks) == 61 and all(a == 0 for a in acks), [a for a in acks if a][:10])
    st = g.wait_state({'Idle'}, 120)
    check('the counted stream ends exactly on its last target', near(mpos(st), end), (st, end))

    # '?' in the middle of a line
    g.write(b'G1 X12.5 F3000')
    g.write(b'?')
    rep, _ = g.wait_for(lambda l: l.startswith('<'), 10)
    g.write(b' Y25?.5\n')
    a = g.answer()
    st = g.wait_state({'Idle'}, 60)
    check('? mid-line answers at once and the line still runs exactly',
          a == 0 and near(mpos(st), (12.5, 25.5, 0.0)), (rep, a, st))

    # feed hold and resume
    g.write(b'G1 X40 Y25 F1200\n')
    g.answer()
    g.wait_state({'Run'}, 20)
    g.write(b'!')
    st1 = g.wait_state({'Hold:0'}, 30)
    time.sleep(0.2)
    st2 = g.status()
    check('! brings the move to a stop and it stays stopped',
          st2.startswith('<Hold:0|') and mpos(st1) == mpos(st2) and not near(mpos(st1), (40.0, 25.0, 0.0)),
          (st1, st2))
    g.write(b'~')
    st = g.wait_state({'Idle'}, 60)
    check('~ resumes and the move ends exactly', near(mpos(st), (40.0, 25.0, 0.0)), st)

    # soft reset in motion
    g.write(b'G1 X10 Y10 F1200\n')
    g.answer()
    # in motion: the state says Run and the position has left the start (the
    # chip plans for a few ms before the first step)
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        st = g.status()
        if st.startswith('<Run|') and not near(mpos(st), (40.0, 25.0, 0.0)):
            break
        time.sleep(0.01)
    g.write(b'\x18')
    _, before = g.wait_for(lambda l: l.startswith('Grbl 1.1h'), 20)
    st1 = g.status()
    time.sleep(0.2)
    st2 = g.status()
    check('ctrl-X in motion raises ALARM:3 and the machine stands still',
          'ALARM:3' in before and st1.startswith('<Alarm|') and mpos(st1) == mpos(st2), (before, st1, st2))
    g.write(b'G0 X1\n')
    locked = g.answer()
    g.write(b'$X\n')
    unlocked = g.answer()
    g.write(b'G0 X0 Y0\n')
    g.answer()
    st = g.wait_state({'Idle'}, 60)
    check('G-code is refused with error:9 until $X, then runs exactly',
          locked == 9 and unlocked == 0 and near(mpos(st), (0.0, 0.0, 0.0)), (locked, unlocked, st))
    g.s.close()


if __name__ == '__main__':
    try:
        main()
    except Exception as e:  # a timeout or a broken pipe is a failure, not a crash
        print('not ok client aborted: %r' % (e,))
        results.append(False)
    passed = sum(results)
    print('%d passed, %d failed' % (passed, len(results) - passed))
    sys.exit(0 if all(results) else 1)
