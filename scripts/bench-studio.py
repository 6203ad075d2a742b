#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Benchmark of terracl studio's API (docs/studio.md), as the page uses it.

  scripts/bench-studio.py [build/bin/terracl] [--size 1025] [--ops 30] [--erosion-size 513] [--frames 60]
  scripts/bench-studio.py [build/bin/terracl] --after-erosion [--size 1025] [--changes 10] [--steps 60]
  scripts/bench-studio.py [build/bin/terracl] --first-drainage [--size 1025]
  scripts/bench-studio.py [build/bin/terracl] --first-strokes DEM

Starts `terracl studio flat:NxN@10` on a free port and measures
  * append: POST one operation at the end (one operation + warm solve) and GET the updated preview
    (terrain.f32?max=400, what the page draws), median and p95;
  * replay: PUT a change to the FIRST operation (the script replayed from the base) + preview;
  * erosion: preview frames per second while eroding at --erosion-size (POST erosion/step?steps=1
    returning the bed, max 513 cells a side).

--after-erosion measures only: change a layer after an erosion (issue #31). On flat:NxN@10 it
builds [mountain_range, erode --steps, crest], then PUTs a changed last crest --changes times
(+ the preview), median and p95 (server side: the replay from the erosion's snapshot).

--first-drainage measures only: the first operation after start on empty kernel caches (a fresh
$XDG_CACHE_HOME for terracl's program cache and $POCL_CACHE_DIR for PoCL's), a `drainage` on a
range: at once after start, and once the studio's background warm-up is done ("warming": false in
/api/state; a studio without warm-up has no such key).

--first-strokes measures only: on a real DEM, once the warm-up is done, the first default stroke of
each landform tool, each in another part of the map (its corners and centre), as the studio's tools
post them (relative: no elevation, no size), so each one's detail uses the DEM's own texture there:
the time to answer the POST and the server's own time.
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


def start(cli, base, env=None):
    p = subprocess.Popen([cli, "-q", "studio", base, "--port", "0", "--workspace", "/tmp/terracl-bench-studio"],
                         stdout=subprocess.PIPE, text=True, env={**os.environ, **(env or {}), "TERRACL_STUDIO_TOKEN": TOKEN})
    for _ in range(50):
        m = re.search(r"(http://127\.0\.0\.1:\d+/)", p.stdout.readline())
        if m:
            return p, m.group(1).rstrip("/")
    raise SystemExit("studio did not start")


def pct(v, q):
    v = sorted(v)
    return v[min(len(v) - 1, int(round(q * (len(v) - 1))))]


def after_erosion(cli):
    n, changes, steps = arg("--size", 1025), arg("--changes", 10), arg("--steps", 60)
    ext = (n - 1) * 10.0
    p, base = start(cli, f"flat:{n}x{n}@10")
    try:
        rng = {"op": "mountain_range", "points": [[0.15 * ext, 0.5 * ext, 600], [0.85 * ext, 0.45 * ext, 800]],
               "radius": 0.2 * ext}

        def crest(i):
            return {"op": "crest", "points": [[0.3 * ext, 0.2 * ext], [0.6 * ext, 0.15 * ext + 5 * i]],
                    "elevation": 300 + 10 * i, "radius": 0.04 * ext}

        request(base, "POST", "/api/operations", {"op": rng})
        request(base, "POST", "/api/operations", {"op": {"op": "erode", "steps": steps}})
        request(base, "POST", "/api/operations", {"op": crest(0)})
        ms, server = [], []
        for i in range(1, changes + 1):
            t0 = time.perf_counter()
            st = json.loads(request(base, "PUT", "/api/operations/2", {"op": crest(i)}))
            request(base, "GET", "/api/terrain.f32?max=400")
            ms.append((time.perf_counter() - t0) * 1e3)
            server.append(st["last"]["ms"])
            frm = st["last"].get("from", "-")
    finally:
        p.terminate()
        p.wait()
    print(f"{cli}: studio {n}x{n}: change the crest after an erosion ({steps} steps), {changes} changes: + preview median "
          f"{statistics.median(ms):.0f} ms  p95 {pct(ms, 0.95):.0f} ms  (server side median {statistics.median(server):.0f} ms; "
          f"replay from operation {frm})")


def first_drainage(cli):
    import tempfile
    n = arg("--size", 1025)
    ext = (n - 1) * 10.0
    rng = {"op": "mountain_range", "points": [[0.15 * ext, 0.5 * ext, 600], [0.85 * ext, 0.45 * ext, 800]], "radius": 0.2 * ext}
    out = []
    for wait in (False, True):
        with tempfile.TemporaryDirectory() as xdg, tempfile.TemporaryDirectory() as pocl:
            t_start = time.perf_counter()
            p, base = start(cli, f"flat:{n}x{n}@10", {"XDG_CACHE_HOME": xdg, "POCL_CACHE_DIR": pocl})
            try:
                warm_s = None
                if wait:
                    while json.loads(request(base, "GET", "/api/state")).get("warming", False):
                        time.sleep(0.2)
                    warm_s = time.perf_counter() - t_start
                t0 = time.perf_counter()
                request(base, "POST", "/api/operations", {"op": rng})
                t1 = time.perf_counter()
                request(base, "POST", "/api/operations", {"op": {"op": "drainage"}})
                t2 = time.perf_counter()
            finally:
                p.terminate()
                p.wait()
        out.append((wait, (t1 - t0) * 1e3, (t2 - t1) * 1e3, warm_s))
    for wait, a, d, w in out:
        when = f"after the warm-up ({w:.1f} s after start)" if wait else "at once after start"
        print(f"{cli}: studio {n}x{n}, empty kernel caches, {when}: first stroke (range) {a:.0f} ms, "
              f"then first drainage {d:.0f} ms")


def first_strokes(cli):
    dem = arg("--first-strokes", "")
    p, base = start(cli, dem)
    try:
        st = json.loads(request(base, "GET", "/api/state"))
        t_start = time.perf_counter()
        while st.get("warming", False):
            time.sleep(0.2)
            st = json.loads(request(base, "GET", "/api/state"))
        warm_s = time.perf_counter() - t_start
        w, h = st["width"], st["height"]
        cx, cy = st.get("cell_x", 1.0), st.get("cell_y", 1.0)
        rows = []
        places = [(0.2, 0.2), (0.8, 0.2), (0.5, 0.5), (0.2, 0.8), (0.8, 0.8)]
        for tool, (fx, fy) in zip(["mountain_range", "river", "canyon", "cliff", "crest"], places):
            x, y, d = fx * (w - 1) * cx, fy * (h - 1) * cy, 0.08 * (w - 1) * cx
            op = {"op": tool, "points": [[x - d, y], [x, y - 0.3 * d], [x + d, y]]}
            t0 = time.perf_counter()
            s2 = json.loads(request(base, "POST", "/api/operations", {"op": op}))
            rows.append((tool, fx, fy, (time.perf_counter() - t0) * 1e3, s2["last"]["ms"]))
    finally:
        p.terminate()
        p.wait()
    print(f"{cli}: studio on {dem} ({w}x{h}), warm-up done {warm_s:.1f} s after the first state; first stroke of each tool:")
    for tool, fx, fy, ms, server in rows:
        print(f"  {tool:15s} at ({fx:.1f}, {fy:.1f}) of the map: {ms:.0f} ms (server {server:.0f} ms)")


def main():
    cli = sys.argv[1] if len(sys.argv) > 1 and not sys.argv[1].startswith("--") else "build/bin/terracl"
    if "--first-strokes" in sys.argv:
        return first_strokes(cli)
    if "--after-erosion" in sys.argv:
        return after_erosion(cli)
    if "--first-drainage" in sys.argv:
        return first_drainage(cli)
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
