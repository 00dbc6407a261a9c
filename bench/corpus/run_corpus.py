#!/usr/bin/env python3
"""Run the corpus of real G-code files through `plotkin sim` and print a table.

The corpus (bench/corpus/files/, listed in MANIFEST.tsv with its origin,
licence and generating tool) is G-code written by public tools and senders,
none of it by this project. Every file is run through `plotkin sim FILE --json`
once per mode (`--exact`, then `--tolerance` 0.01 / 0.02 / 0.05 mm by default)
with a machine configuration sized for the file's own work area (its bounding
box, computed independently by gcode_scan.py) and rates that suit its category
(pen plotter, laser, CNC router). For each file the table shows whether it runs
clean (no G-code error, no alarm, no driver timing violation), the errors by
Grbl code with the first refused lines and the commands on them, the simulated
motion time and the deviation plotkin reports, per mode; a summary gives
"N of M files run clean" and the refused commands across the corpus.

Work origin (--origin): `fit` (default) places the work origin the way a user
zeroes on the workpiece: when the program's box reaches below zero in X or Y,
the machine first moves there in machine coordinates and `G92 X0 Y0` makes it
the work origin (two preamble lines, not counted in the file's line numbers);
`file` runs the file as is from machine zero.

This is a benchmark: it prints findings and exits 0 whatever the G-code does.
It exits non-zero, loudly, when it cannot measure: plotkin missing or not
running, a committed file missing or not matching its manifest checksum, a
run that gives no result. Files the manifest lists as `external` (too large
to commit) are looked for in --external-dir; when absent they get a
"NOT PRESENT" line and are counted as skipped (never as passed);
--require-external makes that an error. --require-clean exits 1 when a file
does not run clean (for a gate once the G-code set is complete).

Python 3 standard library only.
"""

import argparse
import concurrent.futures
import hashlib
import json
import math
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, HERE)
import gcode_scan  # noqa: E402

REPO = os.path.dirname(os.path.dirname(HERE))
MANIFEST = os.path.join(HERE, "MANIFEST.tsv")
FILES = os.path.join(HERE, "files")

DEFAULT_MODES = ["exact", "0.01", "0.02", "0.05"]

# A handful of small files, one per kind of input, for CI-friendly runs.
QUICK = [
    "svg2gcode-shapes.gcode",            # pen, dense SVG flattening
    "grblplotter-grbl-logo.nc",          # pen lifted with Z, M3 S
    "rayforge-square-grbl-dynamic.gcode",  # laser, M4 with S per move
    "cncjs-g2-arc.gcode",                # arcs G2 IJK
    "pcb2gcode-multivibrator-outline.ngc",  # CAM, inches, G64 P, M6/M0
    "bcnc-sample.gcode",                 # sender example
]

# Machine settings per category ($N=value, as `$$` prints them). Travel is
# added per file from its bounding box. Rates: a light pen plotter, a diode
# laser gantry, a hobby CNC router (Shapeoko / X-Carve class).
CATEGORY_SETTINGS = {
    "pen": {100: 80, 101: 80, 102: 80, 110: 6000, 111: 6000, 112: 3000,
            120: 1000, 121: 1000, 122: 500},
    "laser": {100: 80, 101: 80, 102: 80, 110: 12000, 111: 12000, 112: 1500,
              120: 2000, 121: 2000, 122: 500},
    "cam": {100: 80, 101: 80, 102: 400, 110: 5000, 111: 5000, 112: 1000,
            120: 500, 121: 500, 122: 200},
}
CATEGORY_SETTINGS["sender-test"] = CATEGORY_SETTINGS["cam"]

TRAVEL_MAX_MM = 2000.0   # plotkin's $130-$132 range
TRAVEL_MARGIN_MM = 10.0

MANUAL_COLUMNS = ["file", "category", "repo", "path", "commit", "licence", "tool", "stored"]
COMPUTED_COLUMNS = ["bytes", "lines", "sha256", "units", "arcs", "g5", "z_moves", "z_levels",
                    "s_words", "s_on_moves", "codes", "unevaluated", "bbox_x_mm", "bbox_y_mm",
                    "bbox_z_mm"]


class Fatal(Exception):
    """The benchmark cannot measure: reported, exit status 2."""


# ---- manifest ----------------------------------------------------------------
def read_manifest(path=MANIFEST):
    if not os.path.exists(path):
        raise Fatal("manifest %s is missing" % path)
    rows = []
    with open(path, encoding="utf-8") as f:
        header = None
        for n, line in enumerate(f, 1):
            line = line.rstrip("\n")
            if not line or line.startswith("#"):
                continue
            cells = line.split("\t")
            if header is None:
                header = cells
                missing = [c for c in MANUAL_COLUMNS if c not in header]
                if missing:
                    raise Fatal("%s: header lacks %s" % (path, ", ".join(missing)))
                continue
            if len(cells) != len(header):
                raise Fatal("%s:%d: %d cells, header has %d" % (path, n, len(cells), len(header)))
            rows.append(dict(zip(header, cells)))
    if not rows:
        raise Fatal("%s lists no files" % path)
    return rows


def computed_columns(path):
    with open(path, "rb") as f:
        data = f.read()
    s = gcode_scan.scan_text(data.decode("latin-1"))
    b = s["box"]
    return {
        "bytes": str(len(data)),
        "lines": str(s["lines"]),
        "sha256": hashlib.sha256(data).hexdigest(),
        "units": s["units"],
        "arcs": str(s["arcs"]),
        "g5": str(s["g5"]),
        "z_moves": str(s["z_moves"]),
        "z_levels": str(s["z_levels"]),
        "s_words": str(s["s_values"]),
        "s_on_moves": str(s["laser_s_moves"]),
        "codes": " ".join(s["codes"]) or "-",
        "unevaluated": str(s["unevaluated"]),
        "bbox_x_mm": b.fmt(0),
        "bbox_y_mm": b.fmt(1),
        "bbox_z_mm": b.fmt(2),
    }


def write_manifest(rows, path=MANIFEST):
    header = MANUAL_COLUMNS + COMPUTED_COLUMNS
    with open(path, encoding="utf-8") as f:
        comments = [l for l in f if l.startswith("#")]
    with open(path + ".tmp", "w", encoding="utf-8") as f:
        f.writelines(comments)
        f.write("\t".join(header) + "\n")
        for r in rows:
            f.write("\t".join(r.get(c, "-") for c in header) + "\n")
    os.replace(path + ".tmp", path)


def locate(row, external_dir):
    if row["stored"] == "committed":
        return os.path.join(FILES, row["file"])
    if row["stored"] == "external":
        for d in filter(None, [external_dir, FILES]):
            p = os.path.join(d, row["file"])
            if os.path.exists(p):
                return p
        return None
    raise Fatal("%s: stored must be committed or external, not %r" % (row["file"], row["stored"]))


def verify(row, path):
    """A committed file must be byte-identical to what the manifest records."""
    with open(path, "rb") as f:
        data = f.read()
    if str(len(data)) != row.get("bytes") or hashlib.sha256(data).hexdigest() != row.get("sha256"):
        raise Fatal("%s does not match its manifest entry (size/sha256); run --write-manifest "
                    "only after checking the file against its origin %s %s @ %s"
                    % (path, row["repo"], row["path"], row["commit"]))


# ---- one run -------------------------------------------------------------------
def machine_config(category, box):
    """$N=value text for the category, travel sized for the box (mm) after the
    origin shift; returns (text, notes)."""
    if category not in CATEGORY_SETTINGS:
        raise Fatal("unknown category %r" % category)
    s = dict(CATEGORY_SETTINGS[category])
    notes = []
    for a, num in enumerate((130, 131, 132)):
        if box.empty() or not math.isfinite(box.lo[a]):
            need = 1.0
        elif a < 2:
            need = max(box.hi[a], 1.0)  # X, Y in [0, travel] after the shift
        else:
            need = max(abs(box.lo[a]), abs(box.hi[a]), 1.0)  # Z in [-travel, travel]
        t = math.ceil(need + TRAVEL_MARGIN_MM)
        if t > TRAVEL_MAX_MM:
            notes.append("%s needs %.0f mm > plotkin's %g mm travel" % ("XYZ"[a], need, TRAVEL_MAX_MM))
            t = TRAVEL_MAX_MM
        s[num] = int(t)
    return "".join("$%d=%s\n" % (k, v) for k, v in sorted(s.items())), notes


def origin_shift(box, mode):
    """Machine position (mm) made the work origin by the preamble, or None."""
    if mode == "file" or box.empty():
        return None
    ox = max(0.0, -box.lo[0]) + (TRAVEL_MARGIN_MM / 2 if box.lo[0] < 0 else 0.0)
    oy = max(0.0, -box.lo[1]) + (TRAVEL_MARGIN_MM / 2 if box.lo[1] < 0 else 0.0)
    if ox == 0.0 and oy == 0.0:
        return None
    return (round(ox, 3), round(oy, 3))


def shifted_box(box, shift):
    b = gcode_scan.Box()
    if box.empty():
        return b
    d = shift or (0.0, 0.0)
    b.add([box.lo[0] + d[0], box.lo[1] + d[1], box.lo[2]])
    b.add([box.hi[0] + d[0], box.hi[1] + d[1], box.hi[2]])
    return b


def run_sim(plotkin, program, cfg, mode, timeout):
    args = [plotkin, "sim", program, "--json", "--lower-bound", "--config", cfg, "--axes", "3"]
    args += ["--exact"] if mode == "exact" else ["--tolerance", mode]
    t0 = time.monotonic()
    try:
        p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           timeout=timeout if timeout > 0 else None)
    except subprocess.TimeoutExpired:
        return {"_fail": "timeout after %d s" % timeout, "_wall": time.monotonic() - t0}
    except OSError as e:
        raise Fatal("cannot run %s: %s" % (plotkin, e))
    wall = time.monotonic() - t0
    err = p.stderr.decode(errors="replace").strip()
    if p.returncode not in (0, 1):
        return {"_fail": "exit %d: %s" % (p.returncode, err.splitlines()[-1] if err else ""), "_wall": wall}
    try:
        r = json.loads(p.stdout.decode())
    except ValueError:
        return {"_fail": "no JSON (exit %d): %s" % (p.returncode, err[-200:]), "_wall": wall}
    r["_wall"] = wall
    r["_exit"] = p.returncode
    r["_stderr"] = err
    return r


def run_file(row, path, args):
    scan = gcode_scan.scan_file(path)
    shift = origin_shift(scan["box"], args.origin)
    cfg_text, notes = machine_config(row["category"], shifted_box(scan["box"], shift))
    with open(path, "rb") as f:
        body = f.read()
    pre = b""
    if shift is not None:
        pre = ("G21 G90 G0 X%.3f Y%.3f\nG92 X0 Y0\n" % shift).encode()
    res = {"row": row, "scan": scan, "shift": shift, "notes": notes, "modes": {},
           "preamble_lines": pre.count(b"\n")}
    with tempfile.TemporaryDirectory(prefix="plotkin-corpus-") as tmp:
        cfg = os.path.join(tmp, "machine.cfg")
        with open(cfg, "w") as f:
            f.write(cfg_text)
        prog = path
        if pre:
            prog = os.path.join(tmp, row["file"])
            with open(prog, "wb") as f:
                f.write(pre + body)
        for m in args.modes:
            r = run_sim(args.plotkin, prog, cfg, m, args.timeout)
            if "_fail" not in r and pre:
                n = res["preamble_lines"]
                bad = [e for e in r["error_lines"] if e["line"] <= n]
                if bad:
                    r["_fail"] = "the origin preamble was refused: %s" % bad
                for e in r["error_lines"]:
                    e["line"] -= n
                r["lines"] -= n
            res["modes"][m] = r
    return res


# ---- report --------------------------------------------------------------------
def is_clean(r):
    return ("_fail" not in r and r["errors"] == 0 and r["alarms"] == 0
            and r["timing_violations"] == 0 and r["status"] == "finished")


def source_lines(path, wanted):
    """Text of the lines plotkin names, numbered as plotkin numbers them:
    CR LF, a lone CR and a lone LF each end one line (bytes.splitlines). A
    file ending its lines in CR CR LF (one in this corpus) therefore counts
    two lines per line, in plotkin's error numbers and here alike."""
    out = {}
    if not wanted:
        return out
    with open(path, "rb") as f:
        for n, raw in enumerate(f.read().splitlines(), 1):
            if n in wanted:
                out[n] = raw.decode("latin-1").strip()
    return out


def refused_word(text, code):
    """What a refused line asks for: its G/M words (error:20 = unsupported
    command), else the error code's meaning."""
    if code == 15:
        return "travel"
    body = gcode_scan.strip_comments(text).upper()
    words = []
    for w in gcode_scan._WORD.findall(body):
        if w[0].upper() in "GM":
            v = float(w[1])
            name = "%s%g" % (w[0].upper(), v)
            if name not in ("G0", "G1", "G90", "G91", "G21", "G17", "G94"):
                words.append(name)
    if gcode_scan._PARAM_WORD.search(body):
        words.append("#param")
    if not words:
        if any(c in body for c in "IJR"):
            return "modal G2/G3"
        return "other"
    return "+".join(words)


# Per-mode columns: (header, unit, JSON key of `plotkin sim --json`, format).
# A later figure (true deviation from the programmed path, a time-optimal
# lower bound, ...) is one more entry; a key plotkin does not print yet shows
# as "n/a" (never as zero).
PER_MODE_COLUMNS = [
    ("t", "s", "sim_time_s", "%.2f"),
    ("dev", "mm", "max_deviation_mm", "%.3f"),
    ("lb", "s", "lower_bound_s", "%.2f"),
    ("t/lb", "x", "_t_over_lb", "%.3f"),
    ("gain", "%", "_gain_pct", "%+.1f"),
]


def add_derived(results, modes):
    """t/lb: plotkin's time over the lower bound of the same mode (sim_bound.h);
    gain: how much faster than the first mode (--exact), percent."""
    ref = modes[0]
    for res in results:
        r0 = res["modes"].get(ref, {})
        for m in modes:
            r = res["modes"][m]
            if "_fail" in r:
                continue
            t, lb = r.get("sim_time_s"), r.get("lower_bound_s")
            if t and lb:
                r["_t_over_lb"] = t / lb
            t0 = r0.get("sim_time_s") if "_fail" not in r0 else None
            if t and t0:
                r["_gain_pct"] = (t0 / t - 1.0) * 100.0


def fmt_cell(r, key, fmt):
    if "_fail" in r:
        return "FAIL"
    v = r.get(key)
    if v is None:
        return "n/a"
    return fmt % v


def report(results, args, skipped, wall):
    modes = args.modes
    add_derived(results, modes)
    ref = modes[0]
    hdr = ["file", "cat", "origin", "clean", "errors (code:count)", "first refused"]
    for name, unit, _, _ in PER_MODE_COLUMNS:
        hdr += ["%s %s %s" % (name, m, unit) for m in modes]

    def mode_cells(res):
        out = []
        for _, _, key, fmt in PER_MODE_COLUMNS:
            out += [fmt_cell(res["modes"][m], key, fmt) for m in modes]
        return out
    rows = []
    refused = {}
    fails = []
    for res in results:
        r = res["modes"][ref]
        row = res["row"]
        name = row["file"]
        origin = "G92@%g,%g" % res["shift"] if res["shift"] else "-"
        for m, rm in res["modes"].items():
            if "_fail" in rm:
                fails.append("%s [%s]: %s" % (name, m, rm["_fail"]))
        if "_fail" in r:
            rows.append([name, row["category"], origin, "FAIL", r["_fail"][:40], ""] + mode_cells(res))
            continue
        codes = {}
        for e in r["error_lines"]:
            codes[e["error"]] = codes.get(e["error"], 0) + 1
        listed = len(r["error_lines"])
        cs = " ".join("%d:%d" % kv for kv in sorted(codes.items()))
        if r["errors"] > listed:
            cs += " +%d" % (r["errors"] - listed)
        if r["alarms"]:
            cs += " ALARM:%s" % r["alarm"]
        if r["timing_violations"]:
            cs += " viol:%d" % r["timing_violations"]
        if r["status"] != "finished":
            cs += " STATUS:%s" % r["status"].replace(" ", "_")
        src = source_lines(res["path"], {e["line"] for e in r["error_lines"]})
        seen = []
        per_file = set()
        for e in r["error_lines"]:
            w = refused_word(src.get(e["line"], ""), e["error"])
            key = "error:%d %s" % (e["error"], w)
            per_file.add(key)
            if len(seen) < 3:
                seen.append("%d:%s" % (e["line"], w))
        for k in per_file:
            refused.setdefault(k, []).append(name)
        clean = all(is_clean(res["modes"][m]) for m in modes)
        rows.append([name, row["category"], origin, "yes" if clean else "no", cs or "-", " ".join(seen)] +
                    mode_cells(res))
    widths = [max(len(str(x[i])) for x in rows + [hdr]) for i in range(len(hdr))]
    print("plotkin corpus: %d files, modes %s, origin %s, plotkin %s" %
          (len(results), " ".join(modes), args.origin, args.plotkin))
    print("  t = simulated motion time (s, plotkin's clock); dev = max_deviation_mm as plotkin reports it;")
    print("  lb = lower bound on the motion time of any path within the mode's tolerance")
    print("       (plotkin sim --lower-bound, host-sim/sim_bound.h; exact: Grbl's junction model);")
    print("  gain = how much faster than the first mode, percent;")
    print("  clean = finished with no G-code error, no alarm, no timing violation in every mode;")
    print("  errors list the first %s errors plotkin records (code:count), +N = further errors" %
          "32")
    print(" | ".join(h.ljust(w) for h, w in zip(hdr, widths)))
    print("-+-".join("-" * w for w in widths))
    for x in rows:
        print(" | ".join(str(c).ljust(w) for c, w in zip(x, widths)))
    for s in skipped:
        print("NOT PRESENT %s (external: %s %s @ %s) - skipped, not counted as run" %
              (s["file"], s["repo"], s["path"], s["commit"]))
    n_clean = sum(1 for x in rows if x[3] == "yes")
    print()
    print("summary: %d of %d files run clean%s; wall %.1f s" %
          (n_clean, len(rows), " (%d external not present, skipped)" % len(skipped) if skipped else "", wall))
    by_cat = {}
    for x in rows:
        c = by_cat.setdefault(x[1], [0, 0])
        c[1] += 1
        c[0] += x[3] == "yes"
    print("  by category: " + ", ".join("%s %d/%d" % (k, v[0], v[1]) for k, v in sorted(by_cat.items())))
    for m in modes:
        ok = [res for res in results if "_fail" not in res["modes"][m]]
        tot = sum(res["modes"][m]["sim_time_s"] for res in ok)
        lbs = [res["modes"][m].get("lower_bound_s") for res in ok]
        lb = sum(x for x in lbs if x) if all(lbs) else None
        print("  total simulated time %-6s %10.1f s over %d files%s" %
              (m, tot, len(ok), "; lower bound %.1f s (x%.3f)" % (lb, tot / lb) if lb else ""))
    if refused:
        print("  refused (files whose first 32 errors include it):")
        for k, v in sorted(refused.items(), key=lambda kv: (-len(kv[1]), kv[0])):
            print("    %-34s %2d files: %s" % (k, len(v), ", ".join(v[:6]) + (" ..." if len(v) > 6 else "")))
    if fails:
        print("RUNS THAT GAVE NO RESULT:")
        for f in fails:
            print("  " + f)
    return n_clean, len(rows), fails


def report_saved(args, by_name):
    with open(args.report_json) as f:
        saved = json.load(f)
    args.modes = saved["modes"]
    args.origin = saved["origin"]
    args.plotkin = saved.get("plotkin", "(saved run)")
    results = []
    for x in saved["results"]:
        if x["file"] not in by_name:
            raise Fatal("%s: %s is not in the manifest" % (args.report_json, x["file"]))
        results.append({"row": by_name[x["file"]], "path": os.path.join(FILES, x["file"]),
                        "shift": tuple(x["origin_shift_mm"]) if x["origin_shift_mm"] else None,
                        "modes": x["modes"]})
    skipped = [by_name[n] for n in saved.get("skipped", [])]
    _, _, fails = report(results, args, skipped, saved.get("wall_s", 0.0))
    return 2 if fails else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--plotkin", default=os.path.join(REPO, "build", "plotkin"))
    ap.add_argument("--modes", default=",".join(DEFAULT_MODES),
                    help="comma list: exact and/or tolerances in mm (default %(default)s)")
    ap.add_argument("--quick", action="store_true", help="only the %d quick files" % len(QUICK))
    ap.add_argument("--only", action="append", default=[], help="files whose name contains this")
    ap.add_argument("--origin", choices=("fit", "file"), default="fit")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--timeout", type=int, default=0, help="seconds per run, 0 = none")
    ap.add_argument("--external-dir", default=None)
    ap.add_argument("--require-external", action="store_true")
    ap.add_argument("--require-clean", action="store_true")
    ap.add_argument("--json", dest="json_out", help="write the raw results here")
    ap.add_argument("--report-json", metavar="FILE",
                    help="print the table of a run saved with --json, without running plotkin")
    ap.add_argument("--write-manifest", action="store_true",
                    help="recompute the manifest's computed columns from the files, then stop")
    args = ap.parse_args()
    args.modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    for m in args.modes:
        if m != "exact":
            try:
                if float(m) <= 0:
                    raise ValueError
            except ValueError:
                raise Fatal("mode %r: 'exact' or a tolerance > 0 mm" % m)

    rows = read_manifest()
    names = [r["file"] for r in rows]
    if len(set(names)) != len(names):
        raise Fatal("duplicate file names in the manifest")

    if args.write_manifest:
        for r in rows:
            p = locate(r, args.external_dir)
            if p is None:
                print("not present, computed columns kept: %s" % r["file"])
                continue
            r.update(computed_columns(p))
        write_manifest(rows)
        print("wrote %s (%d files)" % (MANIFEST, len(rows)))
        return 0

    if args.report_json:
        return report_saved(args, {r["file"]: r for r in rows})

    if not (os.path.isfile(args.plotkin) and os.access(args.plotkin, os.X_OK)):
        raise Fatal("%s is not an executable (build it with `make`)" % args.plotkin)
    probe = subprocess.run([args.plotkin, "sim", "--help"], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT)
    if b"--json" not in probe.stdout:
        raise Fatal("%s sim --help does not offer --json" % args.plotkin)

    sel = rows
    if args.quick:
        sel = [r for r in rows if r["file"] in QUICK]
        if len(sel) != len(QUICK):
            raise Fatal("quick files missing from the manifest: %s" %
                        sorted(set(QUICK) - {r["file"] for r in sel}))
    if args.only:
        sel = [r for r in sel if any(o in r["file"] for o in args.only)]
        if not sel:
            raise Fatal("--only matches no file")

    todo, skipped = [], []
    for r in sel:
        p = locate(r, args.external_dir)
        if p is None:
            if r["stored"] == "committed" or args.require_external:
                raise Fatal("%s is missing (%s %s @ %s)" % (r["file"], r["repo"], r["path"], r["commit"]))
            skipped.append(r)
            continue
        if not os.path.exists(p):
            raise Fatal("%s is missing" % p)
        verify(r, p)
        todo.append((r, p))

    if not todo:
        for s in skipped:
            print("NOT PRESENT %s (external: %s %s @ %s)" % (s["file"], s["repo"], s["path"], s["commit"]))
        raise Fatal("nothing to measure: every selected file is external and not present")
    t0 = time.monotonic()
    results = []
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as ex:
        futs = [ex.submit(run_file, r, p, args) for r, p in todo]
        for (r, p), fu in zip(todo, futs):
            res = fu.result()
            res["path"] = p
            results.append(res)
            print("  ran %-42s %s" % (r["file"], " ".join(
                "%s=%s" % (m, fmt_cell(res["modes"][m], "sim_time_s", "%.2f")) for m in args.modes)),
                file=sys.stderr)
    wall = time.monotonic() - t0
    n_clean, n, fails = report(results, args, skipped, wall)

    if args.json_out:
        out = []
        for res in results:
            out.append({"file": res["row"]["file"], "category": res["row"]["category"],
                        "origin_shift_mm": res["shift"], "notes": res["notes"],
                        "bbox_mm": [[res["scan"]["box"].lo[a], res["scan"]["box"].hi[a]] for a in range(3)]
                        if not res["scan"]["box"].empty() else None,
                        "modes": {m: {k: v for k, v in r.items() if k != "_stderr"}
                                  for m, r in res["modes"].items()}})
        with open(args.json_out, "w") as f:
            json.dump({"modes": args.modes, "origin": args.origin, "plotkin": args.plotkin,
                   "wall_s": wall, "results": out,
                       "skipped": [s["file"] for s in skipped]}, f, indent=1)
    if fails:
        print("FAILED: %d runs gave no result" % len(fails), file=sys.stderr)
        return 2
    if args.require_clean and n_clean != n:
        print("FAILED: %d of %d files do not run clean" % (n - n_clean, n), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Fatal as e:
        print("run_corpus: FATAL: %s" % e, file=sys.stderr)
        sys.exit(2)
