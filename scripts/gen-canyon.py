#!/usr/bin/env python3
# Writes data/examples/canyon.json (issue 12 gallery, paper figure 1): a canyon cut into an 800 m
# plateau whose two cliff rims wander independently (the canyon widens and narrows, promontories
# and bays), a narrow inner gorge with the river meandering down the floor, a plateau tilted gently
# towards the canyon with some relief, side canyons carved by the plateau's own drainage (the
# `drainage` op with its `canyon` section), layered rock (strata) in every steep wall.
#
# Canyon round 4: the side canyons are no longer drawn. The former script drew six of them, each as
# nested `u` ravines on a hand-placed wandering axis (head alcove, inner gorge, outer layers,
# hanging tributaries, a stream down the main wall): they read as rounded fingers of even width laid
# on the plateau, with mostly concentric benches and fins where they met the rim. Here the plateau
# drains over the rims (a broad tilt towards the canyon under the noise) and one drainage op cuts
# every channel draining more than `threshold` down to a bed graded to the main canyon's floor, with
# a flat floor and walls at `wall_slope`: a network that branches the way water runs, with
# tributaries where the noise gathers them, widths that follow the depth and amphitheatre heads.
# (m = 1: the depth grows with the area, so the smallest channels, from 0.04 km^2, are gullies 18 m
# deep that taper into the plateau; with channels from 0.12 km^2 every branch began 54 m deep, a
# round-ended tube. path_smooth 100 m: the sections follow the flow lines' mean direction; D8's
# 0/45/90-degree zig-zags drew right-angled gullies.)
# Usage: python3 scripts/gen-canyon.py OUT.json
import json
import math
import sys

EXT = 5120.0  # the map's extent (1025 cells of 5 m)
R_CLIFF = 450.0  # the cliffs' half-width: the wall's foot is this far from the rim, into the canyon
TOP = 800.0  # the plateau (the west rim; the east rim 10 m higher)


def centre(y):
    """The canyon's axis: NNW -> SSE with a long swing."""
    return 1700 + 0.27 * y + 200 * math.sin(2 * math.pi * y / 3400 + 0.4)


# Each rim's distance from the axis, with its own wobbles: the canyon is 1.47-1.96 km wide at the top.
# The rims' radius of curvature stays >= 690 m, 1.5 cliff radii: at a bend of ~420 m (a former
# draft) the cliff's profile drew a hairline from the rim across the plateau with a pit at its end.
def west(y):
    return centre(y) - (860 + 170 * math.sin(2 * math.pi * y / 2600 + 6.0) + 45 * math.sin(2 * math.pi * y / 1500 + 2.0))


def east(y):
    return centre(y) + (820 + 190 * math.sin(2 * math.pi * y / 2900 + 2.4) + 40 * math.sin(2 * math.pi * y / 1400 + 0.3))


def rim(f, ys):
    return [[round(f(y), 1), round(y, 1)] for y in ys]


ys = [-990 + k * 445 for k in range(17)]  # -990 .. 6130: the rims run on 1 km past both edges
ops = [
    {"op": "noise", "comment": "plateau relief: the drainage follows it", "amplitude": 24, "wavelength": 1400, "octaves": 6},
    {"op": "noise", "comment": "broad swells on the plateau", "amplitude": 22, "wavelength": 2600, "octaves": 2, "seed": 3},
    # The plateau falls gently towards the canyon (2.7 %: 120 m over 4.5 km), so it drains over the
    # rims and the side canyons grow back from them: a valley of gradients along the canyon's axis,
    # wider than the map, under the cliffs (which pin the rims and so fix the level). (6 km wide and
    # 60 m deep, the east plateau's far part drained off the map's east edge, where the drainage cut
    # canyons running away from the main one.)
    {"op": "ravine", "comment": "the plateau's tilt towards the canyon", "points": [[round(centre(y), 1), y] for y in ys], "smooth": True,
     "depth": 120, "depth_start": 120, "width": 9000, "profile": "v", "taper": 0, "exit": 0, "cut_rims": False},
    {"op": "cliff", "comment": "west rim: the canyon lies to the east, the left of a southward stroke", "points": rim(west, ys),
     "smooth": True, "elevation": TOP, "height": 330, "width": 2 * R_CLIFF, "side": "left", "face": 0.45, "scree": 0.3},
    {"op": "cliff", "comment": "east rim", "points": rim(east, ys), "smooth": True, "elevation": TOP + 10, "height": 340,
     "width": 2 * R_CLIFF, "side": "right", "face": 0.45, "scree": 0.3},
]
# The river: on the floor between the two walls' feet, meandering within it, in a narrow inner
# gorge (its banks rise 45 m over 110 m: the river op's u profile, per-vertex bed 130 -> 70 m).
river = []
for k, y in [(k, -50 + k * 580) for k in range(-1, 11)]:  # (k = -1 and 10: past the map's edges)
    lo, hi = west(y) + R_CLIFF + 150, east(y) - R_CLIFF - 150
    x = 0.5 * (lo + hi) + 0.5 * (hi - lo) * 0.7 * math.sin(1.3 * k + 0.5) if hi > lo else 0.5 * (lo + hi)
    river.append([round(x, 1), round(y, 1), round(130 - 60 * y / 5170, 1)])
ops.append({"op": "river", "comment": "the river in its inner gorge", "points": river, "smooth": True, "width": 220, "floor": 24,
            "bank_height": 45, "profile": "u"})
# The drainage's region: the two plateaus and walls down to 0.8 of the way to the walls' feet, so
# the main floor and the inner gorge keep their shape (a C around the floor, open past the north
# edge). The side canyons' beds are graded to where they leave it, near the walls' feet.
FOOT = 0.8 * R_CLIFF
yr = [-400 + k * 200 for k in range(31)]  # -400 .. 5600
poly = [[-300, -300], [-300, EXT + 300], [EXT + 300, EXT + 300], [EXT + 300, -300]]
poly += [[round(east(y) + FOOT * (-1), 1), y] for y in yr if y < EXT + 250]
poly += [[round(west(y) + FOOT, 1), y] for y in reversed(yr) if y < EXT + 250]
# D8 routing, its zig-zags straightened by path_smooth: D-infinity (the op's default) disperses the
# plateau's sheet flow, so fewer cells reach the threshold (513^2 run: 3 side canyons through the
# rims and 19 junctions, against 8 and 59 with D8).
ops.append({"op": "drainage", "comment": "side canyons: the plateau's drainage cut down to beds graded to the main canyon's floor, "
            "flat floors between walls at 1.4",
            "polygon": poly, "falloff": 60, "profile": "canyon", "n": 0, "m": 1.0, "depth": 450, "reference_area": 1.0e6,
            "threshold": 4.0e4, "max_depth": 600, "channel_width": 50, "max_width": 90, "wall_slope": 1.4, "path_smooth": 100, "routing": "d8",
            "smooth": 2})
# Layered rock: hard beds form cliff bands, soft ones benches, under a caprock.
# (Beds 60 / 30 m jittered by 0.65: with 70 / 35 m and 0.35 the bands ran evenly spaced round every
# wall like a contour model. The strata's steps on the side canyons' steep floors leave closed
# hollows whose depth depends on where the bands fall: 5.6-14.4 m over six variants of these
# numbers (513^2 run), 5.6 m with these, 13.3 m with the former; jitter 0.7 left too few walls with
# three bands.)
ops.append({"op": "strata", "comment": "layered rock in every steep wall (main and side canyons, the inner gorge)",
            "polygon": [[0, 0], [EXT, 0], [EXT, EXT], [0, EXT]], "falloff": 0, "top": TOP + 12, "bottom": 60,
            "thickness": 60, "soft_thickness": 30, "jitter": 0.65, "contrast": 6, "min_slope": 25, "seed": 5})
doc = {"description": "Canyon with rims and side canyons carved by drainage (paper figure 1), written by scripts/gen-canyon.py: two smoothed "
       "cliff rims (face + scree) on an 800 m plateau tilted gently towards the canyon, wandering independently; a river meandering "
       "130 -> 70 m down the floor in a narrow inner gorge; side canyons carved by the plateau's own drainage (drainage op, canyon "
       "section: beds graded to the main floor, flat floors, walls at 1.4); layered rock (strata) in every steep wall.",
       "base": "flat:1025x1025@5", "units": "m", "seed": 11, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
