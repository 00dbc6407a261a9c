#!/usr/bin/env python3
"""Write flower.gcode, plotkin's bundled example drawing (run once; the output
is committed). A frame with sharp corners, a six-petal flower and a circle
drawn as coarse polylines (what smoothing is for), a spiral, and the word
PLOTKIN in straight strokes (corners that must stay sharp).
Usage: python3 make_flower.py > flower.gcode"""
import math

out = []
def g(s): out.append(s)

def stroke(pts, feed=3000):
    x, y = pts[0]
    g(f"G0 X{x:.3f} Y{y:.3f}")
    g("M3")
    for x, y in pts[1:]:
        g(f"G1 X{x:.3f} Y{y:.3f} F{feed}")
    g("M5")

g("(plotkin example: flower, circle, spiral, lettering, frame)")
g("G21 G90 G64 P0.02")
# frame: sharp corners
stroke([(0, 0), (140, 0), (140, 140), (0, 140), (0, 0)])
# six-petal flower, 60 points: r = 22 + 18 cos(6 t)
cx, cy = 70, 86
pts = []
for i in range(61):
    t = 2 * math.pi * i / 60
    r = 22 + 18 * math.cos(6 * t)
    pts.append((cx + r * math.cos(t), cy + r * math.sin(t)))
stroke(pts)
# the flower's centre: a circle as a 12-gon (coarse on purpose)
pts = [(cx + 8 * math.cos(2 * math.pi * i / 12), cy + 8 * math.sin(2 * math.pi * i / 12)) for i in range(13)]
stroke(pts)
# a stem with a leaf: straight stem, curved leaf as a polyline
stroke([(70, 46), (70, 34), (70, 22)])
# a leaf: two arcs from the stem to a pointed tip (sharp at both ends)
tip = (88, 42)
upper = [(70 + (tip[0] - 70) * i / 12, 34 + (tip[1] - 34) * i / 12 + 5 * math.sin(math.pi * i / 12)) for i in range(13)]
lower = [(70 + (tip[0] - 70) * i / 12, 34 + (tip[1] - 34) * i / 12 - 3 * math.sin(math.pi * i / 12)) for i in range(12, -1, -1)]
stroke(upper + lower[1:])
# a spiral in the top-right corner, 3 turns, 15 degree steps
pts = []
for i in range(73):
    t = 2 * math.pi * i / 24
    r = 1 + 12 * i / 72
    pts.append((118 + r * math.cos(t), 118 + r * math.sin(t)))
stroke(pts)
# PLOTKIN in 8 mm block letters at the bottom (sharp corners)
x0, y0, w, h = 12, 6, 8, 10
letters = {
    "P": [[(0, 0), (0, 1), (0.8, 1), (0.8, 0.5), (0, 0.5)]],
    "L": [[(0, 1), (0, 0), (0.8, 0)]],
    "O": [[(0, 0), (0.8, 0), (0.8, 1), (0, 1), (0, 0)]],
    "T": [[(0, 1), (0.8, 1)], [(0.4, 1), (0.4, 0)]],
    "K": [[(0, 0), (0, 1)], [(0.8, 1), (0, 0.45), (0.8, 0)]],
    "I": [[(0.4, 0), (0.4, 1)]],
    "N": [[(0, 0), (0, 1), (0.8, 0), (0.8, 1)]],
}
for k, ch in enumerate("PLOTKIN"):
    for s in letters[ch]:
        stroke([(x0 + k * 17 + px * w, y0 + py * h) for px, py in s])
g("G0 X0 Y0")
g("M2")
print("\n".join(out))
