#!/usr/bin/env python3
# Writes data/examples/river_valley.json (issue 12 gallery, the paper's river curve of section 4.2 on a
# real DEM): a river valley meandering through the Colorado Front Range from the high mountains down to
# the plains. Three operations: `scale_slopes` flattens the terrain's own slopes in a corridor along the
# valley (the flood plain; without it the mountains' ridges ran straight across the floor and the
# valley read as a trench), `river` pins the floor on a graded long profile and raises flat-floored
# walls to the terrain (`bank_height: "terrain"`), and a narrow second `river` cuts the channel that
# meanders inside the floor. The path's meanders lengthen downstream (wavelength 80 -> 140 cells);
# the long profile is concave (steep in the mountains, gentle on the plains) and kept below the
# terrain along the whole path.
# Usage: python3 scripts/gen-river-valley.py OUT.json
import json, math, os, sys

import numpy as np
from osgeo import gdal

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from polyline import arc_lengths  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
DEM = os.path.join(HERE, "..", "data", "dem", "frontrange_srtm3_758.asc")
dem = gdal.Open(DEM).ReadAsArray().astype(float)
H, W = dem.shape

X0, X1 = 230.0, 790.0          # from the high mountains past the plains' east edge (cells; the
                               # river's end and its banks' end effects lie off the map)
Y0 = 300.0
R_VALLEY = 22.0                # the valley's half-width (cells): walls meet the terrain there
FLOOR = 10.0                   # the constrained floor's width (cells)
X_FRONT = 610.0                # the mountain front: the plains east of it need no flattening
R_PLAIN = 0.5 * FLOOR + 4.0    # the flood plain's half-width, where the terrain's slopes are flattened


def centreline():
    """Meanders whose wavelength and amplitude grow downstream, sampled every cell in x."""
    pts, phase = [], 0.6
    for x in np.arange(X0, X1 + 0.5, 1.0):
        t = (x - X0) / (X1 - X0)
        lam = 80 + 60 * t
        amp = (14 + 14 * t) * (1 + 0.35 * math.sin(0.23 * phase + 0.4))
        phase += 2 * math.pi / lam * (1 + 0.3 * math.sin(0.11 * x + 2.0))
        y = Y0 + amp * math.sin(phase + 0.5 * math.sin(phase)) + 6 * math.sin(0.37 * phase + 1.1)
        pts.append([float(x), float(y)])
    return pts


def terrain_min(x, y, rad=3):
    xi, yi = min(W - 1, int(round(x))), min(H - 1, int(round(y)))
    win = dem[max(0, yi - rad):min(H, yi + rad + 1), max(0, xi - rad):min(W, xi + rad + 1)]
    return float(win.min())


line = centreline()
arc = arc_lengths(line)
L = arc[-1]
# Vertices every 8 cells of arc (smoothed again by the op's Catmull-Rom).
verts, next_s = [], 0.0
for p, s in zip(line, arc):
    if s >= next_s or p is line[-1]:
        verts.append([p[0], p[1], s])
        next_s = s + 8.0
z_top = terrain_min(verts[0][0], verts[0][1]) - 60.0
z_end = terrain_min(verts[-1][0], verts[-1][1]) - 8.0
# The floor: a concave long profile under the terrain along the whole path (the terrain's lowest
# cell near the path less a depth that shrinks onto the plains). Clamping the profile to that bound
# alone left flats and 40-50 m steps; relaxing it (moving mean, clamp, fall) gives a smooth grade.
bound = [terrain_min(x, y) - (40 - 32 * min(1.0, s / L)) for x, y, s in verts]
z = [z_end + (z_top - z_end) * (1 - s / L) ** 1.6 for _, _, s in verts]
for _ in range(40):
    z = [min(a, b) for a, b in zip(z, bound)]
    for i in range(1, len(z)):
        z[i] = min(z[i], z[i - 1] - 0.5)
    z = [sum(z[max(0, i - 3):i + 4]) / len(z[max(0, i - 3):i + 4]) for i in range(len(z))]
z = [min(a, b) for a, b in zip(z, bound)]
for i in range(1, len(z)):
    z[i] = min(z[i], z[i - 1] - 0.5)
out = [[round(x, 1), round(y, 1), round(zz, 1)] for (x, y, _), zz in zip(verts, z)]


def corridor(half):
    """A polygon around the centreline at `half` cells (left side out, right side back)."""
    left, right = [], []
    for i in range(0, len(line), 4):
        if line[i][0] > X_FRONT:
            break
        a, b = line[max(0, i - 1)], line[min(len(line) - 1, i + 1)]
        tx, ty = b[0] - a[0], b[1] - a[1]
        l = math.hypot(tx, ty)
        nx, ny = -ty / l, tx / l
        p = line[i]
        left.append([round(p[0] + half * nx, 1), round(p[1] + half * ny, 1)])
        right.append([round(p[0] - half * nx, 1), round(p[1] - half * ny, 1)])
    return left + right[::-1]


script = {
    "description": (
        "A river valley meandering through the Colorado Front Range (SRTM, 758^2 at ~70 x 92 m), written "
        "by scripts/gen-river-valley.py: from the high mountains (%.0f m) down to the plains (%.0f m), a "
        "valley %.0f km wide whose meanders lengthen downstream, its flood plain flattened (scale_slopes: "
        "the mountains' own ridges no longer cross the floor), its floor pinned on a concave long profile "
        "and its walls rising to the terrain (\"bank_height\": \"terrain\"), with a channel meandering in "
        "the floor." % (out[0][2], out[-1][2], 2 * R_VALLEY * 0.07)),
    "base": "../dem/frontrange_srtm3_758.asc",
    "units": "cells",
    "operations": [
        {"op": "scale_slopes", "comment": "the flood plain", "polygon": corridor(R_PLAIN),
         "falloff": 6.0, "factor": 0.08},
        {"op": "river", "comment": "the valley", "points": out, "smooth": True, "width": 2 * R_VALLEY,
         "floor": FLOOR, "profile": "flat", "bank_height": "terrain"},
        {"op": "river", "comment": "the channel in the floor",
         "points": [[v[0], v[1], round(v[2] - 10.0, 1)] for v in out], "smooth": True,
         "width": 4, "floor": 1, "profile": "u", "bank_height": 10},
    ],
}
with open(sys.argv[1], "w") as f:
    json.dump(script, f, indent=1)
    f.write("\n")
print("river valley: %d vertices, z %.0f -> %.0f m, path %.0f cells" % (len(out), out[0][2], out[-1][2], L))
