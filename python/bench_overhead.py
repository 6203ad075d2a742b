#!/usr/bin/env python3
"""Python call overhead of terracl.reconstruct on an N x N grid (default 1025^2).

For each call the wall time seen by Python is compared with the time the C++ solver measured for
the same call (ReconstructResult.total_ms, written by the stage's `report` option): the difference
is what the binding adds (options through the stage table, numpy/Heightfield copies in and out,
GIL release and re-acquisition, the report file). Same problem as `terracl bench reconstruct`
(a smooth terrain, 1 % fixed cells) so the two can be compared.

  PYTHONPATH=build/python /usr/bin/python3 python/bench_overhead.py [--size 1025] [--repeats 10]
"""
import argparse
import json
import os
import statistics
import tempfile
import time

import numpy as np

import terracl


def problem(n, cell=8.0, fixed=0.01, seed=7):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:n, 0:n].astype(np.float64)
    z = np.full((n, n), 1000.0)
    for i in range(6):
        kx, ky = (1 + 3 * rng.random(2)) * 2 * np.pi / n
        z += 500.0 / (i + 2) * np.sin(kx * x + ky * y + 2 * np.pi * rng.random())
    gx = np.zeros((n, n), np.float32)
    gy = np.zeros((n, n), np.float32)
    gx[:, :-1] = (z[:, 1:] - z[:, :-1]) / cell
    gy[:-1, :] = (z[1:, :] - z[:-1, :]) / cell
    g = terracl.GradientField(gx, gy, cell_size=cell, mean_elevation=float(z.mean()))
    k = int(fixed * n * n)
    pts = [{"x": int(a), "y": int(b), "z": float(z[b, a])} for a, b in rng.integers(0, n, size=(k, 2))]
    return g, {"points": pts}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=1025)
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--device", default=None)
    a = ap.parse_args()
    g, cons = problem(a.size)
    with tempfile.TemporaryDirectory() as tmp:
        cpath = os.path.join(tmp, "c.json")
        with open(cpath, "w") as f:
            json.dump(cons, f)
        rpath = os.path.join(tmp, "r.json")
        info = terracl.device(a.device)
        print("reconstruct %dx%d, 1 %% fixed cells, device %s" % (a.size, a.size, info.name))
        terracl.reconstruct(g, constraints=cpath, device=a.device)  # warm-up: kernel builds
        py_ms, cpp_ms = [], []
        for _ in range(a.repeats):
            t0 = time.perf_counter()
            h = terracl.reconstruct(g, constraints=cpath, report=rpath, device=a.device)
            py_ms.append((time.perf_counter() - t0) * 1e3)
            with open(rpath) as f:
                cpp_ms.append(json.load(f)["total_ms"])
        over = [p - c for p, c in zip(py_ms, cpp_ms)]
        mp, mc, mo = statistics.median(py_ms), statistics.median(cpp_ms), statistics.median(over)
        print("python_call_ms   median %.2f  (min %.2f, max %.2f, %d runs)" % (mp, min(py_ms), max(py_ms), len(py_ms)))
        print("cpp_solver_ms    median %.2f  (ReconstructResult.total_ms of the same calls)" % mc)
        print("overhead_ms      median %.2f  (min %.2f) = %.2f %% of the C++ call" % (mo, min(over), 100 * mo / mc))
        # What the overhead is made of: the constraint file is parsed by the stage in both paths;
        # the copies are the gradient into the stage and the result out (4 bytes a cell each).
        t0 = time.perf_counter()
        for _ in range(a.repeats):
            terracl.Heightfield(h.z)
        copy_ms = (time.perf_counter() - t0) * 1e3 / a.repeats
        print("one %dx%d float32 copy  %.2f ms (for scale)" % (a.size, a.size, copy_ms))
        assert h.width == a.size


if __name__ == "__main__":
    main()
