#!/usr/bin/env python3
"""Writes knot.obj: a (3, 2) torus knot tube, closed, 4 800 triangles, no normals (raylab computes
smooth ones with `normals = "smooth"`). Written for raylab's scenes; CC0. Run: python3 make_knot.py"""
import math

P, Q = 3, 2                  # windings
N, M = 240, 10               # segments along the curve, around the tube
R, r, TUBE = 1.0, 0.4, 0.22  # torus radii and tube radius


def curve(t):
    a = Q * t
    return ((R + r * math.cos(P * t)) * math.cos(a), r * math.sin(P * t), (R + r * math.cos(P * t)) * math.sin(a))


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def unit(a):
    n = math.sqrt(sum(x * x for x in a))
    return tuple(x / n for x in a)


lines = ["# (3, 2) torus knot tube, written by make_knot.py (CC0)"]
for i in range(N):
    t = 2 * math.pi * i / N
    c, c2 = curve(t), curve(t + 1e-4)
    tangent = unit(sub(c2, c))
    side = unit(cross(tangent, (0.0, 1.0, 0.0)))
    up = cross(side, tangent)
    for j in range(M):
        a = 2 * math.pi * j / M
        p = tuple(c[k] + TUBE * (math.cos(a) * side[k] + math.sin(a) * up[k]) for k in range(3))
        lines.append("v %.6f %.6f %.6f" % p)
for i in range(N):
    for j in range(M):
        v = lambda ii, jj: (ii % N) * M + (jj % M) + 1
        lines.append("f %d %d %d" % (v(i, j), v(i + 1, j), v(i + 1, j + 1)))
        lines.append("f %d %d %d" % (v(i, j), v(i + 1, j + 1), v(i, j + 1)))
open("knot.obj", "w").write("\n".join(lines) + "\n")
