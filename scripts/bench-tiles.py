#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Tiled vs untiled fill_depressions / D8 drainage on a large raster (docs/scale.md).

Builds an N x N mosaic of the bundled SRTM tile (a VRT of repeated copies, converted to a tiled
GeoTIFF), then runs the job untiled and with --tile, and prints wall time, CPU time, peak RSS and
the GDAL checksums of both outputs (the tests prove them equal bit for bit).

  scripts/bench-tiles.py --size 8192 --tile 2048 [--budget 1G] [--terracl build/bin/terracl]
  scripts/bench-tiles.py --job drainage --size 8192 --tile 2048 [--grass]
  scripts/bench-tiles.py --job drainage --size 4096 --tile 1024 --skip-untiled --ranks 1,2

--job drainage: untiled `read -> drainage` of the raw mosaic (the stage fills it with epsilon
itself) against the tiled form: the epsilon fill untiled (it cannot run tiled), then `read ->
drainage` tiled on the filled surface (exact tiled D8, Barnes 2017). --grass also runs GRASS
r.watershed -s (D8) on the filled surface (needs Debian's grass-core, not a CI dependency) and
reports its time and how its accumulation agrees with terracl's, cell for cell.

--ranks 1,2: the tiled run once per rank count, under `mpirun --oversubscribe -n N` for N > 1 (a
build with TERRACL_MPI), each output compared byte for byte with the first (docs/scale.md).
"""
import argparse, os, resource, subprocess, sys, time

ap = argparse.ArgumentParser()
ap.add_argument("--size", type=int, default=8192)
ap.add_argument("--tile", type=int, default=2048)
ap.add_argument("--budget", default="")
ap.add_argument("--terracl", default="build/bin/terracl")
ap.add_argument("--out", default="/tmp/terracl-bench-tiles")
ap.add_argument("--skip-untiled", action="store_true")
ap.add_argument("--job", choices=["fill", "drainage"], default="fill")
ap.add_argument("--grass", action="store_true")
ap.add_argument("--ranks", default="1", help="comma-separated MPI rank counts for the tiled run (1: no mpirun)")
a = ap.parse_args()
if os.geteuid() == 0:  # OpenMPI refuses root (containers) without these
    os.environ.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
    os.environ.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
os.makedirs(a.out, exist_ok=True)
src = os.path.abspath("data/dem/N44W072.hgt")
n = a.size
mosaic = f"{a.out}/mosaic{n}.tif"
if not os.path.exists(mosaic):
    step = 1200
    res = 1.0 / 1200
    sources = []
    for y in range(0, n, step):
        for x in range(0, n, step):
            w, h = min(step, n - x), min(step, n - y)
            sources.append(f"""  <SimpleSource><SourceFilename relativeToVRT="0">{src}</SourceFilename><SourceBand>1</SourceBand>
   <SrcRect xOff="0" yOff="0" xSize="{w}" ySize="{h}"/><DstRect xOff="{x}" yOff="{y}" xSize="{w}" ySize="{h}"/></SimpleSource>""")
    vrt = f"""<VRTDataset rasterXSize="{n}" rasterYSize="{n}">
 <SRS>EPSG:4326</SRS>
 <GeoTransform>-72.0004166666667, {res}, 0, 45.0004166666667, 0, -{res}</GeoTransform>
 <VRTRasterBand dataType="Float32" band="1"><NoDataValue>-32768</NoDataValue>
{chr(10).join(sources)}
 </VRTRasterBand>
</VRTDataset>
"""
    with open(f"{a.out}/mosaic{n}.vrt", "w") as f:
        f.write(vrt)
    subprocess.run(["gdal_translate", "-q", "-co", "TILED=YES", "-co", "COMPRESS=DEFLATE", "-co", "PREDICTOR=3",
                    "-co", "BIGTIFF=IF_SAFER", f"{a.out}/mosaic{n}.vrt", mosaic], check=True)


def timed(cmd):
    r = subprocess.run(["/usr/bin/time", "-f", "%e %U %S %M"] + cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stdout}{r.stderr}")
    wall, user, system, rss_kb = r.stderr.strip().splitlines()[-1].split()
    return float(wall), float(user) + float(system), int(rss_kb) / 1024


def checksum(path):
    chk = subprocess.run(["gdalinfo", "-checksum", path], capture_output=True, text=True).stdout
    return [l.split("=")[1] for l in chk.splitlines() if "Checksum=" in l][0]


def run(name, extra, stages='"fill_depressions"', src=None, ranks=1):
    p = f"{a.out}/{name}.json"
    with open(p, "w") as f:
        f.write(f'["{src or mosaic}", {stages}, "{a.out}/{name}.tif"]\n')
    mpi = ["mpirun", "--oversubscribe", "-n", str(ranks)] if ranks > 1 else []
    wall, cpu, rss = timed(mpi + [a.terracl, "-q", "run", p] + extra)
    label = ' '.join(extra) or '(untiled)'
    if ranks > 1:
        label = f"mpirun -n {ranks}, {label}"
    print(f"| {name} | {label} | {wall:.1f} | {cpu:.1f} | {rss:.0f} | {checksum(f'{a.out}/{name}.tif')} |", flush=True)
    return f"{a.out}/{name}.tif"


def run_ranks(name, extra, stages, src=None):
    """The tiled run once per --ranks count; outputs compared byte for byte (same pipeline file)."""
    import filecmp, shutil
    first = None
    for r in [int(x) for x in a.ranks.split(",")]:
        out = run(name, extra, stages, src, r)
        kept = f"{a.out}/{name}-ranks{r}.tif"
        shutil.move(out, kept)
        if first is None:
            first = kept
        elif not filecmp.cmp(first, kept, shallow=False):
            sys.exit(f"{kept} differs from {first}")
        else:
            print(f"{r} ranks: output byte-identical to {os.path.basename(first)}", flush=True)
    shutil.copy(first, f"{a.out}/{name}.tif")
    return f"{a.out}/{name}.tif"


extra = ["--tile", str(a.tile)] + (["--memory-budget", a.budget] if a.budget else [])
if a.job == "fill":
    print(f"fill_depressions of a {n} x {n} SRTM mosaic ({n * n / 1e6:.0f} M cells, {n * n * 4 / 2**20:.0f} MiB float32)")
    print("| run | options | wall s | CPU s | peak RSS MiB | GDAL checksum |")
    print("|---|---|---|---|---|---|")
    if not a.skip_untiled:
        run("untiled", [])
    run_ranks("tiled", extra, '"fill_depressions"')
    sys.exit(0)

print(f"D8 drainage (m2) of a {n} x {n} SRTM mosaic ({n * n / 1e6:.0f} M cells, {n * n * 4 / 2**20:.0f} MiB float32)")
print("| run | options | wall s | CPU s | peak RSS MiB | GDAL checksum |")
print("|---|---|---|---|---|---|")
if not a.skip_untiled:
    run("drainage-untiled", [], '"drainage"')
filled = run("filled-eps", [], '{"type": "fill_depressions", "epsilon": true}')
tiled = run_ranks("drainage-tiled", extra, '"drainage"', filled)
if not a.skip_untiled:
    # GDAL's checksum rounds floats; compare the bits (block by block, to keep memory small).
    from osgeo import gdal
    ua, ta = gdal.Open(f"{a.out}/drainage-untiled.tif"), gdal.Open(tiled)
    diff = 0
    for y in range(0, n, 1024):
        h = min(1024, n - y)
        u = ua.ReadAsArray(0, y, n, h)
        t = ta.ReadAsArray(0, y, n, h)
        diff += int((u.view("u4") != t.view("u4")).sum())
    print(f"untiled vs tiled drainage: {diff} cells differ in their bits", flush=True)
if not a.grass:
    sys.exit(0)

# GRASS r.watershed -s (single flow direction, D8) on the same filled surface, in a temporary
# location of the mosaic's CRS. Its accumulation counts cells (negative where flow may come from
# outside the region); terracl's in cells for the comparison.
import numpy as np
from osgeo import gdal

cells_tif = run("drainage-tiled-cells", extra, '{"type": "drainage", "units": "cells"}', filled)
acc = f"{a.out}/grass-acc.tif"
script = f"{a.out}/grass.sh"
with open(script, "w") as f:
    f.write(f"""set -e
r.in.gdal -o --quiet input={filled} output=dem
g.region raster=dem
/usr/bin/time -f "%e %U %S %M" -o {a.out}/grass-time.txt r.watershed -s --quiet elevation=dem accumulation=acc drainage=dir memory=2000
r.out.gdal --quiet --overwrite -f input=acc output={acc} type=Float64 createopt=TILED=YES,COMPRESS=DEFLATE
r.out.gdal --quiet --overwrite -f input=dir output={a.out}/grass-dir.tif type=Int16
""")
crs = "EPSG:4326"
r = subprocess.run(["grass", "--tmp-location", crs, "--exec", "bash", script], capture_output=True, text=True)
if r.returncode != 0:
    sys.exit(f"grass failed:\n{r.stdout}{r.stderr}")
wall, user, system, rss_kb = open(f"{a.out}/grass-time.txt").read().split()
print(f"| GRASS r.watershed -s | on filled-eps | {float(wall):.1f} | {float(user) + float(system):.1f} | {int(rss_kb) / 1024:.0f} | |")
g = np.abs(gdal.Open(acc).ReadAsArray().astype(np.float64))
t = gdal.Open(cells_tif).ReadAsArray().astype(np.float64)
ok = np.isfinite(t) & np.isfinite(g)
same = np.mean(g[ok] == t[ok])
big = ok & (t >= 1000)
rel = np.abs(g[big] - t[big]) / t[big]
print(f"agreement with GRASS on {ok.sum()} cells: {100 * same:.2f} % equal counts; cells draining >= 1000 cells: "
      f"{big.sum()}, median relative difference {np.median(rel):.2e}, {100 * np.mean(rel < 0.01):.1f} % within 1 %")

# Why they differ: GRASS's A* gives each cell the direction of the neighbour it was reached from
# (about the lowest one), terracl's D8 the steepest drop (drop / distance, diagonals sqrt 2 longer).
z = gdal.Open(filled).ReadAsArray().astype(np.float64)
gt = gdal.Open(filled).GetGeoTransform()
lat = np.radians(gt[3] + gt[5] * z.shape[0] / 2)
cy = abs(gt[5]) * 111320.0
cx = gt[1] * 111320.0 * np.cos(lat)
gd = gdal.Open(f"{a.out}/grass-dir.tif").ReadAsArray()
# GRASS codes 1..8 counter-clockwise from north-east: 1 NE, 2 N, 3 NW, 4 W, 5 SW, 6 S, 7 SE, 8 E.
codes = [(1, -1, 1), (2, -1, 0), (3, -1, -1), (4, 0, -1), (5, 1, -1), (6, 1, 0), (7, 1, 1), (8, 0, 1)]
c = z[1:-1, 1:-1]
drops, slopes = [], []
for code, dy, dx in codes:
    nb = z[1 + dy:z.shape[0] - 1 + dy, 1 + dx:z.shape[1] - 1 + dx]
    d = c - nb
    drops.append(d)
    slopes.append(d / (np.hypot(cx, cy) if dx and dy else (cx if dx else cy)))
lowest = np.array([k for k, _, _ in codes])[np.argmax(np.array(drops), axis=0)]
steep = np.array([k for k, _, _ in codes])[np.argmax(np.array(slopes), axis=0)]
g_in = np.abs(gd[1:-1, 1:-1])
print(f"GRASS directions equal to the steepest drop (terracl's D8): {100 * np.mean(g_in == steep):.1f} %; to the "
      f"lowest neighbour: {100 * np.mean(g_in == lowest):.1f} % (interior cells)")
