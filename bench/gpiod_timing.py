#!/usr/bin/python3
"""Step timing error of the Linux board loop on this machine (`make bench-gpiod`).

Runs the board program's test variant (build/plotkin-gpiod-mock: the same
gpiod backend, real-time loop and motion core as plotkin-gpiod; the mock chip
records every line change with the real time it was written and the time its
step-timer callback was scheduled for) on a smoothed zigzag at F6000 with
80 steps/mm (8 kHz per axis at full speed), with ordinary scheduling and with
SCHED_FIFO + mlockall (--realtime) if this process may have them, side by side
in one run: played from a file, and served (`serve --link`, the program
streamed over the pty by a character-counting sender, as cncjs would). For every step/dir edge written by a callback:
error = time written - time planned. Prints p50 / p99 / p99.9 / max in µs,
the callbacks that ran after the NEXT one was already due (the loop fell a
whole event behind: "overruns"), and the step generator's own count of late
events (schedule moved). A benchmark, not a test: the figures depend on the
machine and its load; it fails only when it cannot measure.

usage: gpiod_timing.py PLOTKIN_GPIOD_MOCK [--seconds S]
"""
import os
import re
import select
import signal
import subprocess
import sys
import tempfile
import time
import tty

BIN = sys.argv[1]
SECONDS = float(sys.argv[sys.argv.index("--seconds") + 1]) if "--seconds" in sys.argv else 3.0
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BOARD = os.path.join(ROOT, "hal", "gpiod", "rpi-plotter.conf")
STEP_DIR_LINES = {17, 27, 22, 23}
MODES = ("normal", "fifo", "serve-normal", "serve-fifo")
NAMES = {"normal": "file, SCHED_OTHER (--no-realtime)", "fifo": "file, SCHED_FIFO + mlockall",
         "serve-normal": "served, SCHED_OTHER", "serve-fifo": "served, SCHED_FIFO + mlockall"}


def die(msg):
    print("bench-gpiod: cannot measure: " + msg, file=sys.stderr)
    sys.exit(1)


def program(seconds):
    """A smoothed zigzag, 40 mm strokes at 100 mm/s: about `seconds` long."""
    n = max(4, int(seconds * 100 / 41))
    out = ["G21 G90", "G64 P0.02", "G0 X10 Y10", "M3"]
    for k in range(1, n + 1):
        out.append("G1 X%.3f Y%.3f F6000" % (10 + 40 * (k % 2), 10 + 1.25 * k))
    out += ["M5", "G0 X10 Y10", "M2"]
    return "\n".join(out) + "\n"


def pct(sorted_v, q):
    return sorted_v[min(len(sorted_v) - 1, int(q * len(sorted_v)))]


def stream(link, gcode, deadline_s=120):
    """A character-counting Grbl sender on the pty: every line, then wait Idle."""
    fd = os.open(link, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    buf = [b""]

    def line(deadline):
        while b"\n" not in buf[0]:
            if time.monotonic() > deadline:
                die("served run: the board stopped answering (have %r)" % buf[0][-100:])
            if select.select([fd], [], [], 0.1)[0]:
                buf[0] += os.read(fd, 4096)
        ln, buf[0] = buf[0].split(b"\n", 1)
        return ln.strip()

    end = time.monotonic() + deadline_s
    os.write(fd, b"\x18")
    while not line(end).startswith(b"Grbl"):
        pass
    lines = [ln for ln in open(gcode).read().splitlines() if ln and ln != "M2"]
    inflight, i, acked = [], 0, 0
    while acked < len(lines):
        while i < len(lines) and sum(inflight) + len(lines[i]) + 1 <= 128:
            os.write(fd, (lines[i] + "\n").encode())
            inflight.append(len(lines[i]) + 1)
            i += 1
        a = line(end)
        if a == b"ok" or a.startswith(b"error"):
            if a != b"ok":
                die("served run: %r for a line" % a)
            acked += 1
            inflight.pop(0)
    while True:
        time.sleep(0.05)
        os.write(fd, b"?")
        a = line(end)
        while not a.startswith(b"<"):
            a = line(end)
        if a.startswith(b"<Idle"):
            break
    os.close(fd)


def run(mode, gcode, tmp):
    served = mode.startswith("serve")
    trace = os.path.join(tmp, "trace-%s.txt" % mode)
    flag = "--realtime" if mode.endswith("fifo") else "--no-realtime"
    if served:
        link = os.path.join(tmp, "tty-%s" % mode)
        srv = subprocess.Popen([BIN, "--board", BOARD, flag, "--mock-trace", trace, "serve",
                                "--link", link], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
        for _ in range(200):
            if os.path.exists(link) or srv.poll() is not None:
                break
            time.sleep(0.05)
        if srv.poll() is None:
            stream(link, gcode)
            srv.send_signal(signal.SIGTERM)
        out, err = srv.communicate(timeout=30)
        p = subprocess.CompletedProcess(srv.args, srv.returncode, out, err)
    else:
        p = subprocess.run([BIN, "--board", BOARD, flag, "--mock-trace", trace, gcode],
                           capture_output=True, text=True, timeout=120)
    if mode.endswith("fifo") and p.returncode != 0 and "--realtime: refused" in p.stderr:
        return None, p.stderr.strip().splitlines()[-1]
    if p.returncode != 0:
        die("%s run failed (exit %d): %s %s" % (mode, p.returncode, p.stdout, p.stderr))
    m = re.search(r"(\d+) late step events", p.stdout)
    if not m:
        die("no summary from the board program: %r" % p.stdout)
    late = int(m.group(1))
    mm = re.search(r"longest main turn (\d+) ticks", p.stdout)
    if not mm:
        die("no main-turn figure in the summary: %r" % p.stdout)
    main_us = int(mm.group(1))  # ticks at the default 1 MHz $tick
    errs, dues, first_write = [], [], {}
    for row in open(trace):
        if row.startswith("#"):
            continue
        t, due, line, _v, initial = (int(f) for f in row.split())
        if due < 0 or initial or line not in STEP_DIR_LINES:
            continue
        errs.append(t - due)
        if due not in first_write:
            first_write[due] = t
            dues.append(due)
    if len(errs) < 1000:
        die("%s run: only %d callback edges recorded" % (mode, len(errs)))
    if min(errs) < 0:
        die("%s run: an edge written before its planned time (%d ns): clocks disagree" % (mode, min(errs)))
    if max(errs) == 0:
        die("%s run: every error is exactly 0 ns: the trace is not timestamped on the real clock" % mode)
    overruns = sum(1 for a, b in zip(dues, dues[1:]) if first_write[a] > b)
    errs.sort()
    return dict(edges=len(errs), callbacks=len(dues), p50=pct(errs, .5), p99=pct(errs, .99),
                p999=pct(errs, .999), max=errs[-1], overruns=overruns, late=late,
                main=main_us), None


def main():
    if not os.access(BIN, os.X_OK):
        die("%s is not built (make %s)" % (BIN, os.path.relpath(BIN, ROOT)))
    with tempfile.TemporaryDirectory() as tmp:
        gcode = os.path.join(tmp, "zigzag.gcode")
        with open(gcode, "w") as f:
            f.write(program(SECONDS))
        res = {}
        for mode in MODES:
            res[mode] = run(mode, gcode, tmp)
    load = open("/proc/loadavg").read().split()[0] if os.path.exists("/proc/loadavg") else "?"
    print("plotkin-gpiod step timing error on this machine (%d cores, load %s): edge written - "
          "planned," % (os.cpu_count() or 0, load))
    print("mock chip timestamping on CLOCK_MONOTONIC; a smoothed zigzag at F6000, 80 steps/mm, "
          "%.0f s" % SECONDS)
    print("%-36s %7s %7s %8s %8s %8s %9s %9s %5s %8s" % ("scheduling", "edges", "p50 us", "p99 us",
          "p99.9 us", "max us", "callbacks", "overruns", "late", "main us"))
    for mode in MODES:
        r, why = res[mode]
        if r is None:
            print("%-36s not permitted here: %s" % (NAMES[mode], why))
            continue
        print("%-36s %7d %7.1f %8.1f %8.1f %8.1f %9d %9d %5d %8d" % (
            NAMES[mode], r["edges"], r["p50"] / 1e3, r["p99"] / 1e3, r["p999"] / 1e3,
            r["max"] / 1e3, r["callbacks"], r["overruns"], r["late"], r["main"]))
    print("overruns: callbacks that ran after the next one was due; late: step events the "
          "generator found a whole interval overdue (schedule moved, steps never bunched);")
    print("main us: the longest main-loop turn (a callback due meanwhile waits for it: the loop "
          "is one thread), so a max far above it is the host's scheduling, not the loop's work")


if __name__ == "__main__":
    main()
