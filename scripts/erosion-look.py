#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Erosion look figures (docs/erosion.md): erodes a DEM with the default parameters, prints the
measures an artist's complaints translate to, and draws before / after hillshades and the bed change.

  scripts/erosion-look.py DEM OUT.png [extra erode options...]
  scripts/erosion-look.py nature DEM [--steps N] [--preset P] [--set key=value] [--png OUT.png]

The second form runs what the studio's "Erode all" commits (an edit script {"op": "erode", "steps": N})
on a projected DEM and prints the figures of docs/erosion.md, "Does it read as nature": cells changed
> 1 m on hillslopes vs channels, levee rims beside channels, incised channel width vs drainage area
(and its log-log exponent), the slope where the deposits lie. Needs rasterio too.

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


# ---- "nature" measures (docs/erosion.md, "Does it read as nature"): what the studio's "Erode all" does
# to a real DEM, from the before / after rasters.

def read_rio(path):
    """Float64 array and metric cell size (m) of a projected raster (rasterio)."""
    import rasterio

    with rasterio.open(path) as ds:
        z = ds.read(1).astype(np.float64)
        cx, cy = abs(ds.transform.a), abs(ds.transform.e)
        if ds.crs is not None and ds.crs.is_geographic:
            raise SystemExit(f"{path}: geographic CRS; warp it to metres first (gdalwarp -t_srs EPSG:326xx -tr 30 30)")
        if ds.nodata is not None and np.any(z == ds.nodata):
            raise SystemExit(f"{path}: has nodata cells; crop them away")
    return z, cx, cy


def run_edit(dem, ops, out):
    """`terracl edit DEM --script S -o OUT` with S = {"operations": ops}: what the studio replays."""
    import json

    script = out + ".json"
    with open(script, "w") as f:
        json.dump({"operations": ops}, f)
    subprocess.run([T, "-q", "edit", dem, "--script", script, "-o", out], check=True)


def incised_width(dz, y, x, thr, cx, cy):
    """Width (m) of the incised cross-section through (y, x): along each of the 4 axes (x, y, both
    diagonals) the run of cells incised at least `thr` m; the narrowest of the 4 is the cross-section
    (the others run along the channel)."""
    h, w = dz.shape
    best = np.inf
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        n = 1
        for s in (-1, 1):
            k = 1
            while 0 <= y + s * k * dy < h and 0 <= x + s * k * dx < w and dz[y + s * k * dy, x + s * k * dx] >= thr:
                k += 1
            n += k - 1
        best = min(best, n * np.hypot(dx * cx, dy * cy))
    return best


def nature(z0, z1, area, cx, cy, hill_area=2e4, channel_area=1e5, out=print, filled=None):
    """Figures (a)-(d) of the brief: changes on hillslopes vs channels, levee rims, channel width vs
    drainage area, where the deposits go. `area`: D8 drainage area (m^2) of the input."""
    from scipy import ndimage

    d = z1 - z0
    res = {}
    hill, chan = area < hill_area, area >= channel_area
    res["changed_all"] = 100.0 * np.mean(np.abs(d) > 1)
    res["changed_hill"] = 100.0 * np.mean(np.abs(d[hill]) > 1)
    res["changed_channel"] = 100.0 * np.mean(np.abs(d[chan]) > 1)
    res["lowered_hill"] = 100.0 * np.mean(d[hill] < -1)
    res["raised_hill"] = 100.0 * np.mean(d[hill] > 1)
    res["mean_abs_hill"] = float(np.mean(np.abs(d[hill])))
    res["mean_abs_channel"] = float(np.mean(np.abs(d[chan])))
    out(f"  (a) cells changed > 1 m: {res['changed_all']:.1f} % of all; hillslopes (area < {hill_area / 1e6:g} km2, "
        f"{100 * hill.mean():.0f} % of cells) {res['changed_hill']:.1f} % (lowered {res['lowered_hill']:.1f} %, raised "
        f"{res['raised_hill']:.1f} %), mean |change| {res['mean_abs_hill']:.2f} m; "
        f"channels (area >= {channel_area / 1e6:g} km2, {100 * chan.mean():.1f} %) {res['changed_channel']:.1f} %, "
        f"mean |change| {res['mean_abs_channel']:.2f} m")
    # (b) levee rims: cells 1-3 cells beside a channel (input channels, and cells the run incised > 1 m),
    # not channel cells themselves, raised above their input elevation.
    chan_now = chan | (d < -1.0)
    dist = ndimage.distance_transform_edt(~chan_now)
    ring = (dist >= 1) & (dist <= 3.01)
    if filled is not None:  # a closed depression of the input that fills is a lake floor, not a bank
        lake = filled - z0 > 0.5
        res["lake_fill_cells"] = int(np.sum(lake & (d > 0.5)))
        ring &= ~lake
    raised = d[ring]
    res["rim_cells_05"] = int(np.sum(raised > 0.5))
    res["rim_share_05"] = 100.0 * np.mean(raised > 0.5)
    res["rim_cells_1"] = int(np.sum(raised > 1.0))
    res["rim_max"] = float(raised.max()) if raised.size else 0.0
    res["rim_p99"] = float(np.percentile(raised, 99)) if raised.size else 0.0
    out(f"  (b) levee rims ({raised.size} cells 1-3 cells beside a channel, outside the input's depressions): {res['rim_cells_05']} raised > 0.5 m "
        f"({res['rim_share_05']:.2f} %), {res['rim_cells_1']} > 1 m, 99th pct {res['rim_p99']:+.2f} m, max "
        f"{res['rim_max']:+.2f} m")
    # (c) incised cross-section width vs drainage area: at channel cells incised >= 1 m, the width of
    # the run incised at least half as deep as the centre (and >= 0.25 m).
    inc = -d
    ys, xs = np.nonzero(chan & (inc >= 1.0))
    widths = np.array([incised_width(inc, y, x, max(0.25, 0.5 * inc[y, x]), cx, cy) for y, x in zip(ys, xs)])
    areas = area[ys, xs]
    res["width_exponent"] = float("nan")
    if widths.size >= 20:
        edges = 10 ** np.arange(np.floor(np.log10(channel_area) * 2) / 2, np.log10(areas.max()) + 0.5, 0.5)
        rows, bx, by = [], [], []
        for lo, hi in zip(edges[:-1], edges[1:]):
            m = (areas >= lo) & (areas < hi)
            if m.sum() >= 5:
                med = float(np.median(widths[m]))
                rows.append(f"{lo / 1e6:g}-{hi / 1e6:g} km2: {med:.0f} m (n={m.sum()})")
                bx.append(np.log10(np.sqrt(lo * hi)))
                by.append(np.log10(med))
        slope = np.polyfit(np.log10(areas), np.log10(widths), 1)[0]
        res["width_exponent"] = float(slope)
        res["width_exponent_binned"] = float(np.polyfit(bx, by, 1)[0]) if len(bx) >= 2 else float("nan")
        out(f"  (c) incised width vs drainage area ({widths.size} sections): " + "; ".join(rows))
        out(f"      log-log exponent {slope:.3f} (all sections), {res['width_exponent_binned']:.3f} (bin medians)")
    else:
        out(f"  (c) too few incised channel sections ({widths.size})")
    # (d) deposition > 0.5 m: slope of the input there vs where it eroded, share on low ground
    s0 = slope_deg(z0, cx, cy)
    dep, ero = d > 0.5, d < -0.5
    vol = np.where(dep, d, 0.0)
    res["dep_cells"] = int(dep.sum())
    res["dep_slope"] = float(s0[dep].mean()) if dep.any() else float("nan")
    res["ero_slope"] = float(s0[ero].mean()) if ero.any() else float("nan")
    # valley floors: channel cells; slope breaks: cells much flatter than the ground 3 cells upslope
    smax_up = ndimage.maximum_filter(s0, size=7)
    low = (s0 < 10) & (chan | (smax_up - s0 > 10))
    res["dep_low_share"] = 100.0 * vol[low].sum() / max(vol.sum(), 1e-12)
    res["dep_flat_share"] = 100.0 * vol[s0 < 10].sum() / max(vol.sum(), 1e-12)
    out(f"  (d) deposition > 0.5 m on {res['dep_cells']} cells: mean input slope {res['dep_slope']:.1f} deg (eroded "
        f"cells: {res['ero_slope']:.1f} deg); {res['dep_flat_share']:.0f} % of the deposited volume on ground < 10 deg, "
        f"{res['dep_low_share']:.0f} % on valley floors / slope breaks")
    return res


def nature_main(argv):
    import argparse
    import json

    ap = argparse.ArgumentParser(prog="erosion-look.py nature", description="Figures of an 'Erode all' run on a real DEM")
    ap.add_argument("dem", help="projected DEM in metres (no nodata)")
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--preset", default="default")
    ap.add_argument("--set", action="append", default=[], help="extra erode key=value (JSON value)")
    ap.add_argument("--after", help="measure this raster instead of running the erosion")
    ap.add_argument("--png", help="write before / after hillshades and the change here")
    ap.add_argument("--keep", help="keep the after raster here")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        before = os.path.join(tmp, "before.tif")
        run_edit(a.dem, [], before)  # the reconstruction of the DEM itself: what erosion starts from
        after = a.after
        op = {"op": "erode", "steps": a.steps, "preset": a.preset}
        for kv in a.set:
            k, v = kv.split("=", 1)
            op[k] = json.loads(v)
        if not after:
            after = a.keep or os.path.join(tmp, "after.tif")
            run_edit(a.dem, [op], after)
        acc = os.path.join(tmp, "area.tif")
        subprocess.run([T, "-q", "drainage", before, "-o", acc], check=True)
        fill = os.path.join(tmp, "filled.tif")
        subprocess.run([T, "-q", "fill_depressions", before, "-o", fill], check=True)
        z0, cx, cy = read_rio(before)
        z1, _, _ = read_rio(after)
        area, _, _ = read_rio(acc)
        filled, _, _ = read_rio(fill)
        print(f"{os.path.basename(a.dem)}: {z0.shape[1]} x {z0.shape[0]} cells of {cx:.1f} x {cy:.1f} m; "
              f"{json.dumps(op) if not a.after else a.after}")
        res = nature(z0, z1, area, cx, cy, filled=filled)
        print("  json " + json.dumps({k: round(v, 4) for k, v in res.items()}))
        if a.png:
            shades = []
            for src in (before, after):
                png = os.path.join(tmp, os.path.basename(src) + ".png")
                subprocess.run([T, "-q", "render", src, "-o", png], check=True)
                shades.append(plt.imread(png))
            d = z1 - z0
            lim = max(np.percentile(np.abs(d), 99), 1e-6)
            h, w = z0.shape
            fig, ax = plt.subplots(1, 3, figsize=(3 * w / 100, h / 100 + 0.4), dpi=100)
            for ax_, img, title in zip(ax, shades + [None], ["before", "after", "change (dark = eroded)"]):
                ax_.imshow(d if img is None else img, cmap="gray" if img is None else None,
                           vmin=-lim if img is None else None, vmax=lim if img is None else None)
                ax_.set_title(title)
                ax_.axis("off")
            fig.tight_layout()
            fig.savefig(a.png)
            print(f"  wrote {a.png}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "nature":
        nature_main(sys.argv[2:])
    else:
        main()
