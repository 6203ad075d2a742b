#!/usr/bin/env python3
# Writes data/examples/mountain_range.json (issue 12 gallery, paper figures 1, 8 and 11): a massif
# (a wide round free_crest) carrying one mountain_range stroke over summits and cols, spurs
# (free_crest) of varied length and spacing descending from the crest on both flanks, the long ones
# branching, a ravine between each pair of neighbouring spurs of a flank with its dendritic network
# (second-order branches, third-order gullies, sub-spurs between them), foothills on the plain, a
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
# The drainage network's own draws (tributaries, gullies, sub-spurs, profiles): the main layout keeps
# its draws from rng.
net = random.Random(1212)
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
ridge_lines = []  # every spur and fork: the branches of the ravines keep off them
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
            # A spur wanders (a sine across it, growing downstream) and steps down in knobs and
            # shoulders, not one smooth arc (net's draws: the layout keeps rng's).
            wig, ph = net.uniform(0.025, 0.06) * L, net.uniform(0, 2 * math.pi)
            steps = ((0.04, 0.45), (0.2, net.uniform(0.75, 0.9)), (0.35, 1.0), (0.52, net.uniform(0.7, 0.95)),
                     (0.7, net.uniform(0.5, 0.65)), (0.85, net.uniform(0.25, 0.4)), (1.0, 0.0))
            for f, hf in steps:
                off = bend * L * f * f + wig * f * math.sin(2 * math.pi * 1.3 * f + ph)
                pts.append([r1(x + f * L * ux - off * uy), r1(y + f * L * uy + off * ux), r1(hf * h)])
            last = roots[side][-1] if roots[side] else None
            # Fall lines converge towards a col: a spur that comes within 600 m of the previous one
            # of its flank below their roots (or crosses it) is left out.
            if last is None or min(dist_to(q, last[5]) for q in pts[1:]) > 600:
                width = round(min(1300, 700 + 0.15 * L))
                prof = net.choice(("sharp", "sharp", "sharp", "v", "v", "round"))
                ops.append({"op": "free_crest", "points": pts, "smooth": True, "width": width, "profile": prof})
                roots[side].append((s, z, lean, pts[-1], L, pts))
                spurs.append((pts, L, h, ux, uy))
                ridge_lines.append(pts)
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
        ridge_lines.append(bp)
        break
def branch(x0, y0, L, dx, dy, ex, ey, a, k, dmain, rm, heads):
    """One tributary of the main ravine (x0, y0) + t (dx, dy), t in [0, L] (depth dmain(a) at a L,
    half-width rm), joining at a L on side k."""
    jx, jy = x0 + a * L * dx, y0 + a * L * dy
    # The nearest ridge (spur or fork) on side k: the room the branch has.
    room = min([dist_to((jx, jy), q) for q in ridge_lines
                if sum((p[0] - jx) * ex + (p[1] - jy) * ey for p in q) * k > 0] or [1500.0])
    lat0 = min(700.0, net.uniform(0.42, 0.52) * room)
    th0 = net.uniform(22, 32)
    # Up to three tries, each steeper and shorter than the last.
    for attempt in range(3):
        lat = lat0 * (1 - 0.15 * attempt)
        # A gully, not a dent: 2-5 times as long as it is wide (22-48 degrees off the main ravine).
        th = math.radians(th0 + 8 * attempt)
        hx, hy = jx - lat / math.tan(th) * dx + k * lat * ex, jy - lat / math.tan(th) * dy + k * lat * ey
        seg = [(hx + f * (jx - hx), hy + f * (jy - hy)) for f in (0.2, 0.4, 0.6, 0.8)]
        # It keeps off the ridges, does not head within 300 m of the crest line (a head there
        # notched the cols) and keeps apart from the branches already on this ravine (where the
        # room grows downstream, a branch further down headed on top of the one above it: the two
        # trenches added up to a pit).
        # Its fade across the main ravine's wall (from 0.6 rm out) lies below the main ravine's
        # taper (0.5 rm from its head): along the taper the wall does not fall yet, and a branch
        # fading beside it held water.
        fade_from = a * L - min(0.6 * rm, 0.7 * lat) / math.tan(th)
        if (fade_from >= 0.7 * rm and lat >= 160 and all(dist_to(q, r) >= 0.2 * room for q in seg for r in ridge_lines) and dist_to((hx, hy), line) >= 300 and
                not any(math.hypot(hx - q[0], hy - q[1]) < 240 or dist_to(((hx + jx) / 2, (hy + jy) / 2), [(q[0], q[1]), (q[2], q[3])]) < 160
                        for hs in heads.values() for q in hs)):
            break
    else:
        return
    bend = net.uniform(-0.1, 0.1) * lat
    # Well under the main ravine's depth where it joins (a deeper branch ends in a pit).
    dt = net.uniform(0.38, 0.45) * dmain(a)
    # It deepens down to the main ravine's wall (0.6 rm from its axis) and fades out across the
    # wall, to nothing 0.1 rm from the axis: the main ravine's V wall falls towards its axis at
    # 12 u (1 - u)^2 dm / rm (u = distance / rm), and the branch's depth (at most 0.45 dm) fades
    # slower than that between u = 0.6 and 0.1, so its floor keeps falling into the main ravine.
    # (A branch deepest in its middle, a spoon, held water where it crossed the slope; one that
    # kept its depth to the axis dug a pit at the junction, where the main floor is flat across.)
    w = round(net.uniform(200, 300))
    o1 = min(0.6 * rm, 0.7 * lat)
    pts4 = []
    for out, fz in ((lat, 0.4), (0.5 * (lat + o1), 0.8), (o1, 1.0), (0.1 * rm, 0.05)):
        f = 1 - out / lat
        b_ = bend * 4 * f * (1 - f)  # the bend, none at the ends
        pts4.append([r1(hx + f * (jx - hx) + b_ * ex * k), r1(hy + f * (jy - hy) + b_ * ey * k), r1(fz * dt)])
    ops.append({"op": "ravine", "points": pts4, "smooth": True, "width": w, "profile": net.choice(("v", "sharp", "v")), "exit": 0})
    heads[k].append((hx, hy, jx, jy, lat, dt))
    tl = lat / math.sin(th)
    if tl > 480:
        # A third-order gully into the tributary's middle from the wedge between it and the main
        # ravine upstream, pointing downstream (turned 0.4-0.6 of the way to the main direction).
        ux, uy = (jx - hx) / tl, (jy - hy) / tl
        ga = net.uniform(0.4, 0.6) * th
        sgn = 1 if (ux * dy - uy * dx) < 0 else -1
        cx, cy = ux * math.cos(ga) - sgn * uy * math.sin(ga), uy * math.cos(ga) + sgn * ux * math.sin(ga)
        gx, gy = 0.5 * (hx + jx), 0.5 * (hy + jy)
        gl = net.uniform(0.35, 0.45) * tl
        sx, sy = gx - gl * cx, gy - gl * cy
        # Fading out across the branch's wall as the branch does across the main ravine's.
        gd = net.uniform(0.35, 0.45) * dt
        gw = round(net.uniform(160, 200))
        ops.append({"op": "ravine", "points": [[r1(sx + f * (gx - sx)), r1(sy + f * (gy - sy)), r1(fz * gd)]
                                               for f, fz in ((0, 0.4), (0.45, 0.85), (0.75, 1.0), (0.93, 0.05))],
                    "smooth": True, "width": gw, "profile": "v", "exit": 0})


def tributaries(main, rm):
    """Second-order ravines joining the main ravine `main` (points [x, y, depth], downstream last,
    half-width rm) at an acute angle pointing downstream, from a third of its length down, every
    0.09-0.13 of it, mostly alternating sides (both sides at a third of the stations), heading on the
    flank of the spur beside it; a third-order gully into the long ones; a sub-spur between two
    branches of one side."""
    (x0, y0, _), (x1, y1, _) = main[0], main[-1]
    L = math.hypot(x1 - x0, y1 - y0)
    dx, dy = (x1 - x0) / L, (y1 - y0) / L
    ex, ey = -dy, dx
    fr = [((q[0] - x0) * dx + (q[1] - y0) * dy) / L for q in main]

    def dmain(t):
        """The main ravine's depth at t of its length (linear between its vertices)."""
        for (f0, (_, _, z0)), (f1, (_, _, z1)) in zip(zip(fr, main), zip(fr[1:], main[1:])):
            if t <= f1:
                return z0 + (z1 - z0) * max(0.0, t - f0) / max(1e-9, f1 - f0)
        return main[-1][2]

    heads = {1: [], -1: []}
    # From a third of the way down: above that the main ravine is shallow and hemmed in by the
    # spurs' roots, and branches there ran into them (pits).
    a = net.uniform(0.25, 0.3)
    k = net.choice((-1, 1))
    while a < 0.78:  # (not where the main ravine shallows towards its exit)
        for side in (k, -k) if net.random() < 0.5 else (k,):
            branch(x0, y0, L, dx, dy, ex, ey, a, side, dmain, rm, heads)
        a += net.uniform(0.06, 0.09)
        k = -k if net.random() < 0.8 else k
    for side, hs in heads.items():
        for (hx0, hy0, jx0, jy0, lat0, d0), (hx1, hy1, jx1, jy1, lat1, d1) in zip(hs, hs[1:]):
            # The sub-spur: from the spur's flank above the two heads down between them, ending
            # short of the main ravine's floor.
            tx, ty = 0.5 * (hx0 + hx1), 0.5 * (hy0 + hy1)
            fx, fy = 0.5 * (jx0 + jx1), 0.5 * (jy0 + jy1)
            tx, ty = tx + side * 0.15 * lat0 * ex, ty + side * 0.15 * lat0 * ey
            fx, fy = fx + side * 0.3 * lat1 * ex, fy + side * 0.3 * lat1 * ey
            hz = net.uniform(0.35, 0.55) * max(d0, d1)
            ops.append({"op": "free_crest", "points": [[r1(tx), r1(ty), r1(0.5 * hz)], [r1(0.55 * tx + 0.45 * fx), r1(0.55 * ty + 0.45 * fy), r1(hz)], [r1(fx), r1(fy), 0.0]],
                        "smooth": True, "width": round(net.uniform(320, 450)), "profile": net.choice(("sharp", "round"))})


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
        ops.append({"op": "ravine", "points": pts, "smooth": True, "width": width, "profile": "v", "exit": 500,
                    "taper": round(0.25 * width)})
        tributaries(pts, 0.5 * width)
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
    # Narrower than drawn (0.7) with the v profile (steep flanks, a rounded top): the round
    # 1.4-2.2 km ones read as soft swells, sharp ones as scratches on the plain.
    width = round(0.7 * rng.uniform(1400, 2200))
    ops.append({"op": "free_crest", "comment": "foothill" if k == 0 else None, "points": pts, "smooth": True, "width": width,
                "profile": "v"})
ops = [{k: v for k, v in o.items() if v is not None} for o in ops]
ops.append({"op": "river", "points": [[-100, 14400, 140], [3500, 13300, 136], [7500, 14500, 130], [11000, 13600, 125],
                                      [15500, 14200, 120]], "smooth": True, "width": 1800, "floor": 40, "bank_height": 40})
# Seeds pinned to those of the 51-operation script before the drainage network (8 * 1000003 + index):
# the plain keeps its relief whatever is added above.
ops.append({"op": "noise", "comment": "rolling relief on the plain", "amplitude": 45, "wavelength": 2600, "octaves": 4, "seed": 8000073})
ops.append({"op": "noise", "amplitude": 10, "wavelength": 1200, "octaves": 4, "seed": 8000074})
# Ridged noise on the range and its foothills (a band 2.3 km past the massif's edge, fading over
# 1.2 km): sharp little crests and gullies on the flanks and the foothills, none on the plain.
band = []
for side in (1, -1):
    ring = []
    for s in range(0, int(arc[-1]) + 1, 500):
        (x, y, _), (nx, ny) = at(min(s, arc[-1] - 1))
        ring.append([r1(x + side * (MASSIF + 2300) * nx), r1(y + side * (MASSIF + 2300) * ny)])
    band += ring if side == 1 else ring[::-1]
ops.append({"op": "noise", "comment": "ridged texture on the range and foothills", "polygon": band, "falloff": 1200,
            "amplitude": 15, "wavelength": 650, "octaves": 3, "type": "ridged", "seed": 31})
doc = {"description": "A mountain range (paper figures 1, 8 and 11), written by scripts/gen-mountain-range.py: a massif (round free_crest 8.6 km wide, 350-480 m) under one gently bending smoothed mountain_range stroke 4.8 km wide through summits (1150-1800 m over the massif) and cols at ~0.8 of the lower summit beside them, ridged noise (140 m, 800 m) dragged across it; spurs (free_crest, sharp, v or round, 12-25 % of the crest's height) of 1.2-3.1 km descending along the flank's fall line every 550-750 or 1100-1700 m on each flank, wandering and stepping down in knobs and shoulders, the long ones branching; a main ravine (v, deepening downstream, exiting over 500 m on the massif's lower flank) between each pair of neighbouring spurs, with a dendritic network: second-order ravines (200-300 m wide, 0.38-0.45 of the main depth) joining it at 22-48 degrees pointing downstream, heading on the spurs' flanks and fading out across the main ravine's wall, third-order gullies into the long ones, sub-spurs between the branches of one side; low v-profile foothill ridges, ridged noise (15 m, 650 m) over the range and foothills and rolling fBm (45 m, 2.6 km) on the plain; a river meandering across the plain.",
       "base": "flat:1025x1025@15", "units": "m", "seed": 8, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
