#!/usr/bin/env python3
# Writes data/examples/volcanic_island.json (issue 12 gallery): a cone fitted to an irregular coast, a caldera
# rim and floor, a beach berm, fifteen radial ravines. Usage: python3 scripts/gen-volcanic-island.py OUT.json
import json, math, sys
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
    {"points": ring(lambda th: 0.45*rim_r(th), 20), "elevation": 980, "closed": True},
  ],
  "ridges": [{"points": rim}],
  "noise": {"amplitude": 70, "wavelength": 700, "fade": 3500, "octaves": 4, "type": "fbm", "orient_strength": 0.5},
}]
# radial ravines: (angle deg, start radius as fraction of the way rim->coast, mid depth)
rav = [(8,0.05,170),(31,0.35,150),(52,0.08,180),(75,0.4,140),(98,0.05,160),(121,0.3,150),(146,0.06,190),
       (170,0.38,150),(193,0.07,170),(216,0.33,150),(240,0.05,180),(263,0.4,140),(286,0.06,170),(309,0.35,150),(333,0.05,180)]
for ang, f, dmid in rav:
    th = math.radians(ang)
    r0 = rim_r(th) + 120 + f*(R(th) - rim_r(th))
    r2 = R(th + math.radians(9)) - 340
    r1 = 0.5*(r0 + r2) + 0.1*(r2 - r0)
    bend = math.radians(6)  # a slight curve
    pts = []
    for r, dth, z in ((r0, 0, 25), (r1, bend, dmid), (r2, 1.5*bend, 3)):
        pts.append([round(C + r*math.cos(th+dth), 1), round(C + r*math.sin(th+dth), 1), z])
    ops.append({"op": "ravine", "points": pts, "width": 820, "exit": 200, "cut_rims": False, "smooth": True})
doc = {"description": "Volcanic island (paper figures 10 and 18): a cone fitted to a coast at 0 m, a beach berm at +5 m 110 m inland, a caldera rim ridge at 1210-1390 m and a caldera floor at 980 m, the seabed at -420 m; fBm noise (70 m, 700 m) fading from the rim and dragged radially (gullies down the fall line); fifteen radial ravines, smoothed, deepening downslope (25 m at the top, 140-190 m on the mid-slopes) and fading to 3 m 320 m inland, whose exits die out at the beach.",
       "base": "flat:1025x1025@10", "units": "m", "seed": 5, "operations": ops}
json.dump(doc, open(sys.argv[1], "w"), indent=1)
