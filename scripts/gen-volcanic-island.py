#!/usr/bin/env python3
# Writes data/examples/volcanic_island.json (issue 12 gallery): a cone fitted to an irregular coast, a caldera
# rim and floor, a beach berm, radial ravines at irregular spacing, gullies carved by drainage. Usage: python3 scripts/gen-volcanic-island.py OUT.json
import json, math, random, sys
C = 5120.0
def R(th):  # coast radius
    return 3900 * (1 + 0.07*math.sin(3*th+1.0) + 0.045*math.sin(5*th+2.0) + 0.025*math.sin(8*th+0.3))
def ring(rfun, n, z=None):
    pts = []
    for i in range(n):
        th = 2*math.pi*i/n
        r = rfun(th)
        p = [round(C + r*math.cos(th), 1), round(C + r*math.sin(th), 1)]
        if z is not None: p.append(round(z(th), 1))
        pts.append(p)
    return pts
rim_r = lambda th: 950 * (1 + 0.06*math.sin(2*th+0.5))
rim_z = lambda th: 1300 + 90*math.cos(th - 0.8) - 40*math.cos(3*th)
rim = ring(rim_r, 32, rim_z); rim.append(rim[0])
ops = [{
  "op": "fit",
  "contours": [
    {"points": [[20,20],[10220,20],[10220,10220],[20,10220]], "elevation": -420, "closed": True},
    {"points": ring(R, 72), "elevation": 0, "closed": True},
    {"points": ring(lambda th: R(th) - 110, 72), "elevation": 5, "closed": True},
    {"points": ring(lambda th: 0.72*rim_r(th), 28), "elevation": 980, "closed": True},
  ],
  "ridges": [{"points": rim}],
  "noise": {"amplitude": 70, "wavelength": 700, "fade": 3500, "octaves": 4, "type": "fbm", "orient_strength": 0.5},
}]
# Radial ravines: fifteen, their angles jittered (+-5 degrees, seeded) and their widths and bends
# drawn, so the fan is not an even sun-ray pattern. (Irregular spacings of 17-34 degrees put
# neighbours within a ravine's width of each other near the top: shallow, narrow ravines there.)
rng = random.Random(31)
rav = [(a + rng.uniform(-5, 5), f, d, rng.uniform(760, 900), rng.uniform(2, 8))
       for a, f, d in ((8,0.05,170),(31,0.35,150),(52,0.08,180),(75,0.4,140),(98,0.05,160),(121,0.3,150),(146,0.06,190),
                       (170,0.38,150),(193,0.07,170),(216,0.33,150),(240,0.05,180),(263,0.4,140),(286,0.06,170),(309,0.35,150),(333,0.05,180))]
for ang, f, dmid, width, bend_deg in rav:
    th = math.radians(ang)
    r0 = rim_r(th) + 120 + f*(R(th) - rim_r(th))
    bend = math.radians(bend_deg)  # a slight curve, either way
    # the exit 340 m inside the coast where the ravine meets it (at its bent end's angle: measured
    # at a fixed 9 degrees, two exits bent the other way ended below the sea, as lakes)
    r2 = min(R(th + 1.5*bend + a) for a in (-0.05, 0, 0.05)) - 340
    r1 = 0.5*(r0 + r2) + 0.1*(r2 - r0)
    pts = []
    for r, dth, z in ((r0, 0, 25), (r1, bend, dmid), (r2, 1.5*bend, 3)):
        pts.append([round(C + r*math.cos(th+dth), 1), round(C + r*math.sin(th+dth), 1), round(z, 1)])
    ops.append({"op": "ravine", "points": pts, "width": round(width), "exit": 200, "cut_rims": False, "smooth": True})
# The caldera's inner wall in lava beds (strata: hard flows as cliff bands, soft tuff and scoria
# as ledges), inside the rim only: over the rim the upper outer cone, steeper than min_slope there,
# took rings of terraces like a ziggurat.
ops.append({"op": "strata", "comment": "lava beds in the caldera wall", "polygon": ring(lambda th: 0.97*rim_r(th), 48),
            "falloff": 40, "top": 1400, "bottom": 960, "thickness": 45, "soft_thickness": 25, "jitter": 0.4,
            "contrast": 5, "min_slope": 34, "seed": 3})
# Gullies: stream-power drainage on the land (D-infinity routing, so they follow the fall line of
# the cone instead of D8's straight runs), branching into the ravines and the caldera's inner wall.
ops.append({"op": "drainage", "comment": "gullies on the cone", "polygon": ring(lambda th: R(th) - 260, 72),
            "falloff": 150, "depth": 200, "n": 1.5, "max_depth": 45, "threshold": 15000, "channel_width": 40,
            "smooth": 2})
doc = {"description": "Volcanic island (paper figures 10 and 18): a cone fitted to a coast at 0 m, a beach berm at +5 m 110 m inland, a caldera rim ridge at 1210-1390 m and a caldera floor at 980 m, the seabed at -420 m; fBm noise (70 m, 700 m) fading from the rim and dragged radially (gullies down the fall line); radial ravines at irregular spacing (14-34 degrees apart), smoothed, 600-950 m wide, bending either way, deepening downslope (25 m at the top, 130-200 m on the mid-slopes) and fading to 3 m 320 m inland, whose exits die out at the beach; gullies carved on the land by a stream-power drainage op (D-infinity routing).",
       "base": "flat:1025x1025@10", "units": "m", "seed": 5, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
