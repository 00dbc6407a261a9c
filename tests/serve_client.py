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
    g.write(b"$10=3\n")  # Grbl's status mask: MPos and the Bf: buffer field
    check("$10=3 asks for MPos and Bf as in Grbl", g.answer() == 0)

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
    bad = [  # Grbl 1.1h's answers (grbl-sim), plotkin's where it has more (15: range)
        (b"G1 X1 X2", 25), (b"G1 A5", 20), (b"G1 X", 2), (b"G1 X12345678901", 2),
        (b"G53 G0 X3000", 15), (b"G2 X1 Y1 R0.01 F100", 34), (b"G1 X1 F-5", 4), (b"G0 G1 X1", 24),
        (b"G1.5 X1", 23), (b"G4", 28), (b"N99999999 G0 X1", 27), (b"\x01\x02garbage\x7f", 2),
        (b"G1 X1 \xfe\xffE2", 20), (b"G5 X1 Y1 P1 F100", 28), (b"G80 X1", 31),
        (b"G1 X1 P3 F10", 36), (b"X" + b"1" * 300, 11), (b"$Q", 2), (b"$100=-1", 4),
        (b"T999", 38), (b"G2 X5 I1 F100", 33), (b"G10 L2 P9 X1", 29),
    ]
    ok_all, got = True, []
    for k, (line, err) in enumerate(bad):
        if line.startswith(b"$"):  # $ commands want an idle machine (else error:8)
            g.write(b"G4 P0\n")
            g.answer()
        g.write(line + b"\n")
        a = g.answer()
        g.write(b"G0 X%d Y%d\n" % (k + 1, 2 * k + 1))
        b = g.answer()
        got.append((line[:20], a, b))
        ok_all &= a == err and b == 0
    check("every bad line gets its own error:N and the next line is accepted", ok_all,
          [x for x, (l, e) in zip(got, bad) if x[1] != e or x[2] != 0])
    st = g.wait_state({"Idle"}, 30)
    check("the valid lines between the bad ones all ran",
          near(mpos(st), (len(bad), 2 * len(bad) - 1, 0.0)), st)

    # 7a. A connected client that does not read for a while loses nothing
    # (an `ok` dropped here would hang a character-counting sender).
    g.write(b"G0 X1 Y1\nG4 P0\n$$\n")
    time.sleep(2.5)
    a = g.answer()
    a2 = g.answer()
    listing, _ = g.wait_for(lambda l: l.startswith("$132="), 5)
    b = g.answer()
    check("a client that stops reading for 2.5 s still gets every answer",
          a == 0 and a2 == 0 and b == 0 and listing.startswith("$132="), (a, listing, b))

    # 7. Disconnect without reading the answers, then reconnect.
    g.write(b"G0 X3 Y4\nG4 P0\n$$\n")
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

    grbl_sequences()

    passed = sum(results)
    print("%d passed, %d failed" % (passed, len(results) - passed))
    return 0 if passed == len(results) else 1


def field(status, name):
    m = re.search(r"\|" + name + r":([^|>]*)", status)
    return m.group(1) if m else None


def grbl_sequences():
    """The byte sequences real senders write (issue 12), each checked on the
    pty exactly as cncjs, UGS or stream.py send them."""
    g = Grbl(PTY)
    g.write(b"\x18")
    g.wait_for(lambda l: l.startswith("Grbl "), 10)
    g.write(b"$X\nG21 G90 G0 X0 Y0 Z0\nG4 P0\n")
    g.answer(); g.answer(); g.answer()

    # cncjs writes realtime bytes as UTF-8: 0x91 (feed +10 %) goes out as C2 91.
    # Grbl drops the unknown C2; the next line must not fail.
    g.write(b"\xc2\x91")
    time.sleep(0.1)  # two clicks (flags: two presses before a poll count once, as in Grbl)
    g.write(b"\xc2\x91G0 X1\n")
    a = g.answer()
    ovs = [field(g.status(), "Ov") for _ in range(12)]
    ov = next((o for o in ovs if o), None)
    check("UTF-8-wrapped overrides (C2 91 C2 91): no error, Ov: shows 120 %",
          a == 0 and ov is not None and ov.startswith("120,"), (a, ovs))
    g.write(b"\x90")  # feed override back to 100 %
    time.sleep(0.05)

    # cncjs "Stop": '!', then Ctrl-X 500 ms later when the hold is complete.
    g.write(b"G1 X80 F600\n")
    g.answer()
    g.wait_state({"Run"}, 10)
    g.write(b"!")
    held = g.wait_state({"Hold:0"}, 20)
    time.sleep(0.5)
    g.write(b"\x18")
    _, before = g.wait_for(lambda l: l.startswith("Grbl "), 10)
    st = g.status()
    check("'!' then Ctrl-X after Hold:0: Idle, no alarm",
          st.startswith("<Idle|") and not any("ALARM" in l for l in before), (held, before, st))
    g.write(b"G0 X2 Y2\nG4 P0\n")
    a, b = g.answer(), g.answer()
    st = g.status()
    check("... and the next job runs", a == 0 and b == 0 and near(mpos(st), (2.0, 2.0, 0.0)), st)

    # 256 Ctrl-X in one write: one reset.
    g.write(b"\x18" * 256)
    time.sleep(1.0)
    g.write(b"?")
    time.sleep(0.2)
    data = g.s.read(g.s.in_waiting) + g.buf
    g.buf = b""
    check("256 Ctrl-X in one write: exactly one reset (one greeting)",
          data.count(b"Grbl 1.1h") == 1 and b"ALARM" not in data, data[:300])

    # A burst of '?' never drops a '!'.
    g.write(b"G1 X60 F300\n")
    g.answer()
    g.wait_state({"Run"}, 10)
    g.write(b"?" * 16 + b"!")
    time.sleep(0.5)
    burst = g.s.read(g.s.in_waiting) + g.buf  # the burst's own reports
    g.buf = b""
    st2 = g.wait_state({"Hold:0"}, 5)
    check("'?' x16 then '!': the hold happens", st2.startswith("<Hold:0|"), (burst[-200:], st2))
    g.write(b"\x18")
    g.wait_for(lambda l: l.startswith("Grbl "), 10)
    g.write(b"$X\n")
    g.answer()

    # Negative moves with Grbl's default $20=0 (no soft limits).
    g.write(b"G90 G0 X0 Y0\nG4 P0\n$J=G91 X-10 F1000\n")
    g.answer(); g.answer()
    j = g.answer()
    g.wait_state({"Idle"}, 20)
    g.write(b"G0 X-5\nG92 X10\nG0 X0\nG4 P0\n")
    r = [g.answer() for _ in range(4)]
    st = g.status()
    check("negative moves with $20=0: jog X-10, G0 X-5, G92 X10 then G0 X0 all run",
          j == 0 and r == [0, 0, 0, 0] and near(mpos(st), (-15.0, 0.0, 0.0)), (j, r, st))

    # WCO after the offset returns to zero: the report after the change has it.
    g.write(b"G92.1\n")
    g.answer()
    wco = field(g.status(), "WCO")
    check("WCO after the offset returns to zero: WCO:0.000,0.000,0.000 in the next report",
          wco == "0.000,0.000,0.000", wco)

    # G4 is answered after the queue has drained and the dwell has run.
    g.write(b"G0 X5\nG4 P0.5\n")
    g.answer()
    g.answer()
    st = g.status()
    check("G4 is answered after the move and the dwell: the machine is idle at the target",
          st.startswith("<Idle|") and near(mpos(st), (5.0, 0.0, 0.0)), st)
    g.close()

    # A client that disconnects mid-line: its half line is not glued to the
    # next client's first line (cncjs/UGS reconnecting, a crashed script).
    fd = os.open(PTY, os.O_RDWR | os.O_NOCTTY)
    os.write(fd, b"G0 X1")
    time.sleep(0.2)
    os.close(fd)
    time.sleep(1.5)
    g = Grbl(PTY)
    g.write(b"0 Y5\n")
    a = g.answer()
    g.write(b"G4 P0\n")
    g.answer()
    st = g.status()
    check("a reconnect mid-line: '0 Y5' is its own line (error:1), the machine did not move",
          a == 1 and near(mpos(st), (5.0, 0.0, 0.0)), (a, st))
    g.close()


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Exception as e:  # a timeout or a broken pipe is a failure, not a crash
        print("not ok client aborted: %r" % (e,))
        passed = sum(results)
        print("%d passed, %d failed" % (passed, len(results) - passed + 1))
        sys.exit(1)
