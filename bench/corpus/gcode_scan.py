"""Static scan of a G-code file for the corpus manifest and the runner.

An independent reading of the program (it shares no code with plotkin's
parser): it interprets the modal state a Grbl-style controller keeps (units
G20/G21, distance G90/G91, arc distance G90.1/G91.1, plane G17/G18/G19, motion
G0/G1/G2/G3/G5/G5.1, G92 offsets) far enough to give

  * the work area the program needs: the bounding box of every programmed
    move (rapids included) in millimetres, in the program's own coordinates
    (G54 and friends are taken as zero offsets, which is what a controller
    has after power-on); arcs contribute their true extreme points, not just
    their end points; G5 cubic splines contribute their control hull;
  * the features the manifest records: units, arc count, Z moves, laser power
    S words (with M3/M4 and S, Grbl laser-mode style), G5 use, and the set of
    G/M codes the file uses.

Words whose value is an expression or a parameter (`#1`, `[...]`, LinuxCNC
O-words) cannot be evaluated here; they are counted in `unevaluated` and the
move they belong to is skipped for the bounding box, so a file that relies on
them says so instead of getting a silently wrong box.

Python 3 standard library only (Debian's python3).
"""

import math
import re

MM_PER_INCH = 25.4

# One word: a letter and a number; a parameter/expression value is matched
# separately so that it can be reported.
_WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
_PARAM_WORD = re.compile(r"([A-Za-z])\s*(#\S*|\[)")
_COMMENT_PAREN = re.compile(r"\([^)]*\)")


def strip_comments(line):
    """Remove `( ... )` and `; ...` comments, and a leading block delete."""
    line = _COMMENT_PAREN.sub(" ", line)
    cut = line.find(";")
    if cut >= 0:
        line = line[:cut]
    return line.strip()


class Box:
    """Axis-aligned bounding box over 3 axes (mm)."""

    def __init__(self):
        self.lo = [math.inf] * 3
        self.hi = [-math.inf] * 3

    def add(self, p):
        for a in range(3):
            if p[a] < self.lo[a]:
                self.lo[a] = p[a]
            if p[a] > self.hi[a]:
                self.hi[a] = p[a]

    def empty(self):
        return not math.isfinite(self.lo[0])

    def fmt(self, axis, nd=2):
        if self.empty() or not math.isfinite(self.lo[axis]):
            return "-"
        return "%.*f..%.*f" % (nd, self.lo[axis], nd, self.hi[axis])


def _arc_points(start, end, centre, cw, ax0, ax1):
    """Extreme points (in the plane axes ax0, ax1) of the arc from start to
    end about centre, plus the end point; cw is Grbl's G2. A full circle when
    start == end."""
    r = math.hypot(start[ax0] - centre[0], start[ax1] - centre[1])
    a0 = math.atan2(start[ax1] - centre[1], start[ax0] - centre[0])
    a1 = math.atan2(end[ax1] - centre[1], end[ax0] - centre[0])
    if cw:
        sweep = a0 - a1
    else:
        sweep = a1 - a0
    while sweep <= 1e-12:
        sweep += 2 * math.pi
    pts = []
    for k in range(4):  # the four axis directions
        ang = k * math.pi / 2
        d = (a0 - ang) if cw else (ang - a0)
        d %= 2 * math.pi
        if d <= sweep:
            q = list(end)
            q[ax0] = centre[0] + r * math.cos(ang)
            q[ax1] = centre[1] + r * math.sin(ang)
            pts.append(q)
    return pts


def scan_text(text):
    """Scan G-code text; returns a dict of features (see module doc)."""
    units = None          # "G20" / "G21" as first seen, or None
    units_seen = set()
    scale = 1.0           # mm per program unit
    absolute = True
    arc_abs = False       # G90.1
    plane = (0, 1)        # G17
    motion = 0            # 0,1,2,3,5
    pos = [0.0, 0.0, 0.0]  # program coordinates, mm
    box = Box()
    feed_box = Box()
    box.add(pos)
    n_lines = 0
    n_arcs = 0
    n_g5 = 0
    z_levels = set()
    z_moves = 0
    s_values = set()
    spindle_on = False
    s_cur = 0.0
    laser_s_moves = 0     # feed moves with the spindle/laser on and S > 0
    codes = set()
    unevaluated = 0
    n_moves = 0
    for raw in text.splitlines():
        n_lines += 1
        line = strip_comments(raw)
        if not line or line.startswith("%"):
            continue
        if line[0] in "/":
            line = line[1:]
        if line.startswith("$") or line.upper().startswith("O"):
            if line.upper().startswith("O"):
                unevaluated += 1
            continue
        if _PARAM_WORD.search(line):
            unevaluated += 1
            line = _PARAM_WORD.sub(" ", line)
        words = [(w[0].upper(), float(w[1])) for w in _WORD.findall(line)]
        if not words:
            continue
        axes = {}
        ijk = {}
        r_word = None
        explicit_motion = None
        g92 = False
        g53 = False
        g28 = False
        for letter, val in words:
            if letter == "G":
                code = round(val, 1)
                name = "G%g" % code
                codes.add(name)
                if code == 20:
                    scale = MM_PER_INCH
                    units_seen.add("G20")
                    units = units or "G20"
                elif code == 21:
                    scale = 1.0
                    units_seen.add("G21")
                    units = units or "G21"
                elif code == 90:
                    absolute = True
                elif code == 91:
                    absolute = False
                elif code == 90.1:
                    arc_abs = True
                elif code == 91.1:
                    arc_abs = False
                elif code == 17:
                    plane = (0, 1)
                elif code == 18:
                    plane = (2, 0)
                elif code == 19:
                    plane = (1, 2)
                elif code in (0, 1, 2, 3, 5, 5.1):
                    explicit_motion = code
                elif code == 92:
                    g92 = True
                elif code == 53:
                    g53 = True
                elif code in (28, 30):
                    g28 = True
                elif code == 80:
                    motion = None
            elif letter == "M":
                code = int(val)
                codes.add("M%d" % code)
                if code in (3, 4):
                    spindle_on = True
                elif code in (5, 2, 30):
                    spindle_on = False
            elif letter in "XYZ":
                axes["XYZ".index(letter)] = val * scale
            elif letter in "IJK":
                ijk["IJK".index(letter)] = val * scale
            elif letter == "R":
                r_word = val * scale
            elif letter == "S":
                s_values.add(val)
                s_cur = val
                codes.add("S")
            elif letter == "T":
                codes.add("T")
        if explicit_motion is not None:
            motion = explicit_motion
        if g92 or g28:
            continue  # offsets / homing: not a programmed path segment
        if not axes:
            # an arc with no end point is a full circle (cncjs example)
            if motion in (2, 3) and ijk and explicit_motion is not None:
                axes = {}
            else:
                continue
        if motion is None or (motion not in (0, 1, 2, 3, 5, 5.1)):
            continue
        target = list(pos)
        for a, v in axes.items():
            if g53 or absolute:
                target[a] = v
            else:
                target[a] = pos[a] + v
        n_moves += 1
        if motion in (2, 3):
            n_arcs += 1
            ax0, ax1 = plane
            if r_word is not None and not ijk:
                dx = target[ax0] - pos[ax0]
                dy = target[ax1] - pos[ax1]
                d = math.hypot(dx, dy)
                r = abs(r_word)
                if d > 0 and r >= d / 2:
                    h = math.sqrt(max(r * r - d * d / 4, 0.0))
                    # Grbl: positive R = the shorter arc
                    sgn = -1.0 if motion == 2 else 1.0
                    if r_word < 0:
                        sgn = -sgn
                    mx = pos[ax0] + dx / 2 - sgn * h * dy / d
                    my = pos[ax1] + dy / 2 + sgn * h * dx / d
                    centre = (mx, my)
                else:
                    centre = None
            else:
                off = [0.0, 0.0, 0.0]
                for a, v in ijk.items():
                    off[a] = v
                if arc_abs:
                    centre = (off[ax0], off[ax1])
                else:
                    centre = (pos[ax0] + off[ax0], pos[ax1] + off[ax1])
            if centre is not None:
                for q in _arc_points(pos, target, centre, motion == 2, ax0, ax1):
                    box.add(q)
                    feed_box.add(q)
        elif motion in (5, 5.1):
            n_g5 += 1
            off = [0.0, 0.0]
            for a, v in ijk.items():
                if a < 2:
                    off[a] = v
            box.add([pos[0] + off[0], pos[1] + off[1], pos[2]])
        if target[2] != pos[2]:
            z_moves += 1
        z_levels.add(round(target[2], 4))
        box.add(target)
        if motion != 0:
            feed_box.add(pos)
            feed_box.add(target)
            if spindle_on and s_cur > 0:
                laser_s_moves += 1
        pos = target
    return {
        "lines": n_lines,
        "moves": n_moves,
        "units": "+".join(sorted(units_seen)) if units_seen else "none(mm)",
        "arcs": n_arcs,
        "g5": n_g5,
        "z_moves": z_moves,
        "z_levels": len(z_levels),
        "s_values": len(s_values),
        "s_max": max(s_values) if s_values else 0.0,
        "laser_s_moves": laser_s_moves,
        "codes": sorted(codes, key=_code_key),
        "unevaluated": unevaluated,
        "box": box,
        "feed_box": feed_box,
    }


def _code_key(c):
    if c in ("S", "T"):
        return (2, 0.0)
    return (0 if c[0] == "G" else 1, float(c[1:]))


def scan_file(path):
    with open(path, "rb") as f:
        data = f.read()
    return scan_text(data.decode("latin-1"))
