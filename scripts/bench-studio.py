#!/usr/bin/python3
"""Benchmark of terracl studio's API (docs/studio.md), as the page uses it.

  scripts/bench-studio.py [build/bin/terracl] [--size 1025] [--ops 30] [--erosion-size 513] [--frames 60]

Starts `terracl studio flat:NxN@10` on a free port and measures
  * append: POST one operation at the end (one operation + warm solve) and GET the updated preview
    (terrain.f32?max=400, what the page draws), median and p95;
  * replay: PUT a change to the FIRST operation (the script replayed from the base) + preview;
  * erosion: preview frames per second while eroding at --erosion-size (POST erosion/step?steps=1
    returning the bed, max 513 cells a side).
"""
import json
import random
import os
import re
import statistics
import subprocess
import sys
import time
import secrets
import urllib.request

# The API token the bench fixes for the server it starts (docs/studio.md).
TOKEN = secrets.token_hex(16)


def arg(name, default):
    return type(default)(sys.argv[sys.argv.index(name) + 1]) if name in sys.argv else default


def request(base, method, path, body=None):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(base + path, data=data, method=method, headers={"Content-Type": "application/json", "X-Terracl-Token": TOKEN})
    with urllib.request.urlopen(req, timeout=600) as r:
        return r.read()


def start(cli, base):
    p = subprocess.Popen([cli, "-q", "studio", base, "--port", "0", "--workspace", "/tmp/terracl-bench-studio"],
                         stdout=subprocess.PIPE, text=True, env={**os.environ, "TERRACL_STUDIO_TOKEN": TOKEN})
    for _ in range(50):
        m = re.search(r"(http://127\.0\.0\.1:\d+/)", p.stdout.readline())
        if m:
            return p, m.group(1).rstrip("/")
    raise SystemExit("studio did not start")


def pct(v, q):
    v = sorted(v)
    return v[min(len(v) - 1, int(round(q * (len(v) - 1))))]


def main():
    cli = sys.argv[1] if len(sys.argv) > 1 and not sys.argv[1].startswith("--") else "build/bin/terracl"
    n, nops, en, frames = arg("--size", 1025), arg("--ops", 30), arg("--erosion-size", 513), arg("--frames", 60)
    rng = random.Random(1)
    ext = (n - 1) * 10.0
    p, base = start(cli, f"flat:{n}x{n}@10")
    try:
        def op(i):
            x0, y0 = rng.uniform(0.1, 0.9) * ext, rng.uniform(0.1, 0.9) * ext
            pts = [[x0, y0], [x0 + rng.uniform(-0.3, 0.3) * ext, y0 + rng.uniform(-0.3, 0.3) * ext]]
            kind = i % 3
            if kind == 0:
                return {"op": "crest", "points": pts, "elevation": rng.uniform(50, 300), "radius": 0.05 * ext}
            if kind == 1:
                return {"op": "ravine", "points": pts, "depth": 40, "radius": 0.04 * ext}
            return {"op": "noise", "center": pts[0], "radius": 0.1 * ext, "amplitude": 15, "wavelength": 0.03 * ext}

        append, solve_ms = [], []
        for i in range(nops):
            t0 = time.perf_counter()
            st = json.loads(request(base, "POST", "/api/operations", {"op": op(i)}))
            request(base, "GET", "/api/terrain.f32?max=400")
            append.append((time.perf_counter() - t0) * 1e3)
            solve_ms.append(st["last"]["ms"])
        replay = []
        for i in range(max(3, nops // 5)):
            t0 = time.perf_counter()
            request(base, "PUT", "/api/operations/0", {"op": op(0)})
            request(base, "GET", "/api/terrain.f32?max=400")
            replay.append((time.perf_counter() - t0) * 1e3)
    finally:
        p.terminate()
        p.wait()

    p, base = start(cli, f"flat:{en}x{en}@30")
    try:
        request(base, "POST", "/api/operations", {"op": {"op": "mountain_range", "points": [[0.1 * en * 30, 0.5 * en * 30, 600], [0.9 * en * 30, 0.5 * en * 30, 800]], "radius": 0.3 * en * 30}})
        request(base, "POST", "/api/erosion/start", {"rain": 0.01})
        request(base, "POST", "/api/erosion/step?steps=1&max=400")  # warm-up (kernels compiled)
        t0 = time.perf_counter()
        for _ in range(frames):
            request(base, "POST", "/api/erosion/step?steps=1&max=400")
        fps = frames / (time.perf_counter() - t0)
    finally:
        p.terminate()
        p.wait()

    print(f"studio {n}x{n}: append op + preview  median {statistics.median(append):.1f} ms  p95 {pct(append, 0.95):.1f} ms  "
          f"(server side op + warm solve median {statistics.median(solve_ms):.1f} ms, {nops} ops)")
    print(f"studio {n}x{n}: change op 0 (replay of {nops} ops) + preview  median {statistics.median(replay):.1f} ms  p95 {pct(replay, 0.95):.1f} ms")
    print(f"studio erosion {en}x{en}: {fps:.1f} preview frames/s (1 step per frame, {frames} frames)")


if __name__ == "__main__":
    main()
