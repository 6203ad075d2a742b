#!/usr/bin/env python3
# Writes data/examples/mountain_range.json (issue 12 gallery, paper figures 1, 8 and 11): a massif
# (a wide round free_crest) carrying one mountain_range stroke over summits and cols; spurs
# (free_crest) that radiate from the summits and shoulders down both flanks, fanned like the fall
# lines of a peak, of varied length, the long ones forking (second-order spurs) and running out
# onto the plain as low hogback ridges (the foothills); a main ravine on the midline between each
# pair of neighbouring spurs of a flank, as wide as the gap allows, with its dendritic network
# (second-order branches, third-order gullies, sub-spurs between them), its floor falling evenly
# to its exit; a rolling plain (fBm kept off the range) with a river. Usage: python3
# scripts/gen-mountain-range.py OUT.json
import json, math, os, random, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from polyline import arc_lengths, catmull  # noqa: E402

# The crest: summits (even indices) and cols (odd), [x, y, z] in metres on a 15.36 km square, z the
# crest's relief over the massif. The cols stand at ~0.8 of the lower summit beside them (and the
# massif lifts both): the crest reads as one line from peak to peak, not a row of pyramids. The
# line bends gently (radius of curvature >= 5 km, twice the half-width): a bend tighter than the
# half-width folds the flank on its inner side (a crease where the two legs' profiles meet).
XZ = [(1200, 380), (2200, 520), (3200, 1150), (4150, 930), (5100, 1500), (6050, 1050), (7000, 1300), (8000, 1000),
      (9000, 1800), (10100, 1200), (11200, 1450), (11950, 1120), (12700, 1550), (13400, 760), (14100, 600)]
crest = [[x, round(7200 - 0.16 * (x - 7650) + 350 * math.sin(2 * math.pi * (x - 1200) / 9000), 1), z] for x, z in XZ]
HALF = 2000.0  # the stroke's half-width r (m)
MASSIF = 3600.0  # the massif's half-width (m)


line = catmull(crest, 24)
arc = arc_lengths(line)


def at(s):
    """Point and unit normal (towards +y, the south flank) at arc length s."""
    i = max(1, min(len(line) - 2, next((k for k, v in enumerate(arc) if v >= s), len(arc) - 2)))
    a, b = line[i - 1], line[i + 1]
    tx, ty = b[0] - a[0], b[1] - a[1]
    l = math.hypot(tx, ty)
    return line[i], (-ty / l, tx / l)


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


def along(pts, t):
    """The point at arc length t along the polyline pts (clamped to its ends)."""
    for a, b in zip(pts, pts[1:]):
        l = math.hypot(b[0] - a[0], b[1] - a[1])
        if t <= l or b is pts[-1]:
            f = max(0.0, min(1.0, t / l if l else 0.0))
            return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]))
        t -= l


def length(pts):
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:]))


rng = random.Random(12)  # fixed: the script writes the same file every time
net = random.Random(1212)  # the drainage network's own draws
# The massif under the crest: its relief varies slowly (260-370 m), so the range stands on a
# continuous body and the spurs and ravines fall across it down to the foothills.
# It lies 700 m south of the crest line: the range is asymmetric, a steeper north flank with
# shorter spurs and a longer south flank whose spurs run out onto the plain (a symmetric body with
# legs of one length on both sides read as a caterpillar).
SHIFT = 700.0
massif = [[p[0], p[1] + SHIFT, round(260 + 0.05 * p[2] + rng.uniform(-15, 15))] for p in crest]
ops = [{"op": "free_crest", "comment": "the massif", "points": massif, "smooth": True, "width": 2 * MASSIF, "profile": "round"},
       {"op": "mountain_range", "points": crest, "smooth": True, "width": 2 * HALF, "profile": "sharp",
        "noise": {"amplitude": 100, "wavelength": 700, "octaves": 5, "type": "ridged", "orient_strength": 0.85}}]

# Spurs radiate from the summits (2-3 per flank, fanned over +-40 degrees about the normal, rooted
# within 350 m of the summit) and from some shoulders between a summit and a col (one, leaning
# away from the summit): the valleys between them head below the cols, as on a real range, and
# the flank is not a comb of parallel teeth. Lengths 0.55-1.25 r on the north flank, 0.8-1.9 r on
# the south, heights 20-30 % of the crest's relief at the root: comparable to the stroke's own
# flank there, so the flanks are ribbed, not a smooth sausage.
summit_arcs = []
for c in crest:
    k = min(range(len(line)), key=lambda k: math.hypot(line[k][0] - c[0], line[k][1] - c[1]))
    summit_arcs.append(arc[k])
cand = []  # (side, root arc, lean angle in radians towards increasing arc)
for side in (1, -1):
    for i in range(2, len(crest) - 2, 2):
        sa = summit_arcs[i]
        n = rng.choice((2, 3, 3))
        offs = sorted(rng.uniform(-350, 350) for _ in range(n))
        for j, o in enumerate(offs):
            fan = (j - (n - 1) / 2) / max(1, (n - 1) / 2) * rng.uniform(0.45, 0.7) + rng.uniform(-0.1, 0.1)
            cand.append((side, sa + o, fan))
        # A shoulder spur, half-way to each col, leaning away from the summit.
        for sgn, ca in ((-1, summit_arcs[i - 1]), (1, summit_arcs[i + 1])):
            if rng.random() < 0.55:
                cand.append((side, sa + sgn * rng.uniform(0.45, 0.6) * abs(ca - sa), sgn * rng.uniform(0.15, 0.4)))
spurs = {1: [], -1: []}
ridge_lines = []  # every spur and fork: the branches of the ravines keep off them
for side, s, fan in sorted(cand):
    if s < 1300 or s > arc[-1] - 1300:
        continue
    (x, y, z), (nx, ny) = at(s)
    if z < 650:
        continue
    nx, ny = side * nx, side * ny
    (xa, ya, _), _ = at(s - 50)
    (xb, yb, _), _ = at(s + 50)
    tl = math.hypot(xb - xa, yb - ya)
    tx, ty = (xb - xa) / tl, (yb - ya) / tl
    # The spur leaves the summit fanned and swings towards the fall line of the flank (the normal)
    # over 500-1100 m: spurs of one fan diverge below the summit, then run side by side (fans of
    # two summits that kept their lean converged below the col between them and dammed the valley).
    L = rng.uniform(0.55, 1.25) * HALF if side < 0 else rng.uniform(0.8, 1.9) * HALF
    h = rng.uniform(0.2, 0.3) * z
    ell = rng.uniform(500, 1100)
    drift = rng.uniform(-0.12, 0.12)  # a residual lean at the foot
    path, px, py, t = [(x, y)], x, y, 0.0
    while t < L:
        th = fan * math.exp(-t / ell) + drift * (1 - math.exp(-t / ell))
        px, py, t = px + 25 * (nx * math.cos(th) + tx * math.sin(th)), py + 25 * (ny * math.cos(th) + ty * math.sin(th)), t + 25
        path.append((px, py))
    ux, uy = (path[-1][0] - path[-9][0]) / 200, (path[-1][1] - path[-9][1]) / 200  # the direction at the foot
    wig, ph = net.uniform(0.04, 0.08) * L, net.uniform(0, 2 * math.pi)
    steps = ((0.04, 0.5), (0.2, net.uniform(0.8, 0.92)), (0.35, 1.0), (0.52, net.uniform(0.7, 0.92)),
             (0.7, net.uniform(0.48, 0.62)), (0.85, net.uniform(0.25, 0.38)), (1.0, 0.0))
    pts = []
    for f, hf in steps:
        k = min(len(path) - 2, int(f * (len(path) - 1)))
        qx, qy = path[k]
        dx, dy = path[k + 1][0] - qx, path[k + 1][1] - qy
        dl = math.hypot(dx, dy)
        off = wig * f * math.sin(2 * math.pi * 1.3 * f + ph)
        pts.append([r1(qx - off * dy / dl), r1(qy + off * dx / dl), r1(hf * h)])
    # Neighbours on a flank keep apart: a spur that comes within 450 m of the previous one of its
    # flank from a third of its length down (or crosses it) is left out.
    if any(min(dist_to(q, o["pts"]) for q in pts[2:]) < 450 for o in spurs[side]):
        continue
    width = round(min(1400, 750 + 0.18 * L))
    prof = net.choice(("sharp", "sharp", "v", "v", "round"))
    spurs[side].append({"pts": pts, "L": L, "h": h, "u": (ux, uy), "s": s, "z": z, "width": width, "profile": prof})
    ridge_lines.append(pts)
    ops.append({"op": "free_crest", "points": pts, "smooth": True, "width": width, "profile": prof})
# Second-order spurs: the long spurs fork at a third of their length, 25-40 degrees off, on the
# side where the fork's foot stays within 30 % of the way to the next spur (the ravine between them
# runs on the middle line and must keep its floor); the longest fork twice.
all_spurs = spurs[1] + spurs[-1]
for sp in all_spurs:
    pts, L, h, (ux, uy) = sp["pts"], sp["L"], sp["h"], sp["u"]
    if L <= 1.0 * HALF:
        continue
    others = [q["pts"] for q in all_spurs if q is not sp]
    for b, bl, hb in ((pts[2], rng.uniform(0.3, 0.45) * L, pts[2][2]), (pts[4], rng.uniform(0.25, 0.35) * L, pts[4][2])):
        if b is pts[4] and L < 1.35 * HALF:
            continue
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
            break
        else:
            continue
        # The fork leaves the spur at the spur's height there (hb): its own relief starts low (the
        # spur carries the junction) and rises as it leaves the spur's flank (a fork at full height
        # from the junction stacked on the spur: a knob at every fork).
        bp = [[r1(b[0] + f * bl * bx), r1(b[1] + f * bl * by), r1(hz * hb)] for f, hz in ((0.0, 0.2), (0.25, 0.8), (0.55, 0.6), (1.0, 0.0))]
        ops.append({"op": "free_crest", "points": bp, "smooth": True, "width": round(min(900, 500 + 0.25 * bl)), "profile": "v"})
        ridge_lines.append(bp)
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
    # About half the main ravine's depth where it joins (deeper, or kept to the axis, it ends in a pit).
    dt = net.uniform(0.42, 0.5) * dmain(a)
    # It deepens down to the main ravine's wall (0.6 rm from its axis) and fades out across the
    # wall, to nothing 0.1 rm from the axis: the main ravine's V wall falls towards its axis at
    # 12 u (1 - u)^2 dm / rm (u = distance / rm), and the branch's depth (at most 0.5 dm) fades
    # slower than that between u = 0.6 and 0.1, so its floor keeps falling into the main ravine.
    # (A branch deepest in its middle, a spoon, held water where it crossed the slope; one that
    # kept its depth to the axis dug a pit at the junction, where the main floor is flat across.)
    w = round(net.uniform(300, 420))
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
        gd = net.uniform(0.45, 0.55) * dt
        gw = round(net.uniform(200, 260))
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
    # The main ravine bends (it follows the midline between its spurs): stations are taken along
    # its polyline, each branch in the frame of the main ravine's segment there (on the chord, a
    # junction stood up to a few hundred metres off the axis, on the wall, and the branch's end
    # held water: a 63-71 m pit).
    seg = [math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(main, main[1:])]
    L = sum(seg)
    fr = [sum(seg[:i]) / L for i in range(len(main))]

    def frame(t):
        """The point at t of the main ravine's length, and its segment's unit direction there."""
        for i in range(len(seg)):
            if t <= fr[i + 1] or i == len(seg) - 1:
                u = (t - fr[i]) * L / seg[i]
                (ax, ay, _), (bx, by, _) = main[i], main[i + 1]
                return (ax + u * (bx - ax), ay + u * (by - ay)), ((bx - ax) / seg[i], (by - ay) / seg[i])

    def dmain(t):
        """The main ravine's depth at t of its length (linear between its vertices)."""
        for (f0, (_, _, z0)), (f1, (_, _, z1)) in zip(zip(fr, main), zip(fr[1:], main[1:])):
            if t <= f1:
                return z0 + (z1 - z0) * max(0.0, t - f0) / max(1e-9, f1 - f0)
        return main[-1][2]

    heads = {1: [], -1: []}
    # From a third of the way down: above that the main ravine is shallow and hemmed in by the
    # spurs' roots, and branches there ran into them (pits).
    a = net.uniform(0.2, 0.25)
    k = net.choice((-1, 1))
    while a < 0.8:  # (not where the main ravine shallows towards its exit)
        for side in (k, -k) if net.random() < 0.65 else (k,):
            (jx, jy), (tx, ty) = frame(a)
            branch(jx - a * L * tx, jy - a * L * ty, L, tx, ty, -ty, tx, a, side, dmain, rm, heads)
        a += net.uniform(0.05, 0.08)
        k = -k if net.random() < 0.8 else k
    for side, hs in heads.items():
        for (hx0, hy0, jx0, jy0, lat0, d0), (hx1, hy1, jx1, jy1, lat1, d1) in zip(hs, hs[1:]):
            # The sub-spur: from the spur's flank above the two heads down between them, ending
            # short of the main ravine's floor.
            tx, ty = 0.5 * (hx0 + hx1), 0.5 * (hy0 + hy1)
            fx, fy = 0.5 * (jx0 + jx1), 0.5 * (jy0 + jy1)
            tx, ty = tx + side * 0.15 * lat0 * ex, ty + side * 0.15 * lat0 * ey
            # (Its end at least half the main half-width plus its own half-width from the main
            # axis: a sub-spur whose foot reached a narrow main ravine's floor dammed it, pits of
            # 12-130 m.)
            hz = net.uniform(0.5, 0.7) * max(d0, d1)
            sw = round(net.uniform(320, 450))
            fo = max(0.3 * lat1, 0.5 * rm + 0.5 * sw)
            fx, fy = fx + side * fo * ex, fy + side * fo * ey
            ops.append({"op": "free_crest", "points": [[r1(tx), r1(ty), r1(0.5 * hz)], [r1(0.55 * tx + 0.45 * fx), r1(0.55 * ty + 0.45 * fy), r1(hz)], [r1(fx), r1(fy), 0.0]],
                        "smooth": True, "width": sw, "profile": net.choice(("sharp", "round"))})


# A main ravine on the midline between each pair of neighbouring spurs of a flank (points at the
# same distance down either spur, averaged): it heads where the two spurs are 500 m apart (below
# the col between two summits' fans, or between two spurs of one fan a few hundred metres below
# their summit), runs as far as the shorter spur and a little past, onto the massif's lower flank
# where the ground still falls (a ravine ending on the plain leaves a hollow), and is as wide as
# the gap allows (a ravine wider than the gap between its spurs was filled by their flanks).
mains = []


def smooth(t):
    """Smootherstep on [0, 1] (the strokes' taper)."""
    t = max(0.0, min(1.0, t))
    return t * t * t * (t * (6 * t - 15) + 10)


def spur_at(sp, q):
    """A spur's relief at q: its profile at q's distance from its line times its height there
    (linear between its vertices; no crest rounding or taper)."""
    best, z = 1e30, 0.0
    for a, b in zip(sp["pts"], sp["pts"][1:]):
        dx, dy = b[0] - a[0], b[1] - a[1]
        t = max(0.0, min(1.0, ((q[0] - a[0]) * dx + (q[1] - a[1]) * dy) / (dx * dx + dy * dy)))
        d = math.hypot(q[0] - a[0] - t * dx, q[1] - a[1] - t * dy)
        if d < best:
            best, z = d, a[2] + t * (b[2] - a[2])
    u = min(1.0, best / (0.5 * sp["width"]))
    return z * {"sharp": (1 - u) ** 3, "v": (1 - u) ** 3 * (1 + 3 * u), "round": max(0.0, 1 - u * u) ** 3}[sp["profile"]]


def ground(q, beside=()):
    """The ground before the ravines at q: the massif and the stroke's sharp flank at q's distance
    from the crest line, and the spurs `beside` (a ravine between two spurs runs on their flanks
    where they stand close, and the spurs rise from their roots to their first knob: a ground
    without them fell faster than the terrain below the heads, and the floor held water)."""
    k = min(range(0, len(line), 4), key=lambda k: math.hypot(line[k][0] - q[0], line[k][1] - q[1]))
    d = dist_to(q, line[max(0, k - 8):k + 9])
    zc = line[k][2]
    dm = dist_to((q[0], q[1] - SHIFT), line[max(0, k - 8):k + 9])
    # (Both strokes taper over their half-width of arc at either end: near the range's ends the
    # ground falls along the range as well as across it, and a ravine depth that ignored it left
    # 20-26 m hollows in its floor.)
    end = min(arc[k], arc[-1] - arc[k])
    return sum(spur_at(sp, q) for sp in beside) + (260 + 0.05 * zc) * smooth(end / MASSIF) * max(0.0, 1 - (dm / MASSIF) ** 2) ** 3 + zc * smooth(end / HALF) * max(0.0, 1 - d / HALF) ** 3


for side in (1, -1):
    sp = spurs[side]
    for A, B in zip(sp, sp[1:]):
        LA, LB = length(A["pts"]), length(B["pts"])
        lo = min(LA, LB)

        def mid(t):
            a, b = along(A["pts"], t), along(B["pts"], t)
            return ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2), math.hypot(a[0] - b[0], a[1] - b[1])

        th = next((t for t in range(200, int(lo), 50) if mid(t)[1] >= 500 and dist_to(mid(t)[0], line) >= 300), None)
        if th is None:
            continue
        # (On the massif's upper three quarters: further out it flattens, and a ravine's exit there
        # held water.)
        te = min(lo, 0.6 * MASSIF + side * SHIFT) * rng.uniform(0.85, 1.0)
        if te - th < 800:
            continue
        # Its depth follows the ground it cuts (the massif and the stroke's flank, which falls
        # steeply under the crest and gently on the massif; a depth drawn from the crest's relief
        # alone ran the floor below the massif's foot at mid-flank: a pit 100-180 m deep along the
        # ravine's lower half).
        exx, exy = mid(te)[0][0] + 700 * (mid(te)[0][0] - mid(te - 50)[0][0]) / 50, mid(te)[0][1] + 700 * (mid(te)[0][1] - mid(te - 50)[0][1]) / 50
        ge = ground((exx, exy), (A, B))
        zr = min(A["z"], B["z"])
        (mx, my), gap = mid(th + 0.5 * (te - th))
        width = round(max(600, min(1100, 0.8 * gap)))
        # (And at most 0.45 of its width: deeper, a narrow ravine under a summit was a slot whose
        # floor the spurs' and sub-spurs' feet dammed.)
        # The floor is built from the exit's end upstream: 0.55 of the way from the exit's end up
        # to the modelled ground (a depth of at most 0.45 of the ground's height over the exit's
        # end), but falling by at least 9 % and 0.35 of the ground's own fall, never above the
        # ground. The depth is at most 0.34 of the crest's relief, 0.45 of the width and 0.14 of
        # the crest's relief at the head, taken in the same pass (capping the depths afterwards
        # raised floors below lower ones upstream: 20 m hollows). Depths at seven points. (A depth
        # as a share of the crest's relief, or of a ground model without the strokes' tapers and
        # the spurs, left 10-26 m hollows in the floors, which the branches joined.)
        (ex0, ey0), _ = mid(te)
        (ex1, ey1), _ = mid(te - 50)
        ux, uy = (ex0 - ex1) / 50, (ey0 - ey1) / 50
        n_s = int((te - th + 700) / 50)
        floor = [0.0] * (n_s + 1)
        gz = [0.0] * (n_s + 1)
        for j in range(n_s, -1, -1):
            t = th + j * 50
            q = mid(t)[0] if t <= te else (ex0 + (t - te) * ux, ey0 + (t - te) * uy)
            gz[j] = ground(q, (A, B))
            cap = min(0.45 * max(0.0, gz[j] - ge), 0.34 * zr, 0.45 * width, 0.14 * zr if j == 0 else 1e9)
            fz = gz[j] - cap
            if j < n_s:
                fz = max(fz, floor[j + 1] + max(0.09, 0.35 * (gz[j] - gz[j + 1]) / 50) * 50)
            floor[j] = min(fz, gz[j])
        pts = []
        for i in range(7):
            f = i / 6
            j = min(n_s, round(f * (te - th) / 50))
            (qx, qy), _ = mid(th + f * (te - th))
            dq = gz[j] - floor[j]
            pts.append([r1(qx), r1(qy), r1(dq)])
        ops.append({"op": "ravine", "points": pts, "smooth": True, "width": width, "profile": "v", "exit": 700,
                    "taper": round(0.25 * width)})
        mains.append((side, pts, width))
        tributaries(pts, 0.5 * width)
# Foothills: the spurs that reach the massif's lower flank run on past it as low hogback ridges
# (120-200 m, sharp, 1.2-1.5 km wide) that start on the spur 700 m above its foot and swing 0-8
# degrees off it (swung 5-20 degrees, one closed the mouth of the valley beside it: a 90 m pit),
# so the foothills hang off the range as the lower ends of its spurs, not as blobs
# (or, detached from the spur, dashes) on the plain.
hogs = []
for side in (1, -1):
    for sp in spurs[side]:
        pts, (ux, uy) = sp["pts"], sp["u"]
        if dist_to(pts[-1], line) < 0.6 * MASSIF + side * SHIFT:
            continue
        ul = math.hypot(ux, uy)
        ux, uy = ux / ul, uy / ul
        sw = math.radians(rng.uniform(0, 8)) * rng.choice((-1, 1))
        vx, vy = ux * math.cos(sw) - uy * math.sin(sw), ux * math.sin(sw) + uy * math.cos(sw)
        L = rng.uniform(1800, 2800)
        h = rng.uniform(120, 200)
        b = (pts[-1][0] - 700 * ux, pts[-1][1] - 700 * uy)
        # It rises from nothing on the spur (a hogback at full height where the spur's last
        # shoulder stands doubled it there: a knob at every spur's end).
        # Bowed and wandering, not ruled: a lateral offset of 150-300 m (a sine arch plus a
        # shorter wave) from its own generator, so the layout's other draws stay as they were (a
        # straight 2.6 km hogback read as a drawn line in hillshade).
        wr = random.Random(7919 * len(hogs) + (side > 0))
        bow, wig, ph = wr.uniform(150, 300) * wr.choice((-1, 1)), wr.uniform(40, 90), wr.uniform(0, 2 * math.pi)
        def lat(f):
            return bow * math.sin(math.pi * f) + wig * math.sin(3 * math.pi * f + ph) * math.sin(math.pi * f)
        hp = [[r1(b[0] + f * L * vx - lat(f) * vy), r1(b[1] + f * L * vy + lat(f) * vx), r1(hz * h)]
              for f, hz in ((0.0, 0.0), (0.15, 0.55), (0.3, 0.9), (0.5, 1.0), (0.62, 0.85), (0.75, 0.6), (0.88, 0.3), (1.0, 0.0))]
        # Apart from the other foothills and spurs (two converging ones closed the valley between
        # them below a ravine's exit: a 94 m pit).
        if any(dist_to(q, o) < 1000 for q in hp[1:] for o in hogs + [s["pts"] for s in spurs[side] if s is not sp]):
            continue
        hogs.append(hp)
        ops.append({"op": "free_crest", "comment": "hogback foothill", "points": hp, "smooth": True,
                    "width": round(rng.uniform(1200, 1500)), "profile": "sharp"})
# Drainage (stream-power incision): gullies and branch valleys carved along the terrain's
# own flow over the whole map after the landforms. n = 2 keeps it on the steep flanks (depth 250 m x
# (A / 1000 cells)^0.5 x S^2): with n = 1 the big ravines' gentle floors got straight D8 trenches
# running out onto the plain; max_depth 60 m caps the cut on the steepest walls (S^2 up to ~9).
# Channels from 200 cells (45000 m^2), 75 m half-width at 1000 cells, smoothed 3 times: the
# defaults (100 cells, 30 m, once) drew 1-2 cell scratches with crisp edges.
ops.append({"op": "drainage", "comment": "stream-power gullies", "depth": 250, "n": 2, "max_depth": 60,
            "threshold": 45000, "channel_width": 75, "smooth": 3})
ops.append({"op": "river", "points": [[-100, 14400, 140], [3500, 13300, 136], [7500, 14500, 130], [11000, 13600, 125],
                                      [15500, 14200, 120]], "smooth": True, "width": 1800, "floor": 40, "bank_height": 40})
# The plain rolls: broad swells (60 m, 3.2 km) and a finer fBm (12 m, 1.2 km), on the plain only:
# a region that is the whole map less the massif's upper part (a hole 2.4 km north and 3.5 km
# south of the crest, cut through a slit), fading in over 1.5 km. Over the range their slopes
# (up to ~12 % and 6 %) outdid the floors of the main ravines on the massif's gentle lower flank
# and left 10-26 m hollows in them.
hole = []
for side, off in ((1, 3500.0), (-1, 2400.0)):
    ring = []
    for s in range(0, int(arc[-1]) + 1, 500):
        (x, y, _), (nx, ny) = at(min(s, arc[-1] - 1))
        ring.append([r1(x + side * off * nx), r1(y + side * off * ny)])
    hole += ring if side == 1 else ring[::-1]
outer = [[-3000, -3000], [18360, -3000], [18360, 18360], [-3000, 18360], [-3000, -3000]]
plain = outer + hole[::-1] + [hole[-1], [-3000, -3000]]
ops.append({"op": "noise", "comment": "rolling relief on the plain", "polygon": plain, "falloff": 1500, "amplitude": 60, "wavelength": 3200,
            "octaves": 4, "seed": 8000073})
ops.append({"op": "noise", "polygon": plain, "falloff": 1500, "amplitude": 12, "wavelength": 1200, "octaves": 4, "seed": 8000074})
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
ops = [{k: v for k, v in o.items() if v is not None} for o in ops]
doc = {"description": "A mountain range (paper figures 1, 8 and 11), written by scripts/gen-mountain-range.py: a massif (round free_crest 7.2 km wide, 260-370 m, 700 m south of the crest: an asymmetric range, steeper north flank) under one gently bending smoothed mountain_range stroke 4 km wide through summits (1150-1800 m over the massif) and cols at ~0.8 of the lower summit beside them, ridged noise (100 m, 700 m) dragged across it; spurs (free_crest, 20-30 % of the crest's height) radiating from the summits (2-3 per flank fanned over +-40 degrees, swinging to the fall line over 0.5-1.1 km) and from shoulders, 1.1-2.5 km long on the north flank and 1.6-3.8 km on the south, wandering and stepping down in knobs; the long ones fork (second-order spurs, once or twice); a main ravine on the midline between each pair of neighbouring spurs of a flank, as wide as the gap allows (600-1100 m), its floor falling evenly from its head to its exit's end (at most 0.45 of the modelled ground's height over the exit's end, 0.34 of the crest's relief and 0.45 of its width), with a dendritic network: second-order ravines (300-420 m wide, 0.42-0.5 of the main depth where they join), third-order gullies, sub-spurs between branches; the spurs that reach the massif's lower flank run on as hogback foothill ridges (sharp, 120-200 m); ridged noise over the range and foothills (15 m, 650 m), rolling fBm on the plain only (60 m, 3.2 km); a river meandering across the plain; gullies and branch valleys carved by a stream-power drainage op (depth 250 m x (A / 1000 cells)^0.5 x S^2, at most 60 m, channels from 200 cells, 75 m half-width at 1000 cells) after the landforms.",
       "base": "flat:1025x1025@15", "units": "m", "seed": 8, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
