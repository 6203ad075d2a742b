#!/usr/bin/env python3
# Writes data/examples/canyon.json (issue 12 gallery, paper figure 1): a canyon cut into an 800 m
# plateau whose two cliff rims wander independently (the canyon widens and narrows, promontories
# and bays), a river meandering down its floor, wandering side canyons with amphitheatre heads that
# widen and deepen towards the main canyon, some with tributaries of their own, cut through the rims
# and graded down the wall to the river, layered rock (strata) in every steep wall, fBm,
# oriented gullies on the walls.
# Usage: python3 scripts/gen-canyon.py OUT.json
import json, math, os, random, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from polyline import arc_lengths  # noqa: E402

rng = random.Random(7)  # fixed: the script writes the same file every time
EXT = 5120.0  # the map's extent (1025 cells of 5 m)
R_CLIFF = 450.0  # the cliffs' half-width: the wall's foot is this far from the rim, into the canyon
TOP = 800.0  # the plateau (the west rim; the east rim 10 m higher)
DEPTH = TOP - 130.0  # from the rim to the river at its head


def centre(y):
    """The canyon's axis: NNW -> SSE with a long swing."""
    return 1700 + 0.27 * y + 200 * math.sin(2 * math.pi * y / 3400 + 0.4)


# Each rim's distance from the axis, with its own wobbles: the canyon is 1.47-1.96 km wide at the top.
# The rims' radius of curvature stays >= 690 m, 1.5 cliff radii: at a bend of ~420 m (the former
# draft) the cliff's profile drew a hairline from the rim across the plateau with a pit at its end.
def west(y):
    return centre(y) - (860 + 170 * math.sin(2 * math.pi * y / 2600 + 6.0) + 45 * math.sin(2 * math.pi * y / 1500 + 2.0))


def east(y):
    return centre(y) + (820 + 190 * math.sin(2 * math.pi * y / 2900 + 2.4) + 40 * math.sin(2 * math.pi * y / 1400 + 0.3))


def rim(f, ys):
    return [[round(f(y), 1), round(y, 1)] for y in ys]


ys = [-990 + k * 445 for k in range(17)]  # -990 .. 6130: the rims run on 1 km past both edges
ops = [
    {"op": "noise", "amplitude": 8, "wavelength": 600, "octaves": 5},
    {"op": "noise", "comment": "broad swells on the plateau (the fBm alone read as one uniform texture)", "amplitude": 22,
     "wavelength": 2600, "octaves": 2, "seed": 3},
    {"op": "cliff", "comment": "west rim: the canyon lies to the east, the left of a southward stroke", "points": rim(west, ys),
     "smooth": True, "elevation": TOP, "height": 330, "width": 2 * R_CLIFF, "side": "left", "face": 0.45, "scree": 0.3},
    {"op": "cliff", "comment": "east rim", "points": rim(east, ys), "smooth": True, "elevation": TOP + 10, "height": 340,
     "width": 2 * R_CLIFF, "side": "right", "face": 0.45, "scree": 0.3},
]
# The river: on the floor between the two walls' feet, meandering within it.
river = []
for k, y in [(k, -50 + k * 580) for k in range(-1, 11)]:  # (k = -1 and 10: past the map's edges)
    lo, hi = west(y) + R_CLIFF + 230, east(y) - R_CLIFF - 230
    x = 0.5 * (lo + hi) + 0.5 * (hi - lo) * 0.6 * math.sin(1.3 * k + 0.5) if hi > lo else 0.5 * (lo + hi)
    river.append([round(x, 1), round(y, 1), round(130 - 60 * y / 5170, 1)])
def river_nearest(px, py):
    """The nearest point of the river's polyline to (px, py) and the river's elevation there."""
    best = None
    for (ax, ay, az), (bx, by, bz) in zip(river, river[1:]):
        ux, uy = bx - ax, by - ay
        t = max(0.0, min(1.0, ((px - ax) * ux + (py - ay) * uy) / (ux * ux + uy * uy)))
        qx, qy = ax + t * ux, ay + t * uy
        d = math.hypot(px - qx, py - qy)
        if best is None or d < best[0]:
            best = (d, qx, qy, az + t * (bz - az))
    return best[1:]


# Side canyons (canyon-country tributaries, Grand Canyon / Canyonlands): each wanders back from the
# rim into the plateau and ends in an amphitheatre head (a ravine's round cap: no taper at its head,
# so the head is a half-disc alcove, not a box cut square across the stroke). It is built of nested
# layers along one axis (the same dense spline, so the layers share it): an inner gorge from the
# head to the river, a wider layer starting a quarter to a half of the way down and, on the longer
# ones, a third still wider from about two thirds of the way: each outer layer's depth grows from 0
# (smootherstep over 300-500 m), so the canyon widens and deepens towards the main canyon without a
# step in its floor, and the layers' walls stand at different distances (a broad upper bench). The
# longer side canyons carry tributaries of their own, graded to their floor: a branch's depth is
# what its graded floor needs below the plateau minus what the side canyon's layers already cut
# there (the profiles' formula evaluated here), so it fades out across the side canyon's wall and
# joins its floor without a pit. The floors are graded to the main river along one concave curve
# (z = z_river + (z_head - z_river) (1 - s/L)^1.3, s the arc from the head); from 60 % of the way to
# the rim a tributary stream (a `river`, after the ravines) pins it down the main wall to the main
# river, as a ravine's depth alone could not follow the wall's benches (its floor rose 20-45 m on the
# wall). (The former side canyons were single flat ravines 560-680 m wide, straight and parallel,
# with box heads cut square 150 m deep: rectangular trenches.)
STEP = 40.0  # the dense axis' spacing (m)
# The main wall's drop below the rim (m) every 50 m out from the rim, measured on this script's
# terrain without the side canyons (1025^2; the same within 10 m at y = 533 and 2450 m on the
# west wall); it goes on falling ~0.25 past 600 m.
WALL_DROP = [0, 35, 110, 220, 290, 343, 396, 442, 474, 502, 522, 540, 553]


def wall_drop(d):
    k = d / 50.0
    if k >= len(WALL_DROP) - 1:
        return WALL_DROP[-1] + 0.25 * (d - 50.0 * (len(WALL_DROP) - 1))
    i = int(k)
    return WALL_DROP[i] + (WALL_DROP[i + 1] - WALL_DROP[i]) * (k - i)


def catmull_rom(pts, step):
    """Centripetal Catmull-Rom through pts (mirrored end points), pieces <= step: the curve of
    terracl's `smooth` (host/src/tensor.cpp), so the layers given these dense points share one axis."""
    n = len(pts)

    def at(i):
        if i < 0:
            return (2 * pts[0][0] - pts[1][0], 2 * pts[0][1] - pts[1][1])
        if i >= n:
            return (2 * pts[-1][0] - pts[-2][0], 2 * pts[-1][1] - pts[-2][1])
        return pts[i]

    def kn(a, b):
        return max(math.sqrt(math.hypot(b[0] - a[0], b[1] - a[1])), 1e-9)

    out = []
    for i in range(n - 1):
        p0, p1, p2, p3 = at(i - 1), at(i), at(i + 1), at(i + 2)
        t0, t1 = 0.0, kn(p0, p1)
        t2 = t1 + kn(p1, p2)
        t3 = t2 + kn(p2, p3)

        def ev(t, c):
            def lerp(a, b, ta, tb):
                return (a * (tb - t) + b * (t - ta)) / (tb - ta) if tb > ta else a
            a1, a2, a3 = lerp(p0[c], p1[c], t0, t1), lerp(p1[c], p2[c], t1, t2), lerp(p2[c], p3[c], t2, t3)
            return lerp(lerp(a1, a2, t0, t2), lerp(a2, a3, t1, t3), t1, t2)

        m = max(1, math.ceil(math.hypot(p2[0] - p1[0], p2[1] - p1[1]) / step))
        out += [(ev(t1 + (t2 - t1) * k / m, 0), ev(t1 + (t2 - t1) * k / m, 1)) for k in range(m)]
    out.append(tuple(pts[-1]))
    return out


def smoother(t):
    t = min(max(t, 0.0), 1.0)
    return t * t * t * (t * (6 * t - 15) + 10)


def u_profile(d, r, floor):
    """The ravine's `u` profile with a floor (docs/authoring.md): (1 - u^4)^2, u = (d - f)/(r - f)."""
    f = 0.5 * floor
    u = min(max((d - f) / (r - f), 0.0), 1.0)
    return (1 - u ** 4) ** 2


def nearest(line, amp, px, py):
    """Distance to a polyline and its amplitude (linear) at the closest point."""
    best = (1e30, 0.0)
    for (ax, ay), (bx, by), za, zb in zip(line, line[1:], amp, amp[1:]):
        ux, uy = bx - ax, by - ay
        l2 = ux * ux + uy * uy
        t = max(0.0, min(1.0, ((px - ax) * ux + (py - ay) * uy) / l2)) if l2 > 0 else 0.0
        d = math.hypot(px - ax - t * ux, py - ay - t * uy)
        if d < best[0]:
            best = (d, za + t * (zb - za))
    return best


side_ops, tributaries = [], []
# (side, rim crossing y, length on the plateau, tilt from the rim's normal (deg), branches)
# (Every side canyon's operations say so in their comments, "side canyon N: inner gorge ...",
# "... outer layer K", "... tributary": tests/test_edit_examples.cpp reads them.)
for nsc, (side, y0, back, ang, branches) in enumerate((
        (-1, 700, 1900, 12, [(0.75, 550, 1700)]), (-1, 2450, 950, -8, [(0.8, 750, 3300)]),
        (-1, 3950, 560, 5, []), (1, 1500, 2100, -10, [(0.7, 4300, 2200)]), (1, 3250, 1150, 14, [(0.75, 4100, 2550)]),
        (1, 4500, 620, -4, []))):
    wf = (1.0, 0.72, 0.8, 1.08, 0.86, 0.7)[nsc]  # width factor: some side canyons narrow, some broad
    top = TOP if side < 0 else TOP + 10
    rim_f = west if side < 0 else east
    rx = rim_f(y0)
    tx, ty = (rim_f(y0 + 1) - rim_f(y0 - 1)) / 2, 1.0
    tl = math.hypot(tx, ty)
    nx, ny = side * ty / tl, -side * tx / tl
    a = math.radians(ang)
    nx, ny = nx * math.cos(a) - ny * math.sin(a), nx * math.sin(a) + ny * math.cos(a)
    while not (250 < rx + back * nx < EXT - 250 and 250 < y0 + back * ny < EXT - 250):
        back *= 0.9
    # The axis wanders: a sine across it (one to two bends over its length), nothing at the rim.
    amp_w = rng.uniform(0.08, 0.13) * back * rng.choice((-1, 1))
    lam, ph = rng.uniform(0.7, 1.2) * back, rng.uniform(0, 2 * math.pi)
    nctl = max(4, round(back / 300))
    ctl = []
    for k in range(nctl + 1):
        d = back * (1 - k / nctl)
        off = amp_w * (math.sin(2 * math.pi * d / lam + ph) - math.sin(ph)) * smoother(d / 400)
        ctl.append((rx + d * nx - off * ny, y0 + d * ny + off * nx))
    ctl += [(rx - 0.45 * R_CLIFF * nx, y0 - 0.45 * R_CLIFF * ny), (rx - 0.85 * R_CLIFF * nx, y0 - 0.85 * R_CLIFF * ny)]
    # The stream goes on straight down the wall to the river (to the river's nearest point it
    # could turn at the wall's foot, where the layers now run on to).
    ex, ey = ctl[-1][0] - ctl[-2][0], ctl[-1][1] - ctl[-2][1]
    el = math.hypot(ex, ey)
    t = 0.0
    while t < 1500 and math.hypot(ctl[-1][0] + t * ex / el - river_nearest(ctl[-1][0] + t * ex / el, ctl[-1][1] + t * ey / el)[0],
                                  ctl[-1][1] + t * ey / el - river_nearest(ctl[-1][0] + t * ex / el, ctl[-1][1] + t * ey / el)[1]) > 40:
        t += 20.0
    jx, jy, jz = river_nearest(ctl[-1][0] + t * ex / el, ctl[-1][1] + t * ey / el)
    ctl.append((jx, jy))
    axis = catmull_rom(ctl, STEP)
    s = arc_lengths(axis)
    i_rim = min(range(len(axis)), key=lambda i: math.hypot(axis[i][0] - rx, axis[i][1] - y0))
    i_w1 = min(range(len(axis)), key=lambda i: math.hypot(axis[i][0] - ctl[-3][0], axis[i][1] - ctl[-3][1]))
    i_w2 = min(range(len(axis)), key=lambda i: math.hypot(axis[i][0] - ctl[-2][0], axis[i][1] - ctl[-2][1]))
    z_head, z_end = top - rng.uniform(130, 170), jz + 2
    L = s[-1]

    def grade(sa):
        return z_end + (z_head - z_end) * (1 - sa / L) ** 1.3

    # Depth below the plateau: the graded floor's on the plateau; on the main wall (where the
    # terrain itself falls) a quarter of what the graded floor needs below the wall's own profile
    # (WALL_DROP, at least 8 m) and three quarters of the former fixed fade (20 % at 0.45 R, 30 m at
    # 0.85 R, 8 m at the river). The fixed fade alone fell faster than the wall: beside the stream,
    # which pins only its bed, the mouths' floors rose towards the main canyon, closed hollows
    # 19-39 m deep at the wall's foot; the wall's profile alone left 5-19 m there, but the deeper
    # layers ran into the main river's banks by the narrowest part of the floor (an 11 m pit in
    # its thalweg). The layers run down the wall until the depth is 8 m.
    BLEND = 0.25
    D_rim = top - grade(s[i_rim])

    def depth(sa):
        if sa <= s[i_rim]:
            return top - grade(sa)
        wall = max(8.0, min(D_rim, top - wall_drop(sa - s[i_rim]) - grade(sa)))
        knots = [(s[i_rim], D_rim), (s[i_w1], 0.2 * D_rim), (s[i_w2], 30.0), (L, 8.0)]
        fixed = 8.0
        for (sa0, d0), (sa1, d1) in zip(knots, knots[1:]):
            if sa0 <= sa <= sa1:
                fixed = d0 + (d1 - d0) * (sa - sa0) / (sa1 - sa0)
        return BLEND * wall + (1 - BLEND) * fixed

    # The inner gorge takes the first G metres of the depth (its walls, ~2.4 G / (r - f) at their
    # steepest, below 2 like the main canyon's face: steeper walls made the strata's risers
    # one-cell steps that the perspective view drew as fine striations); the rest goes to the outer layers, so the canyon
    # widens as it deepens: layer 1 from the head (its depth growing from 0 where the floor falls
    # below G), layer 2 (longer side canyons) ramping in to a share of it further down.
    G = rng.uniform(140, 170) * wf
    w0 = round(2 * 1.45 * G / 0.7)  # r - f = 1.45 G (f = 0.3 r): walls ~1.7 at their steepest
    layers = [(w0, None), (round(w0 * rng.uniform(1.5, 1.7)), rng.uniform(0.25, 0.4))]
    if back > 900:
        layers.append((round(w0 * rng.uniform(2.1, 2.3)), rng.uniform(0.6, 0.7)))
    q2 = rng.uniform(0.4, 0.5)
    ramp1, ramp2 = rng.uniform(400, 600), rng.uniform(300, 500)
    # (On the short side canyons the first outer layer ramps in over at most half the way to the rim:
    # over 400-600 m it had barely begun where they cross it.)
    ramp1 = min(ramp1, 0.5 * s[i_rim])
    trunk = []  # (points, amplitudes, width, floor) per layer, for the branches' depths
    for li, (width, h) in enumerate(layers):
        amps = []
        for i, sa in enumerate(s):
            D = depth(sa)
            rest = D - min(D, G * min(1.0, D / D_rim) if sa > s[i_rim] else G)
            share1 = smoother((sa - layers[1][1] * s[i_rim]) / ramp1)
            share2 = q2 * smoother((sa - layers[2][1] * s[i_rim]) / ramp2) if len(layers) > 2 else 0.0
            # (Upstream of layer 1 the gorge takes the whole depth: the side canyon is narrow there.)
            l1, l2 = rest * share1 * (1 - share2), rest * share1 * share2
            if li == 0:
                amps.append(D - l1 - l2)
            elif li == 1:
                amps.append(l1 if sa >= h * s[i_rim] else None)
            else:
                amps.append(l2 if sa >= h * s[i_rim] else None)
        # Smoothed along the arc (a Gaussian of 120 m): the depth peaks where the axis crosses the
        # rim and falls fast down the wall; a kink there (or where the gorge's share saturates)
        # drew a straight crease across the whole side canyon through that vertex (the profile's
        # gradient along the stroke jumps there).
        # (An outer layer's depth counts as 0 before its start: smoothed from its start only, the
        # layers' sum rose 7-12 m there, a sill across the floor.)
        sm = []
        for i, sa in enumerate(s):
            if amps[i] is None:
                sm.append(None)
                continue
            num = den = 0.0
            for j, sb in enumerate(s):
                if abs(sb - sa) < 360:
                    w = math.exp(-0.5 * ((sb - sa) / 120) ** 2)
                    num, den = num + w * (amps[j] or 0.0), den + w
            sm.append(num / den)
        amps = sm
        # Every layer runs down the main wall until the depth is 8 m (round 2 ended the gorge at
        # 0.85 R and the outer layers at 0.45 R, where they still cut 100 m: hollows at the wall's
        # foot), exiting straight along its axis. (Round 2's note: run on to the river's junction
        # past a turn of the axis, a layer's nearest point jumped between its arm on the plateau
        # and its arm on the floor across the bisector of the turn, a straight seam 0.5-1 km long
        # beside the mouth; the stream now runs straight on to the river, so there is no turn.)
        last = next((i for i in range(i_rim, len(s)) if depth(s[i]) <= 8.0), len(s) - 1)
        # The outer layers follow the axis smoothed (a Gaussian of 0.3 times their width along the
        # arc): the gorge meanders within them. On the gorge's own axis, bends tighter than a wide
        # layer's half-width folded its profile along the bends' bisectors (straight creases across
        # the side canyon).
        line = axis
        if li:
            line = []
            for sa in s:
                wsum = xs = ys = 0.0
                for (px, py), sb in zip(axis, s):
                    w = math.exp(-0.5 * ((sb - sa) / (0.3 * width)) ** 2)
                    wsum, xs, ys = wsum + w, xs + w * px, ys + w * py
                line.append((xs / wsum, ys / wsum))
            # Benches that pinch out and widen: the layer's axis swings across the gorge's (a sine
            # of 1.3-1.8 km, 0.75 of the half-width they differ by), so the bench between the
            # gorge's rim and the layer's is wide on one wall where it narrows on the other (on
            # one axis they ran as concentric offsets of the planform, ribbons of one width).
            lam_b, ph_b = rng.uniform(1300, 1800), rng.uniform(0, 2 * math.pi)
            a_b = min(0.75 * 0.5 * (width - w0), (lam_b / (2 * math.pi)) ** 2 / (0.4 * width))
            sw = []
            for i, (p, sa) in enumerate(zip(line, s)):
                q0, q1 = line[max(i - 1, 0)], line[min(i + 1, len(line) - 1)]
                tx, ty = q1[0] - q0[0], q1[1] - q0[1]
                tl = math.hypot(tx, ty)
                # (Faded out over the last 500 m before the rim: swung off the gorge at the mouth,
                # a layer's end dug a hollow 40-120 m deep beside it at the foot of the main wall.)
                off = a_b * math.sin(2 * math.pi * sa / lam_b + ph_b) * (1 - smoother((sa - s[i_rim] + 350) / 300))
                sw.append((p[0] - off * ty / tl, p[1] + off * tx / tl))
            line = sw
        head_op = None
        if li == 0:
            # The head is narrower than the canyon below it (an alcove, not a balloon): a narrow
            # ravine (0.68 of the gorge's width, round cap) takes the gorge's depth at the head and
            # hands it over to the gorge (whose depth grows from 0 at the head) from 10 % to
            # 10 + 35 % of the way to the rim.
            wh = round(0.68 * width)
            hs = [1 - smoother((sa - 0.1 * s[i_rim]) / (0.35 * s[i_rim])) for sa in s]
            nh = next(i for i, v in enumerate(hs) if v < 0.005) + 1
            head_op = {"op": "ravine", "comment": f"side canyon {nsc}: head alcove",
                       "points": [[round(p[0], 1), round(p[1], 1), round(z * v, 1)] for p, z, v in list(zip(line, amps, hs))[:nh]],
                       "smooth": True, "width": wh, "profile": "u", "floor": round(0.3 * wh), "taper": 0, "exit": 0}
            amps = [z * (1 - v) for z, v in zip(amps, hs)]
        pts = [(p, z) for p, z in list(zip(line, amps))[:last + 1] if z is not None]
        floor = round(0.3 * width)
        trunk.append(([p for p, _ in pts], [z for _, z in pts], width, floor))
        side_ops.append({"op": "ravine", "comment": f"side canyon {nsc}: " + ("inner gorge, amphitheatre head" if li == 0 else f"outer layer {li}"),
                         "points": [[round(p[0], 1), round(p[1], 1), round(z, 1)] for p, z in pts], "smooth": True,
                         "width": width, "profile": "u", "floor": floor, "taper": 0, "exit": 100 if li == 0 else round(0.8 * R_CLIFF)})
        if head_op:
            side_ops.append(head_op)
            # A shallow wash on the plateau that feeds the head (canyon heads sit at the end of a
            # plateau drainage: a pour-off notch in the alcove's lip): 0.6-1 km back along the
            # head's direction, bending, 14-22 m deep at the lip, a round swale 380 m wide (240 m and v: scratches).
            ux, uy = axis[0][0] - axis[3][0], axis[0][1] - axis[3][1]
            ul = math.hypot(ux, uy)
            ux, uy = ux / ul, uy / ul
            wr = random.Random(40 + nsc)  # its own draws: the side canyons keep theirs
            lw, bw, dw = wr.uniform(600, 1000), wr.uniform(-0.2, 0.2), wr.uniform(14, 22)
            wpts = []
            for k in range(6, -1, -1):
                t = k / 6
                d = -0.25 * wh + t * (lw + 0.25 * wh)
                px = axis[0][0] + d * ux - bw * lw * t * t * uy
                py = axis[0][1] + d * uy + bw * lw * t * t * ux
                if 30 < px < EXT - 30 and 30 < py < EXT - 30:
                    wpts.append([round(px, 1), round(py, 1), round(dw * smoother(1 - t + 0.15), 1)])
            side_ops.append({"op": "ravine", "comment": f"side canyon {nsc}: wash above the head", "points": wpts, "smooth": True,
                             "width": 380, "profile": "round", "taper": 0, "exit": 0})

    def trunk_depth(px, py, first=0):
        tot = 0.0
        for line, amp, width, floor in trunk[first:]:
            d, a = nearest(line, amp, px, py)
            if d < 0.5 * width:
                tot += a * u_profile(d, 0.5 * width, floor)
        return tot

    # Tributaries of its own, placed by hand where the plateau has room (between the side canyons,
    # on the map): a junction at a share of the way from the head to the rim and a head.
    for sj_f, hx, hy in branches:
        sj = sj_f * s[i_rim]
        ij = min(range(len(axis)), key=lambda i: abs(s[i] - sj))
        jxb, jyb = axis[ij]
        lb = math.hypot(hx - jxb, hy - jyb)
        bx, by = (hx - jxb) / lb, (hy - jyb) / lb
        wb = round(rng.uniform(0.8, 0.95) * w0)
        bw = rng.uniform(0.1, 0.16) * lb * rng.choice((-1, 1))
        bctl = []
        for k in range(5):
            d = lb * (1 - k / 4)
            off = bw * math.sin(math.pi * d / lb)
            bctl.append((jxb + d * bx - off * by, jyb + d * by + off * bx))
        bline = catmull_rom(bctl, STEP)
        bs = arc_lengths(bline)
        zb_head = top - rng.uniform(120, 150)
        # A hanging valley: it ends at the gorge's edge, graded to the outer layers' floor there (a
        # bench above the inner gorge, into which it pours off), its depth what its floor needs
        # below the plateau minus what the outer layers cut. (Run on to the gorge's axis and graded
        # to its floor, its depth less the script's estimate of the layers' cut, which falls short
        # of the solver's by tens of metres under the strata, dug 45-90 m hollows at the junction.)
        gl, ga, gw, gf = trunk[0]
        end = next((i for i, p in enumerate(bline) if nearest(gl, ga, *p)[0] < 0.5 * gw), len(bline) - 1)
        bline = bline[:end + 1]
        d_end = trunk_depth(*bline[-1], first=1)
        d_head = min(top - zb_head, 0.6 * d_end)
        bamp = []
        for p, sa in zip(bline, bs):
            want = d_head + (d_end - d_head) * (1 - (1 - sa / bs[end]) ** 1.2)
            bamp.append(max(0.0, want - trunk_depth(*p, first=1)))
        side_ops.append({"op": "ravine", "comment": f"side canyon {nsc}: tributary, graded to its floor",
                         "points": [[round(p[0], 1), round(p[1], 1), round(z, 1)] for p, z in zip(bline, bamp)], "smooth": True,
                         "width": wb, "profile": "u", "floor": round(0.3 * wb), "taper": 0, "exit": 0})
    i0 = min(range(len(axis)), key=lambda i: abs(s[i] - 0.6 * s[i_rim]))
    idx = list(range(i0, len(axis), 3))
    if idx[-1] != len(axis) - 1:
        idx.append(len(axis) - 1)
    stream = [[round(axis[i][0], 1), round(axis[i][1], 1), round(grade(s[i]), 1)] for i in idx]
    tributaries.append({"op": "river", "comment": "the side canyon's stream, graded to the main river" if not tributaries else None,
                        "points": stream, "width": 120, "floor": 16, "bank_height": 3})
ops += side_ops
ops = [{k: v for k, v in o.items() if v is not None} for o in ops]
# The river after the side canyons: a side canyon releases the hard cells within its half-width
# (cut_rims, meant for the rim it crosses), and its exit reaches the floor: the river's bed,
# pinned before, floated up 70 m into a dam there.
ops.append({"op": "river", "points": river, "smooth": True, "width": 420, "floor": 20, "bank_height": 10})
ops += [{k: v for k, v in o.items() if v is not None} for o in tributaries]
# Layered rock, before the gullies: the gullies' runnels are not stepped (ridged noise amplified by
# the hard beds drew a comb of vertical stripes on the lit walls of the side canyons).
ops.append({"op": "strata", "comment": "layered rock in every steep wall (main and side canyons): hard beds form cliff bands, soft ones benches, under a caprock",
            "polygon": [[0, 0], [EXT, 0], [EXT, EXT], [0, EXT]], "falloff": 0, "top": TOP + 12, "bottom": 180,
            "thickness": 70, "soft_thickness": 35, "jitter": 0.35, "contrast": 6, "min_slope": 25, "seed": 5})
# Gullies down the walls: a band along both rims.
band = [[round(west(y) - 200, 1), y] for y in (0, 1280, 2560, 3840, 5120)] + \
       [[round(east(y) + 200, 1), y] for y in (5120, 3840, 2560, 1280, 0)]
ops.append({"op": "noise", "comment": "gullies down the canyon walls: a band along the two rims", "polygon": band, "falloff": 300,
            "amplitude": 12, "wavelength": 250, "type": "ridged", "octaves": 3, "orient": {"angle": 0, "strength": 0.7}})
doc = {"description": "Canyon with rims and side canyons (paper figure 1), written by scripts/gen-canyon.py: two smoothed cliff rims (face + scree) on an 800 m plateau that wander independently (the canyon 1.6-2.6 km wide at the top, promontories and bays), a river meandering down the floor between the walls' feet (130 -> 70 m; rims and river run on past the map's edges), broad swells on the plateau, six side canyons of different widths that wander back 0.5-2.1 km into the plateau from amphitheatre heads (round alcoves 130-170 m deep, narrower than the canyon below them, fed by a shallow wash), built of nested layers along one axis (a head alcove, an inner gorge, one or two wider outer layers whose depth grows from 0 and which swing across the gorge, so the benches pinch out and widen) so they widen and deepen towards the main canyon, four with tributaries of their own (hanging valleys graded to the bench above the inner gorge), cutting through the rims with their floors graded to the main river by a tributary stream, layered rock (strata: 4-5 hard beds over soft ones under a caprock) in every steep wall, fBm, oriented gullies on the walls.",
       "base": "flat:1025x1025@5", "units": "m", "seed": 11, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
