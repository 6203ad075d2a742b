#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Where the slope of an amplified DEM comes from: the gradient's energy per octave of
spatial frequency, output over truth, from `terracl dictionary evaluate --save PREFIX` files.

  /usr/bin/python3 scripts/amplify-gradient-octaves.py --factor 16 PREFIX [PREFIX ...]

For each PREFIX (PREFIX_truth.tif, PREFIX_out.tif, PREFIX_bicubic.tif) the least-squares plane is
removed, a 2-D Hann window applied, and the gradient's power |2 pi k|^2 |Z(k)|^2 summed over radial
octaves of |k| (cycles per output cell) up to the Nyquist 1/2. Octaves above the input's Nyquist
1/(2 f) are the synthesized ones: at x16 the first x4 step adds 1/32-1/8, the second 1/8-1/2.
Prints each octave's share of the truth's gradient energy and the output's (and bicubic's) energy
over the truth's there, then the mean slope ratio (`terracl info`'s definition is in degrees; here
the mean |grad| in m/m, which follows it closely at these slopes).
"""
import argparse
import os
import subprocess
import tempfile

import numpy as np

TERRACL = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "bin", "terracl")


def load(path):
    with tempfile.TemporaryDirectory() as d:
        npy = os.path.join(d, "z.npy")
        subprocess.run([TERRACL, "-q", "convert", path, npy], check=True, stdout=subprocess.DEVNULL)
        return np.load(npy).astype(np.float64)


def gradient_power(z):
    h, w = z.shape
    y, x = np.mgrid[0:h, 0:w]
    a = np.c_[x.ravel(), y.ravel(), np.ones(x.size)]
    c, *_ = np.linalg.lstsq(a, z.ravel(), rcond=None)
    z = z - (a @ c).reshape(h, w)
    z = z * np.outer(np.hanning(h), np.hanning(w))
    p = np.abs(np.fft.fft2(z)) ** 2
    ky = np.fft.fftfreq(h)[:, None]
    kx = np.fft.fftfreq(w)[None, :]
    k = np.sqrt(kx**2 + ky**2)
    return k, p * (2 * np.pi * k) ** 2


def mean_grad(z):
    gy, gx = np.gradient(z)
    return np.mean(np.hypot(gx, gy))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--factor", type=int, required=True)
    ap.add_argument("prefix", nargs="+")
    a = ap.parse_args()
    # octave edges: 1/2, 1/4, ... down to 1/(4 f), the octave below the input's Nyquist
    edges = [0.5 / 2**j for j in range(int(np.log2(a.factor)) + 2)][::-1]
    for pre in a.prefix:
        t, o, b = (load(f"{pre}_{n}.tif") for n in ("truth", "out", "bicubic"))
        k, pt = gradient_power(t)
        _, po = gradient_power(o)
        _, pb = gradient_power(b)
        total = pt[k <= 0.5].sum()
        print(f"{os.path.basename(pre)} x{a.factor}: mean |grad| out / truth {mean_grad(o) / mean_grad(t):.3f}, "
              f"bicubic / truth {mean_grad(b) / mean_grad(t):.3f}")
        print("| octave (cycles/cell) | truth's share | out / truth | bicubic / truth |")
        print("|---|---|---|---|")
        lo_all = [(0.0, edges[0])] + list(zip(edges[:-1], edges[1:]))
        for lo, hi in lo_all:
            m = (k > lo) & (k <= hi)
            st, so, sb = pt[m].sum(), po[m].sum(), pb[m].sum()
            name = f"0-{hi:.4g}" if lo == 0 else f"{lo:.4g}-{hi:.4g}"
            print(f"| {name} | {st / total:.3f} | {so / max(st, 1e-30):.3f} | {sb / max(st, 1e-30):.3f} |")
        print()


if __name__ == "__main__":
    main()
