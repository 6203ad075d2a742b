#!/usr/bin/env python3
# Writes data/examples/mountain_range.json (issue 12 gallery, paper figures 1, 8 and 11): a massif
# (a wide round free_crest) carrying one mountain_range stroke over summits and cols, spurs
# (free_crest) of varied length and spacing descending from the crest on both flanks, the long ones
# branching, a ravine between each pair of neighbouring spurs of a flank, foothills on the plain, a
# river. Usage: python3 scripts/gen-mountain-range.py OUT.json
import json, math, os, random, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from polyline import arc_lengths, catmull  # noqa: E402

# The crest: summits (even indices) and cols (odd), [x, y, z] in metres on a 15.36 km square, z the
# crest's relief over the massif. The cols stand at ~0.8 of the lower summit beside them (and the
# massif lifts both): the crest reads as one line from peak to peak, not a row of pyramids. The
# line bends gently (radius of curvature >= 5 km, twice the half-width): a bend tighter than the
# half-width folds the flank on its inner side (a crease where the two legs' profiles meet).
XZ = [(1200, 380), (2200, 520), (3200, 1150), (4150, 930), (5100, 1500), (6050, 1050), (7000, 1300), (8000, 1000),
      (9000, 1800), (10100, 1150), (11200, 1450), (11950, 1120), (12700, 1550), (13400, 760), (14100, 600)]
crest = [[x, round(7200 - 0.16 * (x - 7650) + 350 * math.sin(2 * math.pi * (x - 1200) / 9000), 1), z] for x, z in XZ]
HALF = 2400.0  # the stroke's half-width r (m)
MASSIF = 4300.0  # the massif's half-width (m)


line = catmull(crest, 24)
arc = arc_lengths(line)


def at(s):
    """Point and unit normal (towards +y, the south flank) at arc length s."""
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


def r1(v):
    return round(v, 1)


def dist_to(p, pts):
    """Distance from p to the polyline pts."""
    best = 1e30
    for a, b in zip(pts, pts[1:]):
        dx, dy = b[0] - a[0], b[1] - a[1]
        t = max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (dx * dx + dy * dy)))
        best = min(best, math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy))
    return best


rng = random.Random(12)  # fixed: the script writes the same file every time
# The massif under the crest: its relief varies slowly (350-480 m), so the range stands on a
# continuous body and the spurs and ravines fall across it down to the foothills.
massif = [[p[0], p[1], round(350 + 0.07 * p[2] + rng.uniform(-20, 20))] for p in crest]
ops = [{"op": "free_crest", "comment": "the massif", "points": massif, "smooth": True, "width": 2 * MASSIF, "profile": "round"},
       {"op": "mountain_range", "points": crest, "smooth": True, "width": 2 * HALF, "profile": "sharp",
        "noise": {"amplitude": 140, "wavelength": 800, "octaves": 5, "type": "ridged", "orient_strength": 0.85}}]
# Spurs on each flank on their own: spacing 550-750 or 1100-1700 m, lengths 0.5-1.3 r (the long ones run out
# onto the massif and branch), heights 12-25 % of the crest's, each bending a little.
roots = {1: [], -1: []}
spurs = []
for side in (1, -1):
    s = rng.uniform(1200, 1800)
    while s < arc[-1] - 1300:
        (x, y, z), (nx, ny) = at(s)
        if z > 650:
            nx, ny = side * nx, side * ny
            lean = -side * fall(s) + rng.uniform(-0.1, 0.1)
            tx, ty = -ny * lean, nx * lean
            ux, uy = nx + tx, ny + ty
            ul = math.hypot(ux, uy)
            ux, uy = ux / ul, uy / ul
            L = rng.uniform(0.5, 1.3) * HALF
            h = rng.uniform(0.12, 0.25) * z
            bend = rng.uniform(-0.08, 0.08)  # sideways drift at the foot, as a share of L
            pts = []
            for f, hz in ((0.04, 0.45 * h), (0.35, h), (0.7, 0.6 * h), (1.0, 0.0)):
                off = bend * L * f * f
                pts.append([r1(x + f * L * ux - off * uy), r1(y + f * L * uy + off * ux), r1(hz)])
            last = roots[side][-1] if roots[side] else None
            # Fall lines converge towards a col: a spur that comes within 600 m of the previous one
            # of its flank below their roots (or crosses it) is left out.
            if last is None or min(dist_to(q, last[5]) for q in pts[1:]) > 600:
                width = round(min(1300, 700 + 0.15 * L))
                ops.append({"op": "free_crest", "points": pts, "smooth": True, "width": width, "profile": "sharp"})
                roots[side].append((s, z, lean, pts[-1], L, pts))
                spurs.append((pts, L, h, ux, uy))
        # Uneven: short and long gaps mixed (a uniform draw read as comb teeth).
        s += rng.uniform(550, 750) if rng.random() < 0.5 else rng.uniform(1100, 1700)
# Branches: the long spurs fork at a third of their length, 25-40 degrees off, on the side where
# the fork's foot stays within 30 % of the way to the next spur (the ravine between them runs on
# the middle line and must keep its floor).
for pts, L, h, ux, uy in spurs:
    if L <= 0.95 * HALF:
        continue
    b = pts[1]
    bl = rng.uniform(0.3, 0.45) * L
    hb = 0.55 * h
    others = [q for q, *_ in spurs if q is not pts]
    for deg in (40, 32, 25):
        for sgn in rng.sample((-1, 1), 2):
            a = sgn * math.radians(deg)
            bx, by = ux * math.cos(a) - uy * math.sin(a), ux * math.sin(a) + uy * math.cos(a)
            end = (b[0] + bl * bx, b[1] + bl * by)
            own = bl * math.sin(math.radians(deg))
            if all(dist_to(end, q) > own / 0.3 - own for q in others):
                break
        else:
            continue
        bp = [[r1(b[0] + f * bl * bx), r1(b[1] + f * bl * by), r1(hz)] for f, hz in ((0.1, 0.7 * hb), (0.45, hb), (1.0, 0.0))]
        ops.append({"op": "free_crest", "points": bp, "smooth": True, "width": 700, "profile": "sharp"})
        break
summit_arcs = [min(range(len(line)), key=lambda k: math.hypot(line[k][0] - c[0], line[k][1] - c[1])) for c in crest[0::2]]
summit_arcs = [arc[k] for k in summit_arcs]
for side in (1, -1):
    rs = roots[side]
    for (s0, z0, l0, _, L0, _), (s1, z1, l1, _, L1, _) in zip(rs, rs[1:]):
        sm = 0.5 * (s0 + s1)
        # Below a summit a ravine heads mid-slope: one heading on the summit ran down the convex
        # nose of its cone, whose cross-fall filled it (a 40 m notch for 190 m).
        f0 = 0.3 if any(abs(sm - a) < 450 for a in summit_arcs) else 0.08
        (x, y, z), (nx, ny) = at(sm)
        nx, ny = side * nx, side * ny
        lean = 0.5 * (l0 + l1)  # parallel to the spurs on either side
        tx, ty = -ny * lean, nx * lean
        d = rng.uniform(0.2, 0.26) * min(z0, z1)
        # It runs as far as the shorter spur beside it and a little past: onto the massif's lower
        # flank, where the ground still falls (a ravine ending on the plain leaves a hollow).
        L = max(0.65 * HALF, min(1.15 * HALF, min(L0, L1) * rng.uniform(0.8, 0.95)))
        pts = []
        for f, dz in ((f0, 0.3 * d), (0.5 * (f0 + 1) - 0.09, d), (1.0, 0.35 * d)):
            pts.append([r1(x + f * L * (nx + tx)), r1(y + f * L * (ny + ty)), r1(dz)])
        # As wide as the gap between the spurs allows (a 950 m ravine between spurs 600 m apart was
        # filled by their flanks).
        width = round(max(600, min(rng.uniform(900, 1000), 0.85 * (s1 - s0))))
        ops.append({"op": "ravine", "points": pts, "smooth": True, "width": width, "profile": "v", "exit": 500})
# Foothills: low round ridges roughly along the range on the plain, north and south of the massif.
for k in range(9):
    south = k % 2 == 0
    x = rng.uniform(1500, 13800)
    base = 7200 - 0.16 * (x - 7650) + 350 * math.sin(2 * math.pi * (x - 1200) / 9000)
    y = base + (1 if south else -1) * rng.uniform(MASSIF + 800, MASSIF + 1900)
    a = math.radians(rng.uniform(-25, 25) - 9)
    L = rng.uniform(2500, 4500)
    h = rng.uniform(60, 150)
    pts = [[r1(x + f * L * math.cos(a)), r1(y + f * L * math.sin(a) + 250 * math.sin(3 * f)), r1(hz)] for f, hz in ((-0.5, 0.3 * h), (0, h), (0.5, 0.4 * h))]
    ops.append({"op": "free_crest", "comment": "foothill" if k == 0 else None, "points": pts, "smooth": True, "width": round(rng.uniform(1400, 2200)), "profile": "round"})
ops = [{k: v for k, v in o.items() if v is not None} for o in ops]
ops.append({"op": "river", "points": [[-100, 14400, 140], [3500, 13300, 136], [7500, 14500, 130], [11000, 13600, 125],
                                      [15500, 14200, 120]], "smooth": True, "width": 1800, "floor": 40, "bank_height": 40})
ops.append({"op": "noise", "comment": "rolling relief on the plain", "amplitude": 45, "wavelength": 2600, "octaves": 4})
ops.append({"op": "noise", "amplitude": 10, "wavelength": 1200, "octaves": 4})
doc = {"description": "A mountain range (paper figures 1, 8 and 11), written by scripts/gen-mountain-range.py: a massif (round free_crest 8.6 km wide, 350-480 m) under one gently bending smoothed mountain_range stroke 4.8 km wide through summits (1150-1800 m over the massif) and cols at ~0.8 of the lower summit beside them, ridged noise (140 m, 800 m) dragged across it; spurs (free_crest, sharp profile, 12-25 % of the crest's height) of 1.2-3.1 km descending along the flank's fall line every 550-750 or 1100-1700 m on each flank, the long ones branching; a ravine (deepening downstream, parallel to the spurs beside it, exiting over 500 m on the massif's lower flank) between each pair of neighbouring spurs; low round foothill ridges and rolling fBm (45 m, 2.6 km) on the plain; a river meandering across the plain.",
       "base": "flat:1025x1025@15", "units": "m", "seed": 8, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
