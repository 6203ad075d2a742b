#!/usr/bin/env python3
# Writes data/examples/cliff.json (issue 12 gallery, paper figure 14): a cliff band facing west (into
# the light) under a frozen plateau, gullies cut into the face from the brink to its foot, a scree
# cone below each gully on a concave talus apron, oriented gullies on the apron. (The former
# softened toe, a scale_slopes disc, drew a straight edge at the map's south-west corner.)
# Usage: python3 scripts/gen-cliff.py OUT.json
import json, math, random, sys

E = 2048.0          # extent (m): 1025 cells of 2 m
TOP, DROP = 1500.0, 450.0
R, FACE, SCREE = 700.0, 0.17, 0.45   # half-width, face share of r, scree share of the drop
# North-north-east to south-south-west: the face looks west-north-west, towards the renderer's sun
# (azimuth 315 degrees), and is lit.
rim = [[1700, -20], [1500, 700], [1180, 1400], [860, 2070]]


def catmull(P, n=64):
    Q = [P[0]] + P + [P[-1]]
    out = []
    for i in range(1, len(Q) - 2):
        p0, p1, p2, p3 = Q[i - 1], Q[i], Q[i + 1], Q[i + 2]
        for k in range(n):
            t = k / n
            out.append([0.5 * (2 * p1[j] + (-p0[j] + p2[j]) * t + (2 * p0[j] - 5 * p1[j] + 4 * p2[j] - p3[j]) * t * t +
                               (-p0[j] + 3 * p1[j] - 3 * p2[j] + p3[j]) * t ** 3) for j in range(2)])
    out.append(P[-1])
    return out


line = catmull(rim)


def rim_at(y):
    """The smoothed rim's x at y and its unit normal pointing down the face (west)."""
    i = min(range(1, len(line) - 1), key=lambda k: abs(line[k][1] - y))
    a, b = line[i - 1], line[i + 1]
    tx, ty = b[0] - a[0], b[1] - a[1]
    l = math.hypot(tx, ty)
    return line[i][0], (-ty / l, tx / l) if -ty < 0 else (ty / l, -tx / l)


rng = random.Random(7)
ops = [
    {"op": "noise", "amplitude": 3, "wavelength": 250, "octaves": 4, "comment": "gentle undulation everywhere"},
    {"op": "cliff", "points": rim, "smooth": True, "elevation": TOP, "height": DROP, "width": 2 * R, "face": FACE,
     "scree": SCREE, "side": "right"},
    {"op": "freeze", "polygon": [[E, 0], [E, E]] + [[x + 260, y] for x, y in reversed(rim)], "comment": "the plateau (east)"},
]
face_w = FACE * R
y = 90.0
while y < E - 90:
    x, (nx, ny) = rim_at(y)
    w = rng.uniform(80, 110)       # gully width (m)
    d = rng.uniform(45, 70)        # depth cut into the face (m)
    # From the brink down the face to its foot, then fading out on the apron's top.
    pts = [[round(x + f * nx, 1), round(y + f * ny, 1), round(z, 1)] for f, z in ((0.0, 0.3 * d), (0.5 * face_w, d), (face_w, 0.3 * d))]
    ops.append({"op": "ravine", "points": pts, "width": round(w), "profile": "round", "taper": round(0.2 * w), "exit": 60,
                "comment": "a gully cut into the face, notching the brink"})
    # Its scree cone: a lobe on the apron below the gully's mouth, highest at the top, fanning out.
    L = rng.uniform(200, 300)
    c0 = face_w - 10
    cone = [[round(x + f * nx, 1), round(y + f * ny, 1), round(z, 1)] for f, z in ((c0, 0.7 * d), (c0 + 0.35 * L, 0.6 * d), (c0 + L, 0.0))]
    ops.append({"op": "free_crest", "points": cone, "smooth": True, "width": round(1.8 * w), "profile": "round",
                "comment": "scree cone"})
    y += rng.uniform(170, 260)
ops += [
    {"op": "noise", "polygon": [[x - face_w - 40, y] for x, y in rim] + [[0, E], [0, 0]], "falloff": 150, "amplitude": 3, "wavelength": 60,
     "type": "ridged", "octaves": 3, "orient": {"angle": 90, "strength": 0.8}, "comment": "gullies down the apron"},
]
doc = {"description": "A cliff band with scree (paper figure 14), written by scripts/gen-cliff.py: a smoothed cliff line running north-south, 300 m high, facing west into the light: a face 68 m wide dropping ~165 m (steeper than 60 degrees at its middle) over a concave talus apron (~380 m, 135 m, ~0.7 at its top: the scree angle); gullies 36-56 m wide cut 18-30 m into the face from the brink (which they notch) to its foot, each with a scree cone fanning out on the apron below it; the plateau (east) frozen, ridged gullies oriented down the apron.",
       "base": "flat:1025x1025@2", "units": "m", "seed": 3, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
