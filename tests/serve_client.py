#!/usr/bin/python3
"""Protocol tests for `plotkin serve` over a real pseudo-terminal.

A G-code sender as the users' tools behave (pyserial, Debian's python3-serial):
character counting against Grbl's 128-byte buffer, send-and-wait, realtime
bytes mid-line, feed hold / resume, soft reset, bad input. Every wait has a
deadline; nothing sleeps to "let things settle" except while polling status.

usage: serve_client.py PTY_PATH
Prints "ok <name>" / "not ok <name>" per check and "N passed, N failed" last.
"""
import os
import re
import select
import sys
import time

import serial

PTY = sys.argv[1]
RX_BUFFER = 128
results = []


def check(name, cond, detail=""):
    results.append(bool(cond))
    print(("ok " if cond else "not ok ") + name)
    if not cond and detail:
        print("  " + str(detail)[:400])


class Grbl:
    def __init__(self, path):
        self.s = serial.Serial(path, 115200, timeout=0.05)
        self.buf = b""
        self.pending = []  # lines read but not yet consumed (status, msgs)

    def close(self):
        self.s.close()

    def readline(self, deadline):
        while b"\n" not in self.buf:
            if time.monotonic() > deadline:
                raise TimeoutError("no line; have %r" % self.buf[-200:])
            # read(n) would wait for n bytes: take what is there, or wait for one
            self.buf += self.s.read(self.s.in_waiting or 1)
        line, self.buf = self.buf.split(b"\n", 1)
        return line.rstrip(b"\r").decode("ascii", "replace")

    def write(self, data):
        self.s.write(data)

    def wait_for(self, pred, timeout=10.0):
        """Read lines until pred(line) is true; return (line, lines before)."""
        deadline = time.monotonic() + timeout
        seen = []
        while True:
            line = self.readline(deadline)
            if pred(line):
                return line, seen
            seen.append(line)

    def answer(self, timeout=10.0):
        """Next ok / error:N, skipping status reports and messages."""
        line, _ = self.wait_for(lambda l: l == "ok" or l.startswith("error:"), timeout)
        return 0 if line == "ok" else int(line[6:])

    def status(self, timeout=5.0):
        self.write(b"?")
        line, _ = self.wait_for(lambda l: l.startswith("<") and l.endswith(">"), timeout)
        return line

    def wait_state(self, states, timeout=30.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            st = self.status()
            if st[1:].split("|")[0] in states:
                return st
            time.sleep(0.01)
        raise TimeoutError("state never in %s (last %s)" % (states, st))


def mpos(status):
    m = re.search(r"MPos:([-\d.]+),([-\d.]+),([-\d.]+)", status)
    return tuple(float(v) for v in m.groups()) if m else None


def bf(status):
    m = re.search(r"Bf:(\d+),(\d+)", status)
    return tuple(int(v) for v in m.groups()) if m else None


def program(n, seed):
    """n G1 lines: a walk of short moves on a 0.025 mm grid (whole steps at
    80 steps/mm), so the expected end is exact and the run stays short."""
    lines, x, y = [], 2000, 2000
    for i in range(n):
        x += ((seed + i * 37) % 41) - 20          # -0.5 .. +0.5 mm
        y += ((seed * 3 + i * 53) % 39) - 19
        lines.append("G1 X%.3f Y%.3f F%d" % (x * 0.025, y * 0.025, 3000 + (i % 5) * 500))
    return lines, (x * 0.025, y * 0.025, 0.0)


def stream_counting(g, lines):
    """Character counting: keep at most 128 unacknowledged bytes in flight."""
    inflight, acks, i = [], [], 0
    deadline = time.monotonic() + 120
    while len(acks) < len(lines):
        while i < len(lines) and sum(inflight) + len(lines[i]) + 1 <= RX_BUFFER:
            g.write((lines[i] + "\n").encode())
            inflight.append(len(lines[i]) + 1)
            i += 1
        acks.append(g.answer(timeout=max(1.0, deadline - time.monotonic())))
        inflight.pop(0)
    return acks


def stream_send_wait(g, lines):
    acks = []
    for ln in lines:
        g.write((ln + "\n").encode())
        acks.append(g.answer())
    return acks


def near(a, b):
    return a is not None and all(abs(p - q) < 1e-9 for p, q in zip(a, b))


def main():
    g = Grbl(PTY)
    g.write(b"\x18")  # like a sender on connect: reset and wait for the banner
    banner, _ = g.wait_for(lambda l: l.startswith("Grbl "), 10)
    check("the greeting is Grbl 1.1 style and names plotkin",
          banner.startswith("Grbl 1.1h [plotkin") and "'$' for help]" in banner, banner)
    g.write(b"$I\n")
    opt, _ = g.wait_for(lambda l: l.startswith("[OPT:"), 5)
    blocks = int(opt[5:-1].split(",")[1])
    check("$I advertises the 128-byte receive buffer", opt.endswith(",128]"), opt)
    g.answer()

    # 1. 2,000 lines with character counting.
    lines, end = program(2000, 7)
    t = time.monotonic()
    acks = stream_counting(g, lines)
    print("# 2000 lines, character counting: acknowledged in %.2f s" % (time.monotonic() - t))
    check("2000 character-counted lines are each acknowledged once with ok",
          len(acks) == 2000 and all(a == 0 for a in acks), [a for a in acks if a][:10])
    st = g.wait_state({"Idle"}, 120)
    check("after the counted stream the final status shows the last target", near(mpos(st), end),
          (st, end))
    check("when idle every planner block and the whole rx buffer are free",
          bf(st) == (blocks, RX_BUFFER), st)
    g.write(b"?")
    time.sleep(0.05)
    extra = g.s.read(g.s.in_waiting) + g.buf
    g.buf = b""
    check("no stray acknowledgements arrive after the stream", b"ok" not in extra, extra)

    # 2. The same with send-and-wait.
    lines, end = program(2000, 11)
    t = time.monotonic()
    acks = stream_send_wait(g, lines)
    print("# 2000 lines, send-and-wait: acknowledged in %.2f s" % (time.monotonic() - t))
    check("2000 send-and-wait lines are each acknowledged with ok",
          len(acks) == 2000 and all(a == 0 for a in acks))
    st = g.wait_state({"Idle"}, 120)
    check("after send-and-wait the final status shows the last target", near(mpos(st), end),
          (st, end))

    # 3. '?' in the middle of a line.
    g.write(b"G1 X12.5 F3000")
    g.write(b"?")
    rep, _ = g.wait_for(lambda l: l.startswith("<"), 5)
    g.write(b" Y25?.5\n")
    a = g.answer()
    st = g.wait_state({"Idle"}, 30)
    check("? mid-line answers at once and the line still runs exactly",
          a == 0 and near(mpos(st), (12.5, 25.5, 0.0)), (rep, a, st))

    # 4. Feed hold and resume in the middle of a smoothed stroke.
    g.write(b"G64 P0.05\nG1 X5 Y5 F600\n")
    g.answer(); g.answer()
    stroke = ["X%.3f Y%.3f" % (5 + 2.5 * k, 5 + (20 if k % 2 else 0)) for k in range(1, 40)]
    for ln in stroke:
        g.write((ln + "\n").encode())
        g.answer()
    end = (5 + 2.5 * 39, 25.0, 0.0)
    g.wait_state({"Run"}, 10)
    g.write(b"!")
    st1 = g.wait_state({"Hold:0"}, 20)
    time.sleep(0.1)
    st2 = g.status()
    check("! brings the stroke to a stop and it stays stopped",
          st2.startswith("<Hold:0|") and mpos(st1) == mpos(st2) and not near(mpos(st1), end),
          (st1, st2))
    g.write(b"~")
    st = g.wait_state({"Idle"}, 60)
    check("~ resumes and the stroke ends exactly on its last point", near(mpos(st), end), (st, end))

    # 5. Soft reset during motion.
    for ln in ["G61", "G1 X100 Y100 F300", "G1 X0 Y0", "G1 X100 Y0", "G1 X0 Y100"]:
        g.write((ln + "\n").encode())
        g.answer()
    g.wait_state({"Run"}, 10)
    g.write(b"\x18")
    _, before = g.wait_for(lambda l: l.startswith("Grbl 1.1h"), 10)
    unlock, _ = g.wait_for(lambda l: l.startswith("[MSG:"), 5)
    st1 = g.status()
    time.sleep(0.2)
    st2 = g.status()
    check("ctrl-X in motion raises ALARM:3 and asks for an unlock",
          "ALARM:3" in before and "$X" in unlock and st1.startswith("<Alarm|"), (before, unlock, st1))
    check("ctrl-X in motion leaves no queued move and the machine stands still",
          bf(st2) is not None and bf(st2)[0] == blocks and mpos(st1) == mpos(st2), (st1, st2))
    g.write(b"G0 X1\n")
    locked = g.answer()
    g.write(b"$X\n")
    g.answer()
    check("G-code is refused with error:9 until $X", locked == 9, locked)

    # 6. Bad input, each followed by a valid line that must run.
    bad = [
        (b"G1 X1 X2", 25), (b"G1 A5", 20), (b"G1 X", 2), (b"G1 X12345678901", 2),
        (b"G0 X301", 15), (b"G0 Y-1", 15), (b"G1 X1 F-5", 4), (b"G0 G1 X1", 21),
        (b"G1.5 X1", 23), (b"G4", 28), (b"N99999999 G0 X1", 27), (b"\x01\x02garbage\x7f", 1),
        (b"G1 X1 \xfe\xff", 1), (b"G5 X1 Y1 P1 F100", 28), (b"G80 X1", 31), (b"G1 X1 P3 F10", 36),
        (b"X" + b"1" * 300, 11), (b"$Q", 3), (b"$100=-1", 4), (b"T999", 38),
    ]
    ok_all, got = True, []
    for k, (line, err) in enumerate(bad):
        g.write(line + b"\n")
        a = g.answer()
        g.write(b"G0 X%d Y%d\n" % (k + 1, 2 * k + 1))
        b = g.answer()
        got.append((line[:20], a, b))
        ok_all &= a == err and b == 0
    check("every bad line gets its own error:N and the next line is accepted", ok_all, got)
    st = g.wait_state({"Idle"}, 30)
    check("the valid lines between the bad ones all ran",
          near(mpos(st), (len(bad), 2 * len(bad) - 1, 0.0)), st)

    # 7. Disconnect without reading the answers, then reconnect.
    g.write(b"G0 X3 Y4\n$$\n")
    time.sleep(0.05)
    g.close()
    time.sleep(2.5)  # serve drops output nobody read for a second
    # A plain open(), like socat or a sender that does not flush on open
    # (pyserial flushes its input when it opens, which would hide stale data).
    fd = os.open(PTY, os.O_RDWR | os.O_NOCTTY)
    os.write(fd, b"?")
    got, deadline = b"", time.monotonic() + 5
    while b"\n" not in got and time.monotonic() < deadline:
        if select.select([fd], [], [], 0.1)[0]:
            got += os.read(fd, 4096)
    os.close(fd)
    first = got.split(b"\n")[0].rstrip(b"\r").decode("ascii", "replace")
    check("a reconnecting client gets no stale answers and a live status",
          first.startswith("<Idle|") and near(mpos(first), (3.0, 4.0, 0.0)), got[:200])

    passed = sum(results)
    print("%d passed, %d failed" % (passed, len(results) - passed))
    return 0 if passed == len(results) else 1


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Exception as e:  # a timeout or a broken pipe is a failure, not a crash
        print("not ok client aborted: %r" % (e,))
        passed = sum(results)
        print("%d passed, %d failed" % (passed, len(results) - passed + 1))
        sys.exit(1)
