#!/usr/bin/env python3
# Writes data/examples/mountain_range.json (issue 12 gallery, paper figures 1, 8 and 11): one
# mountain_range stroke over summits and cols, spurs (free_crest) descending from the crest on both
# flanks, a ravine between each pair of neighbouring spurs along the flank's fall line, a river on
# the plain. Usage: python3 scripts/gen-mountain-range.py OUT.json
import json, math, random, sys

# The crest: summits (even indices) and cols (odd), [x, y, z] in metres on a 15.36 km square. The
# line bends gently (radius of curvature >= 5 km, twice the half-width): a bend tighter than the
# half-width folds the flank on its inner side (a crease where the two legs' profiles meet).
XZ = [(1200, 450), (2200, 324), (3200, 1150), (4150, 828), (5100, 1550), (6050, 900), (7000, 1250), (8000, 900),
      (9000, 1900), (10100, 972), (11200, 1350), (11950, 972), (12700, 1600), (13400, 540), (14100, 750)]
crest = [[x, round(7200 - 0.16 * (x - 7650) + 350 * math.sin(2 * math.pi * (x - 1200) / 9000), 1), z] for x, z in XZ]
HALF = 2400.0  # the stroke's half-width r (m)


def catmull(pts, n=24):
    """Centripetal-ish (uniform) Catmull-Rom samples through pts (x, y, z), n per segment."""
    out = []
    P = [pts[0]] + pts + [pts[-1]]
    for i in range(1, len(P) - 2):
        p0, p1, p2, p3 = P[i - 1], P[i], P[i + 1], P[i + 2]
        for k in range(n):
            t = k / n
            out.append([0.5 * ((2 * p1[j]) + (-p0[j] + p2[j]) * t + (2 * p0[j] - 5 * p1[j] + 4 * p2[j] - p3[j]) * t * t +
                               (-p0[j] + 3 * p1[j] - 3 * p2[j] + p3[j]) * t ** 3) for j in range(3)])
    out.append(list(pts[-1]))
    return out


line = catmull(crest)
arc = [0.0]
for a, b in zip(line, line[1:]):
    arc.append(arc[-1] + math.hypot(b[0] - a[0], b[1] - a[1]))


def at(s):
    """Point, unit normal (towards +y, the south flank) and crest height at arc length s."""
    i = max(1, min(len(line) - 2, next((k for k, v in enumerate(arc) if v >= s), len(arc) - 2)))
    a, b = line[i - 1], line[i + 1]
    tx, ty = b[0] - a[0], b[1] - a[1]
    l = math.hypot(tx, ty)
    return line[i], (-ty / l, tx / l)


def fall(s):
    """Lean of the fall line off the normal: the flank falls away from the summits beside it."""
    (_, _, za), _ = at(s - 300)
    (_, _, zb), _ = at(s + 300)
    return max(-0.35, min(0.35, -0.6 * (zb - za) / 600))


ops = [{
    "op": "mountain_range", "points": crest, "smooth": True, "width": 2 * HALF, "profile": "sharp",
    "noise": {"amplitude": 140, "wavelength": 800, "octaves": 5, "type": "ridged", "orient_strength": 0.85},
}]
# Spurs every ~760 m along the crest, alternating flanks with a jitter, each descending to ~0.9 r
# from its root near the crest; a ravine between neighbouring spurs of the same flank.
rng = random.Random(12)  # fixed: the script writes the same file every time
step, s, k = 450.0, 1500.0, 0
roots = {1: [], -1: []}
while s < arc[-1] - 1300:
    side = 1 if k % 2 == 0 else -1
    (x, y, z), (nx, ny) = at(s)
    if z > 600:
        nx, ny = side * nx, side * ny
        lean = -side * fall(s) + rng.uniform(-0.08, 0.08)  # down the fall line, give or take (t = -side T)
        tx, ty = -ny * lean, nx * lean
        h = rng.uniform(0.15, 0.25) * z
        L = rng.uniform(0.6, 0.95) * HALF
        pts = []
        for f, hz in ((0.05, 0.45 * h), (0.4, h), (0.95, 0.0)):
            pts.append([round(x + f * L * (nx + tx), 1), round(y + f * L * (ny + ty), 1), round(hz, 1)])
        # Fall lines converge towards a col: a spur whose foot comes within 700 m of its neighbour's
        # on the same flank is left out (the ravine between the neighbours takes its place).
        last = roots[side][-1] if roots[side] else None
        if last is None or math.hypot(pts[-1][0] - last[3][0], pts[-1][1] - last[3][1]) > 700:
            ops.append({"op": "free_crest", "points": pts, "smooth": True, "width": 1100, "profile": "sharp"})
            roots[side].append((s, z, lean, pts[-1]))
    s += step * rng.uniform(0.7, 1.3)
    k += 1
for side in (1, -1):
    rs = roots[side]
    for (s0, z0, l0, _), (s1, z1, l1, _) in zip(rs, rs[1:]):
        sm = 0.5 * (s0 + s1)
        (x, y, z), (nx, ny) = at(sm)
        nx, ny = side * nx, side * ny
        lean = 0.5 * (l0 + l1)  # parallel to the spurs on either side
        tx, ty = -ny * lean, nx * lean
        d = rng.uniform(0.2, 0.26) * min(z0, z1)
        L = rng.uniform(0.65, 0.8) * HALF
        pts = []
        for f, dz in ((0.08, 0.3 * d), (0.45, d), (1.0, 0.35 * d)):
            pts.append([round(x + f * L * (nx + tx), 1), round(y + f * L * (ny + ty), 1), round(dz, 1)])
        ops.append({"op": "ravine", "points": pts, "smooth": True, "width": round(rng.uniform(900, 1000)), "profile": "v", "exit": 500})
ops.append({"op": "river", "points": [[-100, 14400, 140], [3500, 13300, 136], [7500, 14500, 130], [11000, 13600, 125],
                                      [15500, 14200, 120]], "smooth": True, "width": 1800, "floor": 40, "bank_height": 40})
ops.append({"op": "noise", "amplitude": 10, "wavelength": 1200, "octaves": 4})
doc = {"description": "A mountain range (paper figures 1, 8 and 11), written by scripts/gen-mountain-range.py: one gently bending smoothed mountain_range stroke 4.8 km wide (sharp profile, its crest rounded over 0.08 r: no knife line) through eight summits (450-1900 m) and the cols between them, ridged noise (140 m, 800 m) dragged across it; spurs (free_crest, sharp profile with its crest rounded, 1100 m wide, 15-25 % of the crest's height) descending from the crest on alternating flanks every ~520 m (+-30 %); a ravine (900-1000 m wide, deepening downstream, parallel to the spurs beside it) between each pair of neighbouring spurs along the flank's fall line; a river meandering across the plain at ~100 m.",
       "base": "flat:1025x1025@15", "units": "m", "seed": 8, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
