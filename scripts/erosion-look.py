#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Erosion look figures (docs/erosion.md): erodes a DEM with the default parameters, prints the
measures an artist's complaints translate to, and draws before / after hillshades and the bed change.

  scripts/erosion-look.py DEM OUT.png [extra erode options...]

Measures: mean elevation change (0 when the material is kept), mean |change|, share of cells at
33-37 deg (a pile-up there means thermal erosion planed slopes into talus facets), share of cells
flatter than 1 deg (flat ribbons), the ratio of the RMS Laplacian (crinkle: > 1 means rougher), the
share of one-cell curvature flips (one-cell incised crinkles), the channel floor widths (share of
carved channel cross-sections whose floor is a one-cell V notch), the valley ribbon (the settled
load raising the valley floors flat: see ribbon() and wide_floor()) and the slope histogram.
Needs build/bin/terracl, gdal-bin, python3-numpy, python3-scipy, python3-matplotlib.
"""
import os
import re
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
T = os.environ.get("TERRACL", os.path.join(ROOT, "build", "bin", "terracl"))


def read(path, tmp):
    """Float32 array and metric cell size (m) of a raster, through gdal_translate and terracl info."""
    raw = os.path.join(tmp, os.path.basename(path) + ".bin")
    subprocess.run(["gdal_translate", "-q", "-of", "ENVI", "-ot", "Float32", path, raw], check=True)
    info = subprocess.run([T, "info", path], check=True, capture_output=True, text=True).stdout
    size = re.search(r"size:\s+(\d+) x (\d+)", info)
    cell = re.search(r"cell size:\s+([\d.]+) m x ([\d.]+) m", info)
    w, h = int(size.group(1)), int(size.group(2))
    z = np.fromfile(raw, dtype=np.float32).reshape(h, w).astype(np.float64)
    return z, float(cell.group(1)), float(cell.group(2))


def slope_deg(z, cx, cy):
    gy, gx = np.gradient(z, cy, cx)
    return np.degrees(np.arctan(np.hypot(gx, gy)))


def laplacian_rms(z, cx, cy):
    lap = (z[1:-1, 2:] - 2 * z[1:-1, 1:-1] + z[1:-1, :-2]) / cx**2 + (z[2:, 1:-1] - 2 * z[1:-1, 1:-1] + z[:-2, 1:-1]) / cy**2
    return float(np.sqrt(np.mean(lap**2)))


def one_cell_crinkle(z):
    """Share (%) of interior cells whose Laplacian has the opposite sign of both neighbours along x or
    along y: a curvature that flips every cell, the one-cell incised channels and ridges of a crinkled
    bed. A smooth surface sampled finer than its features has next to none."""
    lap = z[1:-1, 2:] - 2 * z[1:-1, 1:-1] + z[1:-1, :-2] + z[2:, 1:-1] - 2 * z[1:-1, 1:-1] + z[:-2, 1:-1]
    c = lap[1:-1, 1:-1]
    fx = (c * lap[1:-1, :-2] < 0) & (c * lap[1:-1, 2:] < 0)
    fy = (c * lap[:-2, 1:-1] < 0) & (c * lap[2:, 1:-1] < 0)
    return 100.0 * float(np.mean(fx | fy))


def channel_floor_widths(z0, z1):
    """Cross-section floor widths (cells) of the channels carved into z1, as test
    ErosionScale.ChannelsAreSeveralCellsWideAtTenMetres measures them: at every cell that is a strict
    minimum of the bed across x (or y) and at least 1 m below the input, the run of cells along that
    axis whose concave-up second difference is at least half the centre's (a V notch: 1 cell)."""
    h, w = z1.shape
    widths = []
    for dy, dx in ((0, 1), (1, 0)):
        c2 = np.zeros_like(z1)
        c2[1:-1, 1:-1] = z1[1 - dy:h - 1 - dy, 1 - dx:w - 1 - dx] + z1[1 + dy:h - 1 + dy, 1 + dx:w - 1 + dx] - 2 * z1[1:-1, 1:-1]
        c = z1[1:-1, 1:-1]
        m = (c < z1[1 - dy:h - 1 - dy, 1 - dx:w - 1 - dx]) & (c < z1[1 + dy:h - 1 + dy, 1 + dx:w - 1 + dx]) & (z0[1:-1, 1:-1] - c >= 1.0)
        for y, x in zip(*np.nonzero(m)):
            y, x = y + 1, x + 1
            half, n = 0.5 * c2[y, x], 1
            for s in (-1, 1):
                k = 1
                while 1 <= y + s * k * dy < h - 1 and 1 <= x + s * k * dx < w - 1 and c2[y + s * k * dy, x + s * k * dx] >= half:
                    k += 1
                n += k - 1
            widths.append(n)
    return np.array(widths)


def d8_area(z, cx, cy):
    """Contributing area (m^2) of D8 flow on z, highest cell first (flats and pits keep their water)."""
    h, w = z.shape
    acc = np.full(z.size, cx * cy)
    flat = z.ravel()
    zp = np.pad(z, 1, constant_values=np.inf)
    best = np.zeros(z.shape)
    target = np.full(z.shape, -1, dtype=np.int64)
    yy, xx = np.mgrid[0:h, 0:w]
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy == 0 and dx == 0:
                continue
            drop = (z - zp[1 + dy:h + 1 + dy, 1 + dx:w + 1 + dx]) / np.hypot(dx * cx, dy * cy)
            better = drop > best
            best = np.where(better, drop, best)
            target = np.where(better, (yy + dy) * w + (xx + dx), target)
    t = target.ravel()
    for i in np.argsort(-flat, kind="stable"):
        if t[i] >= 0:
            acc[t[i]] += acc[i]
    return acc.reshape(h, w)


def ribbon(z0, z1, cx, cy, min_area=0.5e6):
    """The valley ribbon: on the valley floors (D8 contributing area of the input >= min_area m^2),
    the share (%) of cells raised more than 1 m above the input, the share that is flatter than 1 deg
    after the run and was not before, and the 95th percentile of the raise (m). A carved valley lies
    at or below its input floor; the suspended load settled in place lifts it into a flat band."""
    valley = d8_area(z0, cx, cy) >= min_area
    d = (z1 - z0)[valley]
    s0, s1 = slope_deg(z0, cx, cy)[valley], slope_deg(z1, cx, cy)[valley]
    return (100.0 * float(np.mean(d > 1.0)), 100.0 * float(np.mean((s1 < 1) & (s0 >= 1))),
            float(np.percentile(d, 95)), int(valley.sum()))


def wide_floor(z0, z1, cx, cy, min_area=0.5e6, reach=300.0, above=10.0):
    """The valley ribbon over the whole valley floor, not only its one-cell D8 thread: cells within
    `reach` m of a thread cell (D8 area >= min_area on the input) and at most `above` m higher than
    it on the input. A fill beside the carved thread escapes ribbon(); here it counts. Returns the
    share (%) raised more than 1 m, the 95th percentile of the raise (m) and the cell count."""
    from scipy import ndimage

    thread = d8_area(z0, cx, cy) >= min_area
    dist, idx = ndimage.distance_transform_edt(~thread, sampling=(cy, cx), return_indices=True)
    floor = (dist <= reach) & (z0 - z0[idx[0], idx[1]] <= above)
    d = (z1 - z0)[floor]
    return 100.0 * float(np.mean(d > 1.0)), float(np.percentile(d, 95)), int(floor.sum())


def main():
    dem, out = sys.argv[1], sys.argv[2]
    extra = sys.argv[3:]
    with tempfile.TemporaryDirectory() as tmp:
        eroded = os.path.join(tmp, "eroded.tif")
        subprocess.run([T, "-q", "erode", dem, "-o", eroded] + extra, check=True)
        z0, cx, cy = read(dem, tmp)
        z1, _, _ = read(eroded, tmp)
        d = z1 - z0
        s0, s1 = slope_deg(z0, cx, cy), slope_deg(z1, cx, cy)
        band = lambda s: 100.0 * np.mean((s >= 33) & (s <= 37))
        flat = lambda s: 100.0 * np.mean(s < 1)
        print(f"{os.path.basename(dem)}: {z0.shape[1]} x {z0.shape[0]} cells of {cx:.1f} x {cy:.1f} m; erode {' '.join(extra)}")
        print(f"  mean change {d.mean():+.3f} m, mean |change| {np.abs(d).mean():.2f} m, 99th pct |change| "
              f"{np.percentile(np.abs(d), 99):.1f} m")
        print(f"  slope 33-37 deg: {band(s0):.2f} % -> {band(s1):.2f} %; flatter than 1 deg: {flat(s0):.2f} % -> "
              f"{flat(s1):.2f} %; mean slope {s0.mean():.2f} -> {s1.mean():.2f} deg")
        print(f"  RMS Laplacian x{laplacian_rms(z1, cx, cy) / laplacian_rms(z0, cx, cy):.2f}; one-cell curvature "
              f"flips {one_cell_crinkle(z0):.2f} % -> {one_cell_crinkle(z1):.2f} %")
        fw = channel_floor_widths(z0, z1)
        if fw.size:
            print(f"  channel floors: {fw.size} cross-sections, {100.0 * np.mean(fw == 1):.1f} % one cell wide, mean "
                  f"{fw.mean():.2f} cells")
        raised, flattened, p95, n = ribbon(z0, z1, cx, cy)
        print(f"  valley ribbon ({n} valley-floor cells, area >= 0.5 km2): {raised:.1f} % raised > 1 m, "
              f"{flattened:.1f} % newly flatter than 1 deg, 95th pct raise {p95:+.1f} m")
        raised, p95, n = wide_floor(z0, z1, cx, cy)
        print(f"  valley floors, whole width ({n} cells within 300 m of those and <= 10 m above them): {raised:.1f} % "
              f"raised > 1 m, 95th pct raise {p95:+.1f} m")
        hist0, edges = np.histogram(s0, bins=np.arange(0, 91, 5))
        hist1, _ = np.histogram(s1, bins=edges)
        print("  slope histogram (% of cells per 5 deg, before -> after): " + ", ".join(
            f"{int(a)}-{int(a) + 5}: {100.0 * h0 / s0.size:.1f}->{100.0 * h1 / s1.size:.1f}"
            for a, h0, h1 in zip(edges[:-1], hist0, hist1) if h0 or h1))
        shades = []
        for src in (dem, eroded):
            png = os.path.join(tmp, os.path.basename(src) + ".png")
            subprocess.run([T, "-q", "render", src, "-o", png], check=True)
            shades.append(plt.imread(png))
        lim = max(np.percentile(np.abs(d), 99), 1e-6)
        aspect = z0.shape[0] * cy / (z0.shape[1] * cx)
        fig, ax = plt.subplots(1, 3, figsize=(15, 5 * aspect + 0.6), dpi=100)
        for a, img, title in zip(ax, shades + [None], ["before", "after", "bed change (dark = eroded)"]):
            if img is None:
                a.imshow(d, cmap="gray", vmin=-lim, vmax=lim, aspect=cy / cx)
            else:
                a.imshow(img, aspect=cy / cx)
            a.set_title(title)
            a.axis("off")
        fig.tight_layout()
        fig.savefig(out)
        print(f"  wrote {out}")


if __name__ == "__main__":
    main()
