#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Start-up time of small terracl commands against gdalinfo, and where it goes.

usage: /usr/bin/python3 scripts/bench-startup.py [build/bin/terracl] [--repeats 9]

Runs each command alternately (A B C ... A B C ...), prints the median and the fastest wall time
and the shared libraries each command loads (at start and by dlopen: GDAL comes at its first call
in the CLI, cmake/LazyLibraries.cmake), then the dynamic linker's share for `terracl --version`
(LD_DEBUG=statistics: time in relocation and in loading, number of relocations).
"""
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def main():
    args = sys.argv[1:]
    repeats = 9
    if "--repeats" in args:
        i = args.index("--repeats")
        repeats = int(args[i + 1])
        del args[i:i + 2]
    cli = os.path.abspath(args[0] if args else "build/bin/terracl")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    dem = os.path.join(root, "data", "crops", "presidential_128x96.tif")
    tmp = tempfile.mkdtemp(prefix="terracl-startup-")
    out = os.path.join(tmp, "out.tif")
    png = os.path.join(tmp, "in.png")
    subprocess.run([cli, "-q", "convert", dem, png], check=True, stdout=subprocess.DEVNULL)
    gdalinfo = shutil.which("gdalinfo") or "gdalinfo"
    commands = {
        "terracl --version": [cli, "--version"],
        "terracl devices": [cli, "devices"],
        "terracl info (128x96 tif)": [cli, "info", dem],
        "terracl convert (tif->tif)": [cli, "-q", "convert", dem, out],
        "terracl convert (png->exr)": [cli, "-q", "convert", png, os.path.join(tmp, "out.exr")],
        "gdalinfo --version": [gdalinfo, "--version"],
        "gdalinfo (128x96 tif)": [gdalinfo, dem],
    }
    times = {k: [] for k in commands}
    for _ in range(repeats):
        for name, cmd in commands.items():
            t0 = time.perf_counter()
            subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
            times[name].append(time.perf_counter() - t0)
    load = os.getloadavg()[0]
    print(f"start-up, {repeats} runs each interleaved, load {load:.2f}, {os.cpu_count()} cores")
    for name, t in times.items():
        env = dict(os.environ, LD_DEBUG="libs")
        r = subprocess.run(commands[name], env=env, capture_output=True, text=True)
        libs = len(re.findall(r"calling init: ", r.stderr))
        print(f"  {name:<27} median {1000 * statistics.median(t):7.1f} ms   fastest {1000 * min(t):7.1f} ms"
              f"   {libs:4d} libraries")
    env = dict(os.environ, LD_DEBUG="statistics")
    r = subprocess.run([cli, "--version"], env=env, capture_output=True, text=True)
    stats = r.stderr
    total = re.search(r"total startup time in dynamic loader:\s*([\d,.]+)\s*(\w+)", stats)
    reloc = re.search(r"time needed for relocation:\s*([\d,.]+)\s*(\w+)\s*\(([\d.]+)%\)", stats)
    nrel = re.search(r"number of relocations:\s*(\d+)", stats)
    if total:
        print(f"dynamic loader for `terracl --version`: {total.group(1)} {total.group(2)} in all"
              + (f", relocation {reloc.group(1)} {reloc.group(2)} ({reloc.group(3)} %)" if reloc else "")
              + (f", {nrel.group(1)} relocations" if nrel else ""))
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
