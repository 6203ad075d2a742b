#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Python call overhead of terracl.reconstruct on an N x N grid (default 1025^2).

Three timings of the same reconstruction, alternated call by call so that a loaded machine slows
them alike: the Python call `terracl.reconstruct(g, ...)` (wall time seen by Python: options from
keywords, the gradient copied into the stage, the GIL released and re-acquired, the result
wrapped), the same stage called from C++ in a loop (`_terracl._time_stage`: options resolved and
the stage run, as the CLI or a C++ program does, with the GIL released), and the solver's own
ReconstructResult.total_ms. Overhead = Python call - C++ call. Same problem as `terracl bench
reconstruct` (a smooth terrain; --fixed 0.01 adds 1 % fixed cells as a constraint file, which the
stage parses in both paths).

  PYTHONPATH=build/python /usr/bin/python3 python/bench_overhead.py [--size 1025] [--repeats 10] [--fixed 0.01]
"""
import argparse
import json
import os
import statistics
import tempfile
import time

import sys

import numpy as np

# Not the source package beside this script (it has no compiled module): the built or installed one.
_here = os.path.dirname(os.path.abspath(__file__))
sys.path = [p for p in sys.path if os.path.abspath(p or ".") != _here]
import terracl  # noqa: E402


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
    ap.add_argument("--fixed", type=float, default=0.0, help="fraction of fixed cells (constraint file)")
    ap.add_argument("--device", default=None)
    a = ap.parse_args()
    g, cons = problem(a.size, fixed=a.fixed)
    with tempfile.TemporaryDirectory() as tmp:
        opts = {"report": os.path.join(tmp, "r.json")}
        if a.fixed > 0:
            opts["constraints"] = os.path.join(tmp, "c.json")
            with open(opts["constraints"], "w") as f:
                json.dump(cons, f)
        info = terracl.device(a.device)
        print("reconstruct %dx%d, %.2f %% fixed cells, device %s" % (a.size, a.size, 100 * a.fixed, info.name))
        terracl.reconstruct(g, device=a.device, **opts)  # warm-up: kernel builds, first-touch memory
        py_ms, cpp_ms, solver_ms, py_cpu, cpp_cpu = [], [], [], [], []
        for _ in range(a.repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            h = terracl.reconstruct(g, device=a.device, **opts)
            py_ms.append((time.perf_counter() - t0) * 1e3)
            py_cpu.append((time.process_time() - c0) * 1e3)
            with open(opts["report"]) as f:
                solver_ms.append(json.load(f)["total_ms"])
            c0 = time.process_time()
            cpp_ms += terracl._terracl._time_stage("reconstruct", g, opts, a.device, 1)
            cpp_cpu.append((time.process_time() - c0) * 1e3)
        med = statistics.median
        mp, mc, ms = med(py_ms), med(cpp_ms), med(solver_ms)
        print("python_call_ms  median %8.2f  (min %.2f, max %.2f, %d calls)" % (mp, min(py_ms), max(py_ms), len(py_ms)))
        print("cpp_call_ms     median %8.2f  (min %.2f, max %.2f; the same stage called from C++)" % (mc, min(cpp_ms), max(cpp_ms)))
        print("solver_ms       median %8.2f  (ReconstructResult.total_ms of the Python calls)" % ms)
        print("overhead_ms     median %8.2f  (min-to-min %.2f) = %.2f %% of the C++ call"
              % (mp - mc, min(py_ms) - min(cpp_ms), 100 * (mp - mc) / mc))
        # CPU time of all threads (PoCL's included): on a shared machine wall time is inflated by
        # other processes, CPU time much less.
        print("cpu_ms          python %.2f, C++ %.2f (medians): overhead %.2f = %.2f %%"
              % (med(py_cpu), med(cpp_cpu), med(py_cpu) - med(cpp_cpu), 100 * (med(py_cpu) - med(cpp_cpu)) / med(cpp_cpu)))
        t0 = time.perf_counter()
        for _ in range(a.repeats):
            terracl.Heightfield(h.z, cell_size=h.cell_size)
        print("one %dx%d float32 copy: %.2f ms (for scale)" % (a.size, a.size, (time.perf_counter() - t0) * 1e3 / a.repeats))


if __name__ == "__main__":
    main()
