#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Fine-to-coarse relief of a terrain (or of the part an edit changed): the RMS of a difference of
Gaussians at 2-4 cells over the same at 8-16 cells, on sloping cells (>= 5 degrees); and the
finest/coarse relief, the RMS of the relief below one cell's Gaussian (the texture finer than about
4 cells) over the same 8-16-cell band (docs/authoring.md, "Realism of a stroke").

  scripts/landform-relief.py OUT.tif [--base BASE.tif] [--min-change M]

With --base, the edit's change (terrain - base) is measured on the cells it moved by more than M
metres (default 1): the new landform itself, without the DEM's own texture.
"""
import argparse
import sys

import numpy as np
from osgeo import gdal


def gaussian_filter(z, sigma):
    """Separable Gaussian blur (reflecting edges), numpy only."""
    r = int(4 * sigma + 0.5)
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()
    p = np.pad(z, r, mode="reflect")
    p = np.apply_along_axis(lambda v: np.convolve(v, k, mode="valid"), 1, p)
    return np.apply_along_axis(lambda v: np.convolve(v, k, mode="valid"), 0, p)


def read(path):
    ds = gdal.Open(path)
    if ds is None:
        sys.exit(f"{path}: cannot open")
    z = ds.GetRasterBand(1).ReadAsArray().astype(np.float64)
    gt = ds.GetGeoTransform()
    cx, cy = abs(gt[1]), abs(gt[5])
    if ds.GetSpatialRef() is not None and ds.GetSpatialRef().IsGeographic():
        lat = gt[3] + gt[5] * ds.RasterYSize / 2
        cx, cy = cx * 111320 * np.cos(np.radians(lat)), cy * 110540
    return z, cx, cy


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("terrain")
    ap.add_argument("--base")
    ap.add_argument("--min-change", type=float, default=1.0)
    a = ap.parse_args()
    z, cx, cy = read(a.terrain)
    mask = np.ones_like(z, bool)
    gy, gx = np.gradient(z, cy, cx)
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    if a.base:
        b, _, _ = read(a.base)
        if b.shape != z.shape:
            sys.exit(f"{a.base}: size {b.shape} differs from {a.terrain}'s {z.shape}")
        mask = np.abs(z - b) > a.min_change
        z = z - b
    mask &= slope >= 5
    # Away from the grid's edge (the filters' reach).
    m = 32
    mask[:m, :] = mask[-m:, :] = False
    mask[:, :m] = mask[:, -m:] = False
    if mask.sum() < 100:
        sys.exit("fewer than 100 sloping cells to measure")
    fine = gaussian_filter(z, 2) - gaussian_filter(z, 4)
    coarse = gaussian_filter(z, 8) - gaussian_filter(z, 16)
    finest = z - gaussian_filter(z, 1)
    rc = np.sqrt(np.mean(coarse[mask] ** 2))
    r = np.sqrt(np.mean(fine[mask] ** 2)) / rc
    t = np.sqrt(np.mean(finest[mask] ** 2)) / rc
    print(f"{a.terrain}: fine/coarse relief {r:.3f}, finest/coarse {t:.3f} over {int(mask.sum())} cells "
          f"(cell {cx:.1f} x {cy:.1f} m)")


if __name__ == "__main__":
    main()
