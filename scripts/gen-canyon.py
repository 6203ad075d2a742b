#!/usr/bin/env python3
# Writes data/examples/canyon.json (issue 12 gallery, paper figure 1): a canyon cut into a 500 m
# plateau whose two cliff rims wander independently (the canyon widens and narrows, promontories
# and bays), a river meandering down its floor, side canyons of varied length that cut through the
# rims and end at the foot of the wall, fBm, oriented gullies on the walls.
# Usage: python3 scripts/gen-canyon.py OUT.json
import json, math, random, sys

rng = random.Random(7)  # fixed: the script writes the same file every time
EXT = 5120.0  # the map's extent (1025 cells of 5 m)
R_CLIFF = 450.0  # the cliffs' half-width: the wall's foot is this far from the rim, into the canyon


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
     "smooth": True, "elevation": 500, "height": 180, "width": 2 * R_CLIFF, "side": "left", "face": 0.45, "scree": 0.3},
    {"op": "cliff", "comment": "east rim", "points": rim(east, ys), "smooth": True, "elevation": 510, "height": 190,
     "width": 2 * R_CLIFF, "side": "right", "face": 0.45, "scree": 0.3},
]
# The river: on the floor between the two walls' feet, meandering within it.
river = []
for k, y in enumerate([-50 + k * 580 for k in range(10)]):
    lo, hi = west(y) + R_CLIFF + 230, east(y) - R_CLIFF - 230
    x = 0.5 * (lo + hi) + 0.5 * (hi - lo) * 0.6 * math.sin(1.3 * k + 0.5) if hi > lo else 0.5 * (lo + hi)
    river.append([round(x, 1), round(min(y, 5170), 1), round(130 - 60 * min(y, 5170) / 5170, 1)])
ops.append({"op": "river", "points": river, "smooth": True, "width": 420, "floor": 20, "bank_height": 10})
# Side canyons: from the plateau (their heads 0.3-2.2 km back from the rim) through the rim to the
# wall's foot, where they end (depth back to a few metres: the floor they open onto is their base
# level; a side canyon still 170 m deep at the foot, running on into the floor, dug a pit by the river).
for side, y0, back, ang in ((-1, 700, 1900, 12), (-1, 2450, 800, -8), (-1, 3950, 350, 5), (1, 1500, 2200, -10),
                            (1, 3250, 1100, 14), (1, 4500, 450, -4)):
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
    depth = rng.uniform(140, 170)
    pts = []
    # (distance out from the rim, depth): negative distances lie inside the canyon, on the wall.
    plan = [(back, 20), (0.5 * back, 0.35 * depth + 0.3 * depth * min(1, back / 1500)), (120, 0.9 * depth), (-0.45 * R_CLIFF, 0.6 * depth), (-0.85 * R_CLIFF, 12)]
    if back < 600:
        plan = [(back, 25), (120, 0.7 * depth), (-0.45 * R_CLIFF, 0.5 * depth), (-0.85 * R_CLIFF, 12)]
    wob = rng.uniform(-0.25, 0.25)
    for d, z in plan:
        off = wob * max(d, 0) * (1 - max(d, 0) / max(back, 1))  # a side canyon bends on the plateau
        pts.append([round(rx + d * nx - off * ny, 1), round(y0 + d * ny + off * nx, 1), round(z, 1)])
    ops.append({"op": "ravine", "comment": "side canyon" if len(ops) == 4 else None, "points": pts, "smooth": True,
                "width": round(rng.uniform(440, 560)), "exit": 120})
ops = [{k: v for k, v in o.items() if v is not None} for o in ops]
# Gullies down the walls: a band along both rims.
band = [[round(west(y) - 200, 1), y] for y in (0, 1280, 2560, 3840, 5120)] + \
       [[round(east(y) + 200, 1), y] for y in (5120, 3840, 2560, 1280, 0)]
ops.append({"op": "noise", "comment": "gullies down the canyon walls: a band along the two rims", "polygon": band, "falloff": 300,
            "amplitude": 12, "wavelength": 250, "type": "ridged", "octaves": 3, "orient": {"angle": 0, "strength": 0.7}})
doc = {"description": "Canyon with rims and side canyons (paper figure 1), written by scripts/gen-canyon.py: two smoothed cliff rims (face + scree) on a 500 m plateau that wander independently (the canyon 1.6-2.6 km wide at the top, promontories and bays), a river meandering down the floor between the walls' feet (130 -> 70 m), six side canyons of varied length (heads 0.35-1.9 km back on the plateau) that cut through the rims and end at the wall's foot, fBm, oriented gullies on the walls.",
       "base": "flat:1025x1025@5", "units": "m", "seed": 11, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
