#!/usr/bin/env python3
"""bench/sim_rss.py -- peak memory of `plotkin sim` on big jobs (a table, not a test).

Writes two programs into a temporary directory and runs `plotkin sim` on each,
printing the peak resident set (VmHWM, which `plotkin sim --json` reads from
/proc/self/status at the end of the run: a fork's ru_maxrss would count the
Python that forked it), the CPU time and what the run reports:
  - about 1 km of pen-down path: a Lissajous figure in a 180 mm box, 5 mm chords
    at F6000 (200,000 lines);
  - a G-code file of SIZE_MB megabytes (default 500): serpentine passes of points
    1 um apart, 200 mm long, 0.01 mm apart (28.6 M lines for 500 MB).
The goal (issue 11) is under 64 MB whatever the size. Usage:

    python3 bench/sim_rss.py [--plotkin build/plotkin] [--size-mb 500] [--km 1.0]

Takes a few minutes of CPU (and ~SIZE_MB of disk, removed afterwards).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile


def write_lissajous(path, km):
    length, px, py, t = 0.0, 100.0, 100.0, 0.0
    with open(path, "w") as f:
        f.write("G21 G90\nG0 X100 Y100\nM3\n")
        while length < km * 1e6:
            t += 0.0004
            x = 100 + 85 * math.sin(3.01 * t)
            y = 100 + 85 * math.sin(2.0 * t + 0.3)
            seg = math.hypot(x - px, y - py)
            if seg < 5.0:
                continue
            f.write("G1 X%.3f Y%.3f F6000\n" % (x, y))
            length, px, py = length + seg, x, y
        f.write("M5\nM2\n")


def write_points(path, size_mb):
    target = size_mb * 1000 * 1000
    with open(path, "w") as f:
        f.write("G21 G90\nG0 X0 Y1\nM3\nF3000\n")
        n, y, x, d, buf = 0, 1.0, 0, 1, []
        while n < target:
            x += d
            if x > 200000 or x < 0:
                d, x, y = -d, x - 2 * d, y + 0.01
                if y > 190:
                    y = 1.0
            s = "G1 X%d.%03d Y%.2f\n" % (x // 1000, x % 1000, y)
            buf.append(s)
            n += len(s)
            if len(buf) > 100000:
                f.write("".join(buf))
                buf = []
        f.write("".join(buf))
        f.write("M5\nM2\n")


def run(plotkin, path):
    """Peak RSS (MB, the run's own VmHWM), CPU seconds, the JSON summary."""
    with tempfile.TemporaryFile("w+") as out:
        p = subprocess.Popen([plotkin, "sim", path, "--json"], stdout=out, stderr=subprocess.DEVNULL)
        _, status, ru = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        text = out.read()
    if p.returncode not in (0, 1) or not text:
        sys.exit("plotkin sim failed on %s (status %d)" % (path, p.returncode))
    j = json.loads(text)
    if j.get("vm_hwm_kb", -1) <= 0:
        sys.exit("plotkin sim did not report its peak memory (not Linux?)")
    return j["vm_hwm_kb"] / 1024.0, ru.ru_utime + ru.ru_stime, j


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--plotkin", default="build/plotkin")
    ap.add_argument("--size-mb", type=int, default=500)
    ap.add_argument("--km", type=float, default=1.0)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        jobs = [("%g km of path" % a.km, os.path.join(d, "km.gcode"), lambda p: write_lissajous(p, a.km)),
                ("%d MB file" % a.size_mb, os.path.join(d, "big.gcode"), lambda p: write_points(p, a.size_mb))]
        print("%-16s %10s %12s %9s %10s %12s %12s" % ("job", "file MB", "lines", "CPU s", "peak MB",
                                                      "deviation", "forced drops"))
        for name, path, gen in jobs:
            gen(path)
            mb = os.path.getsize(path) / 1e6
            rss, cpu, j = run(a.plotkin, path)
            if rss <= 0 or cpu <= 0:
                sys.exit("no measurement for %s" % name)
            print("%-16s %10.1f %12d %9.1f %10.1f %9.4f mm %12d" % (name, mb, j["lines"], cpu, rss,
                                                                    j["max_deviation_mm"], j["path_forced_drops"]))
            os.remove(path)


if __name__ == "__main__":
    main()
