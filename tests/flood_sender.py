#!/usr/bin/python3
"""Flood `plotkin serve` over its pseudo-terminal with a character-counting
sender, faster than the machine moves, and check that nothing is lost.

usage: flood_sender.py PTY_PATH LINES SERVE_PID [--disconnect-at K] [--no-counting]

The sender keeps as many lines in flight as fit Grbl's 128-byte receive
buffer (character counting, as UGS and bCNC do), so the firmware's receive
ring is full most of the time. The program is a zig-zag of short G1 moves
(0.05 mm, F300) ending at X12.345 Y6.789. Checked:
  - every line is acknowledged exactly once, in order, and every answer is
    "ok" (no error, no ALARM, nothing unexpected on the wire)
  - after the last ok the machine goes Idle at exactly the last target,
    rounded to whole steps with the $100/$101 steps/mm the firmware reports
  - the server's resident memory is flat: no growth between 10% of the lines
    and the end beyond 256 kB (fixed-size buffers only)
With --disconnect-at K the sender closes the pty after K lines (lines in
flight), waits 0.3 s and opens it again, as a sender that crashes and
restarts: the answers written meanwhile wait in the pty, so the counts above
must still hold across the two connections. With --no-counting the sender
ignores character counting and writes as fast as the pty takes bytes: the
firmware reads only what its 128-byte ring has room for, so the pty's own
buffer holds the rest and still nothing may be lost (a real UART, which has
no such back-pressure, is covered by fuzz_protocol's RX-overflow events).
Prints "ok <name>" / "not ok <name>", a figures line, and "N passed, N failed"
last. Every wait has a deadline.
"""
import os
import re
import select
import sys
import termios
import time
import tty

PTY, LINES, PID = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
OPTS = sys.argv[4:]
DISCONNECT_AT = int(OPTS[OPTS.index("--disconnect-at") + 1]) if "--disconnect-at" in OPTS else -1
RX_BUFFER = 1 << 30 if "--no-counting" in OPTS else 128
results = []



def check(name, cond, detail=""):
    results.append(bool(cond))
    print(("ok " if cond else "not ok ") + name)
    if not cond and detail:
        print("  " + str(detail)[:600])


def rss_kb(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return -1


def open_pty():
    f = os.open(PTY, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(f, termios.TCSANOW)  # TCSAFLUSH would drop answers waiting in the pty
    return f


fd = open_pty()
buf = b""


def readline(deadline):
    global buf
    while b"\n" not in buf:
        left = deadline - time.monotonic()
        if left <= 0:
            return None
        r, _, _ = select.select([fd], [], [], left)
        if r:
            buf += os.read(fd, 65536)
    line, _, buf = buf.partition(b"\n")
    return line.rstrip(b"\r").decode("ascii", "replace")


def write_all(data):
    view = memoryview(data)
    while view:
        _, w, _ = select.select([], [fd], [], 5)
        if not w:
            raise TimeoutError("pty not writable")
        n = os.write(fd, view)
        view = view[n:]


def command(cmd, deadline_s=10):
    """Send one line and collect everything up to its ok/error."""
    write_all(cmd.encode() + b"\n")
    out = []
    end = time.monotonic() + deadline_s
    while True:
        line = readline(end)
        if line is None:
            return out, None
        if line == "ok" or line.startswith("error:"):
            return out, line
        out.append(line)


def status(deadline_s=5):
    write_all(b"?")
    end = time.monotonic() + deadline_s
    while True:
        line = readline(end)
        if line is None:
            return None
        if line.startswith("<"):
            return line


# Wake up: take the start-up greeting if it is there (not on a reconnect),
# then a soft reset gives a clean state. Send nothing until its greeting:
# a reset discards input not read yet (as Grbl does), so a line sent right
# behind 0x18 could be dropped unanswered.
def wait_greeting(seconds):
    end = time.monotonic() + seconds
    while True:
        line = readline(end)
        if line is None:
            return None
        if line.startswith("Grbl "):
            return line


wait_greeting(1.0)
write_all(b"\x18")
greet = wait_greeting(10)
check("serve greets after a soft reset", greet is not None)
settings, ans = command("$$")
spmm = {}
for s in settings:
    m = re.match(r"\$(\d+)=([-0-9.]+)", s)
    if m:
        spmm[int(m.group(1))] = float(m.group(2))
check("$$ lists the steps/mm", ans == "ok" and 100 in spmm and 101 in spmm, settings)
_, ans = command("G21 G90 G1 F300")
check("the program's modal line is accepted", ans == "ok", ans)

TARGET = (12.345, 6.789)


def program_line(i):
    if i == LINES - 1:
        return "G1 X%.3f Y%.3f" % TARGET
    x = (i % 200) * 0.05
    y = ((i // 200) % 100) * 0.05
    return "G1 X%.3f Y%.3f" % (x, y)


# The flood: character counting against the 128-byte buffer.
inflight = []  # lengths of unacknowledged lines, oldest first
answers = 0
bad_answers = []
unexpected = []
sent = 0
t0 = time.monotonic()
rss_early = None
deadline = t0 + max(120, LINES / 100)
reconnected = False
while answers < LINES and time.monotonic() < deadline:
    if DISCONNECT_AT >= 0 and not reconnected and sent >= DISCONNECT_AT:
        os.close(fd)
        time.sleep(0.3)
        fd = open_pty()
        reconnected = True
    while sent < LINES:
        data = (program_line(sent) + "\n").encode()
        if sum(inflight) + len(data) > RX_BUFFER - 1:
            break
        write_all(data)
        inflight.append(len(data))
        sent += 1
    line = readline(time.monotonic() + 10)
    if line is None:
        break
    if line == "ok" or line.startswith("error:"):
        if not inflight:
            unexpected.append("answer with nothing in flight: " + line)
            continue
        inflight.pop(0)
        answers += 1
        if line != "ok":
            bad_answers.append((answers, line))
        if rss_early is None and answers >= LINES // 10:
            rss_early = rss_kb(PID)
    elif line:
        unexpected.append(line)
elapsed = time.monotonic() - t0
check("every one of %d lines is acknowledged exactly once" % LINES,
      answers == LINES and sent == LINES and not inflight, (answers, sent, inflight))
check("every answer is ok", not bad_answers, bad_answers[:5])
check("nothing unexpected on the wire during the flood", not unexpected, unexpected[:5])

# Final position: wait for Idle, compare with the last target in whole steps.
st = None
end = time.monotonic() + max(60, LINES / 200)
while time.monotonic() < end:
    st = status()
    if st and st.startswith("<Idle"):
        break
    time.sleep(0.05)
m = re.search(r"MPos:([-0-9.]+),([-0-9.]+)", st or "")
# MPos has 3 decimals, finer than a step: compare in whole steps
want = [round(TARGET[k] * spmm.get(100 + k, 1)) for k in range(2)]
got = [round(float(m.group(1 + k)) * spmm.get(100 + k, 1)) for k in range(2)] if m else None
check("the machine ends Idle", bool(st) and st.startswith("<Idle"), st)
check("the final position is the last target in whole steps",
      got is not None and got == want, (got, want, st))
rss_end = rss_kb(PID)
check("server memory is flat (%s kB at 10%%, %s kB at the end)" % (rss_early, rss_end),
      rss_early is not None and rss_end - rss_early <= 256, (rss_early, rss_end))
if DISCONNECT_AT >= 0:
    check("the sender disconnected and reconnected mid-flood", reconnected)
print("# flood: %d lines in %.1f s (%.0f lines/s), memory %s -> %s kB" %
      (LINES, elapsed, LINES / elapsed if elapsed else 0, rss_early, rss_end))
os.close(fd)
print("%d passed, %d failed" % (sum(results), len(results) - sum(results)))
sys.exit(0 if all(results) else 1)
