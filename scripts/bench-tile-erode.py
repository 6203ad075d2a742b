#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Tiled vs untiled erosion (and render) of an SRTM tile (docs/scale.md, "Erosion").

Runs `terracl erode DEM --steps S` untiled and with --tile T (halo: one cell per sub-step, plus
--halo), and prints wall time, CPU time, peak RSS, the difference of the tiled to the untiled
output (max and mean |dz|, cells over 1 cm) and the seam metric of both (mean squared second
difference on the rows/columns beside tile borders over the same elsewhere; tile_seam_ratio in
host/src/tile/seam.cpp). Writes the hillshades of both runs and of their difference as PNGs.

  scripts/bench-tile-erode.py [--dem data/dem/N44W072.hgt] [--steps 100] [--tile 512] [--halo 0]
"""
import argparse, os, subprocess, sys

import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("--dem", default="data/dem/N44W072.hgt")
ap.add_argument("--steps", type=int, default=100)
ap.add_argument("--tile", type=int, default=512)
ap.add_argument("--halo", default="")
ap.add_argument("--terracl", default="build/bin/terracl")
ap.add_argument("--out", default="/tmp/terracl-bench-tile-erode")
a = ap.parse_args()
os.makedirs(a.out, exist_ok=True)


def run(args):
    cmd = ["/usr/bin/time", "-f", "%e %U %S %M", a.terracl, "-q"] + args
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stdout}{r.stderr}")
    wall, user, system, rss_kb = r.stderr.strip().splitlines()[-1].split()
    return float(wall), float(user) + float(system), int(rss_kb) / 1024


def load(f):
    raw = f"{a.out}/_load.bin"
    subprocess.run(["gdal_translate", "-q", "-of", "ENVI", "-ot", "Float32", f, raw], check=True)
    info = subprocess.run(["gdalinfo", f], capture_output=True, text=True).stdout
    w = int([l for l in info.splitlines() if l.startswith("Size is")][0].split()[2].rstrip(","))
    return np.fromfile(raw, np.float32).reshape(-1, w).astype(np.float64)


def seam_ratio(z, tile):
    """As tile_seam_ratio (host/src/tile/seam.cpp)."""
    dx = z[:, :-2] - 2 * z[:, 1:-1] + z[:, 2:]  # centred at x = 1 .. w-2
    dy = z[:-2, :] - 2 * z[1:-1, :] + z[2:, :]
    bx = np.arange(1, z.shape[1] - 1)
    by = np.arange(1, z.shape[0] - 1)
    bx = (bx % tile == 0) | (bx % tile == tile - 1)
    by = (by % tile == 0) | (by % tile == tile - 1)
    border = np.concatenate([(dx[:, bx] ** 2).ravel(), (dy[by, :] ** 2).ravel()])
    other = np.concatenate([(dx[:, ~bx] ** 2).ravel(), (dy[~by, :] ** 2).ravel()])
    return border.mean() / other.mean()


halo = ["--halo", a.halo] if a.halo else []
rows = []
u = f"{a.out}/untiled.tif"
t = f"{a.out}/tiled.tif"
rows.append(("untiled", "", run(["erode", a.dem, "-o", u, "--steps", str(a.steps)])))
opts = ["--tile", str(a.tile)] + halo
rows.append(("tiled", " ".join(opts), run(["erode", a.dem, "-o", t, "--steps", str(a.steps)] + opts)))
zu, zt, z0 = load(u), load(t), load(a.dem)
d = np.abs(zu - zt)
print(f"erode {a.dem} --steps {a.steps}: {zu.shape[1]} x {zu.shape[0]} cells, erosion changed up to "
      f"{np.abs(zu - z0).max():.1f} m (mean {np.abs(zu - z0).mean():.3f} m)")
print("| run | options | wall s | CPU s | peak RSS MiB | seam ratio |")
print("|---|---|---|---|---|---|")
for (name, o, (wall, cpu, rss)), z in zip(rows, (zu, zt)):
    print(f"| {name} | {o or '(untiled)'} | {wall:.1f} | {cpu:.1f} | {rss:.0f} | {seam_ratio(z, a.tile):.4f} |")
print(f"tiled - untiled: max {d.max():.3g} m, mean {d.mean():.3g} m, cells over 1 cm: {(d > 0.01).sum()} of {d.size}")
for name, f in (("untiled", u), ("tiled", t)):
    run(["render", f, "-o", f"{a.out}/{name}_hillshade.png"])
print(f"hillshades: {a.out}/untiled_hillshade.png {a.out}/tiled_hillshade.png")
