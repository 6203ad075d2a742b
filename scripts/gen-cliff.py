#!/usr/bin/env python3
# Writes data/examples/cliff.json (issue 12 gallery, paper figure 14): a cliff band facing west (into
# the light) under a plateau with gentle relief, its brink wandering in bays and headlands. Gullies at
# irregular spacing (+-45 %) of three kinds: notches that cut back into the plateau (fed by shallow
# plateau valleys), chutes from the brink to the foot, and short scars on the face; buttresses (ribs)
# between them; a scree cone under each gully, its size following the gully's, merging into a talus
# apron with fine noise; layered rock (strata) down the face: cliff bands, ledges and a caprock;
# fallen blocks on the apron. (Before: ten identical, evenly spaced
# gullies, a flat featureless slab, a straight brink, scree cones all alike.)
# Usage: python3 scripts/gen-cliff.py OUT.json
import json, math, os, random, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from polyline import arc_lengths, catmull  # noqa: E402

E = 2048.0          # extent (m): 1025 cells of 2 m
TOP, DROP = 1500.0, 450.0
R, FACE, SCREE = 700.0, 0.17, 0.45   # half-width, face share of r, scree share of the drop
face_w = FACE * R
rng = random.Random(11)

# North-north-east to south-south-west: the face looks west-north-west, towards the renderer's sun
# (azimuth 315 degrees), and is lit. The brink wanders about the former straight-ish line in bays and
# headlands (wavelengths >= 500 m: a tighter bend puts the profile's medial-axis crease inside the
# apron, within the bend's radius of curvature of the rim).
# The stroke runs 400 m past the map at both ends: a cliff dies out past its ends (its drop fades over
# r), which drew a straight ramp edge across the apron's corner when the stroke ended at the map's edge.
base = [[1812, -420], [1700, -20], [1500, 700], [1180, 1400], [860, 2070], [669, 2470]]


base_line = catmull(base, 64)


def base_x(y):
    i = min(range(len(base_line)), key=lambda k: abs(base_line[k][1] - y))
    return base_line[i][0]


ph1, ph2 = rng.uniform(0, 2 * math.pi), rng.uniform(0, 2 * math.pi)
rim = []
for k in range(16):
    y = -420 + k * (2890 / 15)
    wander = 45 * math.sin(2 * math.pi * y / 950 + ph1) + 18 * math.sin(2 * math.pi * y / 520 + ph2)
    rim.append([round(base_x(y) + wander, 1), round(y, 1)])
line = catmull(rim, 64)
arc = arc_lengths(line)


def rim_at_arc(s):
    """The smoothed rim's point at arc length s, its unit tangent and its unit normal down the face (west)."""
    i = max(1, min(len(line) - 2, next((k for k, v in enumerate(arc) if v >= s), len(line) - 2)))
    a, b = line[i - 1], line[i + 1]
    tx, ty = b[0] - a[0], b[1] - a[1]
    l = math.hypot(tx, ty)
    tx, ty = tx / l, ty / l
    n = (-ty, tx) if -ty < 0 else (ty, -tx)
    return line[i], (tx, ty), n


def pt(p, n, f, z=None, t=(0, 0), g=0.0):
    """The point f metres down the face from rim point p (negative: back on the plateau), g along the rim."""
    q = [round(p[0] + f * n[0] + g * t[0], 1), round(p[1] + f * n[1] + g * t[1], 1)]
    return q + [round(z, 1)] if z is not None else q


on_map = [v for v, q in zip(arc, line) if 60 < q[0] < E - 60 and 60 < q[1] < E - 60]


def band(f0, f1, step=60.0):
    """A polygon between f0 and f1 metres down the face from the smoothed rim, over its part on the
    map (each vertex costs time in every cell of the region's box)."""
    a0, a1 = max(0.0, on_map[0] - 100), min(arc[-1], on_map[-1] + 100)
    ss = [a0 + k * step for k in range(int((a1 - a0) / step) + 1)] + [a1]
    a = [pt(*rim_at_arc(v)[::2], f0) for v in ss]
    b = [pt(*rim_at_arc(v)[::2], f1) for v in reversed(ss)]
    return a + b


plateau_poly = [[E, 0], [E, E]] + [[x + 40, y] for x, y in reversed(rim)]
ops = [
    {"op": "noise", "amplitude": 3, "wavelength": 250, "octaves": 4, "comment": "gentle undulation everywhere"},
    {"op": "cliff", "points": rim, "smooth": True, "elevation": TOP, "height": DROP, "width": 2 * R, "face": FACE,
     "scree": SCREE, "side": "right", "comment": "the brink wanders in bays and headlands"},
    {"op": "noise", "polygon": plateau_poly, "falloff": 120, "amplitude": 30, "wavelength": 600, "octaves": 3, "seed": 21,
     "comment": "the plateau's gentle relief (swells and hollows over ~40 m)"},
    {"op": "noise", "polygon": plateau_poly, "falloff": 60, "amplitude": 2.5, "wavelength": 40, "octaves": 3, "seed": 22,
     "comment": "fine roughness on the plateau (outcrops, ledges)"},
]

# Gullies along the brink at irregular spacing; their kinds and sizes drawn at random.
gullies = []
s = on_map[0] + rng.uniform(0, 80)
while s < on_map[-1] - 40:
    u = rng.random()
    kind = "notch" if u < 0.3 else ("chute" if u < 0.65 else "scar")
    size = rng.uniform(0.6, 1.4)
    gullies.append((s, kind, size))
    s += 210 * rng.uniform(0.55, 1.45)

plateau_valleys, cuts, cones, ribs = [], [], [], []
for s, kind, size in gullies:
    p, t, n = rim_at_arc(s)
    w = round(70 * size * rng.uniform(0.8, 1.2))
    d = 62 * size * rng.uniform(0.8, 1.2)
    if kind == "notch":
        back = rng.uniform(50, 130)       # how far it cuts back into the plateau
        pts = [pt(p, n, -back, 0.05 * d), pt(p, n, -0.4 * back, 0.5 * d), pt(p, n, 0.3 * face_w, 1.1 * d), pt(p, n, 0.8 * face_w, 0.5 * d),
               pt(p, n, face_w + 50, 0.1 * d)]
        # (It runs out onto the apron: a wide notch ending at the face's foot rose out of its exit
        # against the apron's fall and left a moat at the foot beside it.)
        cuts.append({"op": "ravine", "points": pts, "smooth": True, "width": round(1.6 * w), "profile": "v", "taper": round(0.6 * w), "exit": 80,
                     "comment": "a notch: a gully cutting back into the plateau"})
        # A shallow plateau valley draining into the notch's head.
        L = rng.uniform(250, 450)
        bend = rng.uniform(-80, 80)
        plateau_valleys.append({"op": "ravine", "points": [pt(p, n, -back - L, 0, t, bend), pt(p, n, -back - 0.5 * L, 6, t, 0.5 * bend),
                                                           pt(p, n, -back + 20, 12)], "smooth": True,
                                "width": round(rng.uniform(90, 160)), "profile": "round", "exit": 0,
                                "comment": "a shallow valley on the plateau feeding a notch"})
        cone_scale = 1.3
    elif kind == "chute":
        # Deepest high on the face; it shallows where the face is steep (shallowing at the foot, where
        # the face has turned gentle, left a flat step at the mouth).
        pts = [pt(p, n, 0.0, 0.3 * d), pt(p, n, 0.35 * face_w, d), pt(p, n, 0.8 * face_w, 0.35 * d), pt(p, n, face_w + 40, 0.1 * d)]
        cuts.append({"op": "ravine", "points": pts, "smooth": True, "width": w, "profile": "round", "taper": round(0.2 * w), "exit": 60,
                     "comment": "a chute from the brink to the face's foot"})
        cone_scale = 1.0
    else:
        a, b = rng.uniform(0.15, 0.35), rng.uniform(0.6, 0.85)
        pts = [pt(p, n, a * face_w, 0.2 * d), pt(p, n, 0.5 * (a + b) * face_w, 0.5 * d), pt(p, n, b * face_w, 0.2 * d)]
        cuts.append({"op": "ravine", "points": pts, "width": round(0.6 * w), "profile": "round", "taper": round(0.25 * w), "exit": 30,
                     "comment": "a scar on the face"})
        cone_scale = 0.5
    # Its scree cone: a lobe on the apron below the mouth, highest at the top, fanning out; its size
    # follows the gully's (the material it shed).
    # It starts up in the gully's lower half (debris fills its floor): a cone starting at the foot
    # ramps up over its taper and leaves a hollow between the gully's mouth and itself.
    L = cone_scale * rng.uniform(160, 300) * size
    c0 = face_w - 10
    h = cone_scale * 0.4 * d
    cones.append({"op": "free_crest", "points": [pt(p, n, 0.4 * face_w, 0.0), pt(p, n, c0, h),
                                                  pt(p, n, c0 + 0.35 * L, 0.85 * h, t, rng.uniform(-15, 15)),
                                                  pt(p, n, c0 + L, 0.0, t, rng.uniform(-40, 40))],
                  "smooth": True, "width": round(1.5 * w * max(cone_scale, 0.7)), "profile": "round", "taper": 15,
                  "comment": "scree cone (a short taper: the default, its half-width, left it low at the mouth)"})

# Buttresses: a rib down the face between each pair of neighbouring gullies, its height and width
# following the gap.
for (s0, _, _), (s1, _, _) in zip(gullies, gullies[1:]):
    gap = s1 - s0
    if gap < 140:
        continue
    p, t, n = rim_at_arc(0.5 * (s0 + s1) + rng.uniform(-0.1, 0.1) * gap)
    hgt = rng.uniform(8, 22) * min(gap, 300) / 200
    ribs.append({"op": "free_crest", "points": [pt(p, n, 0.1 * face_w, 0.2 * hgt), pt(p, n, 0.55 * face_w, hgt), pt(p, n, face_w + 20, 0.1 * hgt)],
                 "width": round(min(0.5 * gap, 140)), "profile": "round", "taper": 25, "comment": "a buttress between two gullies"})

face_poly = [[x - 8, y] for x, y in rim] + [[x - face_w - 10, y] for x, y in reversed(rim)]
apron_poly = [[x - face_w - 40, y] for x, y in rim] + [[0, E], [0, 0]]
ops += plateau_valleys
ops.append({"op": "freeze", "polygon": [[E, 0], [E, E]] + [[x + 300, y] for x, y in reversed(rim)],
            "comment": "the plateau (east), back from the brink"})
ops += cuts + ribs + cones
# Layered rock in the face (after the gullies, which it steps too; before the runnels, which it
# would comb into vertical stripes): hard beds ~26 m thick as near-vertical bands, soft ones ~7 m as
# ledges, under a caprock at the brink. (It replaces the former cap and ledge, two scale_slopes bands.)
# (The stack ends 30 m above the face's foot: beds reaching the apron's top stepped it, with a
# counter-slope, a hollow, under the foot.)
ops.append({"op": "strata", "polygon": band(-30, face_w + 10), "falloff": 20, "top": TOP + 4,
            "bottom": round(TOP - (1 - SCREE) * DROP + 30),
            "thickness": 30, "soft_thickness": 10, "jitter": 0.4, "contrast": 20, "min_slope": 40, "slope_ramp": 12, "seed": 9,
            "comment": "layered rock: cliff bands and ledges down the face, a caprock at the brink"})
# Fallen blocks on the apron: most near the foot, fewer out on the scree.
blocks = []
for k in range(36):
    s_b = rng.uniform(on_map[0], on_map[-1])
    p, t, n = rim_at_arc(s_b)
    f = face_w + 5 + rng.expovariate(1 / 90.0)
    size = rng.uniform(10, 24) * (1.2 if f < face_w + 60 else 0.8)
    a = rng.uniform(0, math.pi)
    c = pt(p, n, f, None, t, rng.uniform(-20, 20))
    dx, dy = 0.35 * size * math.cos(a), 0.35 * size * math.sin(a)
    blocks.append({"op": "free_crest", "points": [[round(c[0] - dx, 1), round(c[1] - dy, 1)], [round(c[0] + dx, 1), round(c[1] + dy, 1)]],
                   "width": round(size, 1), "height": round(0.5 * size, 1), "profile": "flat", "taper": round(0.2 * size, 1)})
blocks[0]["comment"] = "fallen blocks on the apron (36, 8-29 m across, half as high, most within 90 m of the foot)"
ops += blocks
ops += [
    {"op": "noise", "polygon": face_poly, "falloff": 25, "amplitude": 6, "wavelength": 45, "type": "ridged", "octaves": 3, "seed": 24,
     "orient": {"angle": 90, "strength": 0.85}, "comment": "ribs and runnels down the face"},
    {"op": "noise", "polygon": apron_poly, "falloff": 150, "amplitude": 3, "wavelength": 60, "type": "ridged", "octaves": 3,
     "orient": {"angle": 90, "strength": 0.8}, "comment": "gullies down the apron"},
    {"op": "noise", "polygon": apron_poly, "falloff": 80, "amplitude": 0.8, "wavelength": 18, "octaves": 2, "seed": 23,
     "comment": "fine grain on the scree"},
]
def count(k, plural):
    m = sum(1 for g in gullies if g[1] == k)
    return "%d %s" % (m, k if m == 1 else plural)


n_kind = {k: sum(1 for g in gullies if g[1] == k) for k in ("notch", "chute", "scar")}
doc = {"description": "A cliff band with scree (paper figure 14), written by scripts/gen-cliff.py: a cliff 450 m high running "
                       "NNE-SSW, facing west into the light, its brink wandering in bays and headlands (+-60 m), layered rock "
                       "(strata: hard beds ~30 m as near-vertical bands over soft ones ~10 m as ledges, a caprock at the brink), over a concave talus apron (~0.7 at its top: the scree angle). %d gullies at irregular spacing: %s cutting back "
                       "into the plateau (each fed by a shallow plateau valley), %s from the brink to the foot, %s "
                       "on the face; buttresses between them; a scree cone under each gully, sized by it; 36 fallen blocks on the apron, most near the foot; a plateau (east) "
                       "with gentle relief and fine roughness, frozen 300 m back from the brink; ridged gullies and fine "
                       "grain on the apron." % (len(gullies), count("notch", "notches"), count("chute", "chutes"), count("scar", "scars")),
       "base": "flat:1025x1025@2", "units": "m", "seed": 3, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
