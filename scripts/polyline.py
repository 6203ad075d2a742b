"""Polyline helpers shared by the gallery generators (scripts/gen-*.py)."""
import math


def catmull(pts, n):
    """Uniform Catmull-Rom samples through pts (each [x, y] or [x, y, z]), n per segment, ends doubled."""
    dims = len(pts[0])
    P = [pts[0]] + list(pts) + [pts[-1]]
    out = []
    for i in range(1, len(P) - 2):
        p0, p1, p2, p3 = P[i - 1], P[i], P[i + 1], P[i + 2]
        for k in range(n):
            t = k / n
            out.append([0.5 * ((2 * p1[j]) + (-p0[j] + p2[j]) * t + (2 * p0[j] - 5 * p1[j] + 4 * p2[j] - p3[j]) * t * t +
                               (-p0[j] + 3 * p1[j] - 3 * p2[j] + p3[j]) * t ** 3) for j in range(dims)])
    out.append(list(pts[-1]))
    return out


def arc_lengths(line):
    """Cumulative arc length (x, y) at every point of the line, 0 at the first."""
    arc = [0.0]
    for a, b in zip(line, line[1:]):
        arc.append(arc[-1] + math.hypot(b[0] - a[0], b[1] - a[1]))
    return arc
