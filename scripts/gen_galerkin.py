#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Generates the straight-line Galerkin coarse-operator formula used in kernels/multigrid.cl.

A fine level is stored in "edge form": for node n, s(n) (diagonal excess) and the weights of the
edges n->n+E, n+S, n+SE, n+SW, so that x^T A x = sum_e w_e (x_a - x_b)^2 + sum_n s_n x_n^2.
With bilinear interpolation P (coarse node I at fine 2I) the Galerkin operator P^T A P has entries
A_c(I,J) = sum_e w_e (p^I_a - p^I_b)(p^J_a - p^J_b) + sum_n s_n p^I_n p^J_n, a fixed linear map of the
fine stencils around I. This script enumerates it and prints only the nonzero terms (as named
locals loaded once), so the kernel does no work on the many structural zeros.
Usage: python3 scripts/gen_galerkin.py > snippet (pasted into kernels/multigrid.cl)
"""
from fractions import Fraction as F


def pw(d):
    return {0: F(1), 1: F(1, 2), -1: F(1, 2)}.get(d, F(0))


def q(J, x, y):
    return pw(x - 2 * J[0]) * pw(y - 2 * J[1])


def name(acc, x, y):
    f = lambda v: ("m" if v < 0 else "p") + str(abs(v))
    return f"{acc}_{f(x)}_{f(y)}"


I = (0, 0)
outs = {"C": (0, 0), "E": (1, 0), "S": (0, 1), "SE": (1, 1), "SW": (-1, 1)}
dirs = {"WE": (1, 0), "WS": (0, 1), "WSE": (1, 1), "WSW": (-1, 1)}
R = range(-4, 5)
used = set()
exprs = {}
for oname, J in outs.items():
    terms = {}
    for y in R:
        for x in R:
            c = q(I, x, y) * q(J, x, y)
            if c:
                terms[("S", x, y)] = terms.get(("S", x, y), 0) + c
            for dn, (dx, dy) in dirs.items():
                bx, by = x + dx, y + dy
                c = (q(I, x, y) - q(I, bx, by)) * (q(J, x, y) - q(J, bx, by))
                if c:
                    terms[(dn, x, y)] = terms.get((dn, x, y), 0) + c
    sign = 1 if oname == "C" else -1
    parts = []
    for (acc, x, y), c in sorted(terms.items(), key=lambda t: (t[0][2], t[0][1], t[0][0])):
        used.add((acc, x, y))
        parts.append(f"{float(sign * c)!r}f * {name(acc, x, y)}")
    exprs["D" if oname == "C" else "W" + oname] = parts

print("#define GALERKIN_LOADS \\")
for acc, x, y in sorted(used, key=lambda t: (t[0], t[2], t[1])):
    print(f"  const float {name(acc, x, y)} = {acc}({x}, {y}); \\")
print("  (void)0")
for out, parts in exprs.items():
    print(f"#define GALERKIN_{out} ( \\")
    for i, p in enumerate(parts):
        print(f"    {'+ ' if i else '  '}{p} \\")
    print("  )")

# Level 0 (5-point, hard cells = NaN in g) straight from a 5x5 window of cell states cs_a_b
# (0 absent, 1 free, 2 hard): the D A D edge-form stencil, with everything in registers.
def v(a, b):
    return name("cs", a, b)

print("#define GALERKIN0_STATES \\")
for b in range(-2, 3):
    for a in range(-2, 3):
        print(f"  const int {v(a, b)} = cell_state(g, bx + ({a}), by + ({b}), W, H); \\")
print("  (void)0")
print("#define GALERKIN0_LOADS \\")
for acc, x, y in sorted(used, key=lambda t: (t[0], t[2], t[1])):
    if acc == "WE":
        e = f"({v(x, y)} == 1 && {v(x + 1, y)} == 1) ? wx : 0.0f"
    elif acc == "WS":
        e = f"({v(x, y)} == 1 && {v(x, y + 1)} == 1) ? wy : 0.0f"
    elif acc == "S":
        e = (f"{v(x, y)} == 1 ? wx * (float)(({v(x - 1, y)} == 2) + ({v(x + 1, y)} == 2)) + "
             f"wy * (float)(({v(x, y - 1)} == 2) + ({v(x, y + 1)} == 2)) : 0.0f")
    else:
        e = "0.0f"
    print(f"  const float {name(acc, x, y)} = {e}; \\")
print("  (void)0")
