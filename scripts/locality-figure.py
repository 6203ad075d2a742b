#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Before / after / difference of an edit on a real DEM (docs/authoring.md, "Locality").

usage: scripts/locality-figure.py BASE EDITED OUT.png X0,Y0,X1,Y1 [VMIN,VMAX]
BASE, EDITED: rasters GDAL reads (the edit's base and `terracl edit -o` output); the box is the
window shown, in cells. The difference panel outlines the cells that changed at all.
Needs python3-gdal, python3-matplotlib (Debian).
"""
import sys

import matplotlib
import numpy as np
from osgeo import gdal

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import LightSource  # noqa: E402


def read(path):
    ds = gdal.Open(path)
    a = ds.GetRasterBand(1).ReadAsArray().astype(float)
    return a, ds.GetGeoTransform()


def main():
    base, gt = read(sys.argv[1])
    edited, _ = read(sys.argv[2])
    x0, y0, x1, y1 = [int(v) for v in sys.argv[4].split(",")]
    vmin, vmax = [float(v) for v in sys.argv[5].split(",")] if len(sys.argv) > 5 else (np.nanmin(base), np.nanmax(edited))
    # Metric cell size: degrees -> metres at the window's latitude for geographic rasters.
    dx, dy = abs(gt[1]), abs(gt[5])
    if dx < 0.1:
        lat = np.radians(gt[3] + (y0 + y1) / 2 * gt[5])
        dx, dy = dx * 111320 * np.cos(lat), dy * 110574
    ls = LightSource(azdeg=315, altdeg=45)
    shade = lambda a: ls.shade(a, cmap=plt.cm.terrain, vert_exag=3, dx=dx, dy=dy, blend_mode="soft", vmin=vmin, vmax=vmax)
    crop = lambda a: a[y0:y1, x0:x1]
    d_all = edited - base
    fig, ax = plt.subplots(1, 3, figsize=(18, 6.5))
    ax[0].imshow(shade(crop(base)))
    ax[0].set_title("before")
    ax[1].imshow(shade(crop(edited)))
    ax[1].set_title("after")
    d = crop(d_all)
    m = max(np.abs(d).max(), 1e-9)
    im = ax[2].imshow(d, cmap="RdBu_r", vmin=-m, vmax=m)
    ax[2].contour(d != 0, levels=[0.5], colors="k", linewidths=0.6)
    ax[2].set_title(f"after - before (m); whole raster: {np.count_nonzero(d_all)} cells changed, "
                    f"median |change| {np.median(np.abs(d_all)):.2f} m")
    plt.colorbar(im, ax=ax[2], shrink=0.8)
    for a in ax:
        a.set_xticks([])
        a.set_yticks([])
    plt.tight_layout()
    plt.savefig(sys.argv[3], dpi=60)


if __name__ == "__main__":
    main()
