#!/usr/bin/env python3
# Writes data/examples/canyon.json (issue 12 gallery, paper figure 1): a canyon cut into an 800 m
# plateau whose two cliff rims wander independently (the canyon widens and narrows, promontories
# and bays), a river meandering down its floor, side canyons of varied length that cut through the
# rims and are graded down the wall to the river, layered rock (strata) in every steep wall, fBm,
# oriented gullies on the walls.
# Usage: python3 scripts/gen-canyon.py OUT.json
import json, math, random, sys

rng = random.Random(7)  # fixed: the script writes the same file every time
EXT = 5120.0  # the map's extent (1025 cells of 5 m)
R_CLIFF = 450.0  # the cliffs' half-width: the wall's foot is this far from the rim, into the canyon
TOP = 800.0  # the plateau (the west rim; the east rim 10 m higher)
DEPTH = TOP - 130.0  # from the rim to the river at its head
HEAD = 150.0  # a side canyon's box head: its depth at the head


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


ys = [-100 + k * 445 for k in range(13)]  # -100 .. 5240
ops = [
    {"op": "noise", "amplitude": 8, "wavelength": 600, "octaves": 5},
    {"op": "cliff", "comment": "west rim: the canyon lies to the east, the left of a southward stroke", "points": rim(west, ys),
     "smooth": True, "elevation": TOP, "height": 330, "width": 2 * R_CLIFF, "side": "left", "face": 0.45, "scree": 0.3},
    {"op": "cliff", "comment": "east rim", "points": rim(east, ys), "smooth": True, "elevation": TOP + 10, "height": 340,
     "width": 2 * R_CLIFF, "side": "right", "face": 0.45, "scree": 0.3},
]
# The river: on the floor between the two walls' feet, meandering within it.
river = []
for k, y in enumerate([-50 + k * 580 for k in range(10)]):
    lo, hi = west(y) + R_CLIFF + 230, east(y) - R_CLIFF - 230
    x = 0.5 * (lo + hi) + 0.5 * (hi - lo) * 0.6 * math.sin(1.3 * k + 0.5) if hi > lo else 0.5 * (lo + hi)
    river.append([round(x, 1), round(min(y, 5170), 1), round(130 - 60 * min(y, 5170) / 5170, 1)])
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


# Side canyons: from the plateau (their heads 0.5-2.2 km back from the rim) through the rim down the
# wall. Flat-floored (floor 110 m) with steep walls of their own (width 560-680 m), a box head 150 m
# deep, 65-72 % of the main canyon's depth where they cross the rim. Their floor is graded: it falls
# from the head to the main river along one concave curve (z = z_river + (z_head - z_river) (1 -
# s/L)^1.3, s the arc length from the head), the ravine's depth on the plateau following it, and
# from halfway to the rim on a tributary stream (a `river`, after the ravines) pins it down to the
# main river: a ravine's depth alone could not follow the wall's benches (its floor rose 20-45 m
# again on the wall). (Before: V troughs 440-560 m wide and ~130 m deep at the rim, half the main
# canyon's depth, walls gentler than the plateau's noise: in the perspective view their floors,
# rising towards the sun, read as light tongues lying on the plateau.)
tributaries = []
for side, y0, back, ang in ((-1, 700, 1900, 12), (-1, 2450, 900, -8), (-1, 3950, 520, 5), (1, 1500, 2200, -10),
                            (1, 3250, 1100, 14), (1, 4500, 600, -4)):
    rim_f = west if side < 0 else east
    rx = rim_f(y0)
    # The rim's outward normal (away from the canyon), tilted by ang degrees.
    dy = 1.0
    tx, ty = (rim_f(y0 + dy) - rim_f(y0 - dy)) / (2 * dy), 1.0
    tl = math.hypot(tx, ty)
    nx, ny = side * ty / tl, -side * tx / tl
    a = math.radians(ang)
    nx, ny = nx * math.cos(a) - ny * math.sin(a), nx * math.sin(a) + ny * math.cos(a)
    # (Its head stays on the map.)
    while not (80 < rx + back * nx < EXT - 80 and 80 < y0 + back * ny < EXT - 80):
        back *= 0.9
    at_rim = rng.uniform(0.65, 0.72) * DEPTH
    # (distance out from the rim, depth below the terrain there): negative distances lie inside the
    # canyon, on the wall, where the terrain itself falls (the stream pins the floor there).
    plan = [(back, HEAD), (0.5 * back, HEAD + 0.6 * (at_rim - HEAD)), (0, at_rim), (-0.45 * R_CLIFF, 0.2 * at_rim),
            (-0.85 * R_CLIFF, 30)]
    wob = rng.uniform(-0.25, 0.25)
    pts = []
    for d, z in plan:
        off = wob * max(d, 0) * (1 - max(d, 0) / max(back, 1))  # a side canyon bends on the plateau
        pts.append([round(rx + d * nx - off * ny, 1), round(y0 + d * ny + off * nx, 1), z])
    jx, jy, jz = river_nearest(pts[-1][0], pts[-1][1])
    line = pts + [[jx, jy, 0]]
    arc = [0.0]
    for p, q in zip(line, line[1:]):
        arc.append(arc[-1] + math.hypot(q[0] - p[0], q[1] - p[1]))
    z_head, z_end = TOP - HEAD, jz + 2

    def grade(s):
        return z_end + (z_head - z_end) * (1 - s / arc[-1]) ** 1.3

    # On the plateau the depth is the plateau minus the graded floor; at the rim the planned depth.
    for k in (0, 1):
        pts[k][2] = TOP - grade(arc[k])
    # It runs on along its stream to the river, shallow (an exit along its last wall segment dug a
    # trough of its own beside the stream, ending in a closed hollow 20-60 m deep on the wall).
    pts.append([round(jx, 1), round(jy, 1), 8])
    for p in pts:
        p[2] = round(p[2], 1)
    ops.append({"op": "ravine", "comment": "side canyon" if len(ops) == 4 else None, "points": pts, "smooth": True,
                "width": round(rng.uniform(560, 680)), "profile": "flat", "floor": 110, "taper": 60, "exit": 40})
    stream = [[round(q[0], 1), round(q[1], 1), round(grade(sa), 1)] for q, sa in zip(line[1:], arc[1:])]
    assert len(stream) == len(pts) - 1
    tributaries.append({"op": "river", "comment": "the side canyon's stream, graded to the main river" if not tributaries else None,
                        "points": stream, "width": 120, "floor": 16, "bank_height": 3})
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
doc = {"description": "Canyon with rims and side canyons (paper figure 1), written by scripts/gen-canyon.py: two smoothed cliff rims (face + scree) on an 800 m plateau that wander independently (the canyon 1.6-2.6 km wide at the top, promontories and bays), a river meandering down the floor between the walls' feet (130 -> 70 m), six flat-floored side canyons of varied length (box heads 150 m deep, 0.5-2.2 km back on the plateau) that cut through the rims (~65-72 % of the canyon's depth there) with walls of their own, their floors graded to the main river by a tributary stream, layered rock (strata: 4-5 hard beds over soft ones under a caprock) in every steep wall, fBm, oriented gullies on the walls.",
       "base": "flat:1025x1025@5", "units": "m", "seed": 11, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
