#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Start-up time of small terracl commands against gdalinfo, and where it goes.

usage: /usr/bin/python3 scripts/bench-startup.py [build/bin/terracl] [--repeats 9]

Runs each command alternately (A B C ... A B C ...), prints the median and the fastest wall time,
then the dynamic linker's share for `terracl --version` (LD_DEBUG=statistics: time in relocation
and in loading, number of relocations) and the number of shared libraries each binary loads.
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
    commands = {
        "terracl --version": [cli, "--version"],
        "terracl devices": [cli, "devices"],
        "terracl info (128x96)": [cli, "info", dem],
        "terracl convert (128x96)": [cli, "-q", "convert", dem, out],
        "gdalinfo (128x96)": [shutil.which("gdalinfo") or "gdalinfo", dem],
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
        print(f"  {name:<26} median {1000 * statistics.median(t):7.1f} ms   fastest {1000 * min(t):7.1f} ms")
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
    for name, exe in (("terracl", cli), ("gdalinfo", shutil.which("gdalinfo"))):
        if exe:
            libs = [l for l in subprocess.run(["ldd", exe], capture_output=True, text=True).stdout.splitlines() if "=>" in l]
            print(f"shared libraries loaded by {name}: {len(libs)}")
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
