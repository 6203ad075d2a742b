#!/usr/bin/python3
"""Tiled vs untiled fill_depressions on a large raster (docs/scale.md).

Builds an N x N mosaic of the bundled SRTM tile (a VRT of repeated copies, converted to a tiled
GeoTIFF), then runs `read -> fill_depressions -> write` untiled and with --tile, and prints wall
time, peak RSS and the GDAL checksums of both outputs (the tests prove them equal bit for bit).

  scripts/bench-tiles.py --size 8192 --tile 2048 [--budget 1G] [--terracl build/bin/terracl]
"""
import argparse, os, resource, subprocess, sys, time

ap = argparse.ArgumentParser()
ap.add_argument("--size", type=int, default=8192)
ap.add_argument("--tile", type=int, default=2048)
ap.add_argument("--budget", default="")
ap.add_argument("--terracl", default="build/bin/terracl")
ap.add_argument("--out", default="/tmp/terracl-bench-tiles")
ap.add_argument("--skip-untiled", action="store_true")
a = ap.parse_args()
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


def run(name, extra):
    p = f"{a.out}/{name}.json"
    with open(p, "w") as f:
        f.write(f'["{mosaic}", "fill_depressions", "{a.out}/{name}.tif"]\n')
    cmd = ["/usr/bin/time", "-f", "%e %U %S %M", a.terracl, "-q", "run", p] + extra
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stdout}{r.stderr}")
    wall, user, system, rss_kb = r.stderr.strip().splitlines()[-1].split()
    chk = subprocess.run(["gdalinfo", "-checksum", f"{a.out}/{name}.tif"], capture_output=True, text=True).stdout
    chk = [l.split("=")[1] for l in chk.splitlines() if "Checksum=" in l][0]
    print(f"| {name} | {' '.join(extra) or '(untiled)'} | {float(wall):.1f} | {float(user) + float(system):.1f} | {int(rss_kb) / 1024:.0f} | {chk} |", flush=True)


print(f"fill_depressions of a {n} x {n} SRTM mosaic ({n * n / 1e6:.0f} M cells, {n * n * 4 / 2**20:.0f} MiB float32)")
print("| run | options | wall s | CPU s | peak RSS MiB | GDAL checksum |")
print("|---|---|---|---|---|---|")
if not a.skip_untiled:
    run("untiled", [])
extra = ["--tile", str(a.tile)] + (["--memory-budget", a.budget] if a.budget else [])
run("tiled", extra)
