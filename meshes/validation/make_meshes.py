#!/usr/bin/env python3
"""Writes the meshes of the validation suite's hard cases (binary STL, metres) into this folder:

    drum.stl       open, zero-thickness washing-machine drum: a cylinder shell of radius 0.15 m and
                   length 0.16 m about the y axis (y from -0.08 to 0.08), closed by two end discs,
                   with 2 rings of 12 square holes (0.039 m x 0.04 m) in its mantle
                   (a thin shell, offset: none; tried for
                   case 6a, see docs/validation.md)
    drum_cage.stl  closed-solid washing-machine drum (used from outside, offset auto): 16 bars
                   0.02 m thick and 0.035 m wide at radius 0.15-0.17 m about the y axis, 0.16 m
                   long, with gaps of about 0.024 m between them, and two end discs 0.02 m thick
                   (config/validation/stability_drum.yaml)
    thin_cup.stl   open, zero-thickness cup 0.12 x 0.12 x 0.10 m (a bottom and four walls, no top),
                   bottom centre at the origin (config/validation/stability_cup.yaml)

The files are committed; this script documents them and remakes them:
    python3 meshes/validation/make_meshes.py
Standard library only.
"""
import importlib.util
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


# The STL writer of the demo meshes (meshes/make_meshes.py); loaded by path, as both files share a name.
_spec = importlib.util.spec_from_file_location("fluid_sim_meshes", os.path.join(HERE, "..", "make_meshes.py"))
_base = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_base)


normal = _base.normal


def write_stl(name, v, t):
    _base.write_stl(name, v, t, folder=HERE, title=f"fluid_sim validation {name}")


def drum(radius=0.15, length=0.16, sectors=48, rows=8, hole_rows=(2, 5), hole_every=4):
    """Cylinder shell about y with end discs. The mantle is a grid of sectors x rows quads
    (0.0196 m x 0.02 m each); each hole is 2 x 2 quads (0.039 m x 0.04 m) starting at a row of
    hole_rows and at every hole_every-th sector: 2 rings of 12 holes."""
    v = []
    for r in range(rows + 1):
        y = -0.5 * length + length * r / rows
        for j in range(sectors):
            phi = 2 * math.pi * j / sectors
            v.append((radius * math.cos(phi), y, radius * math.sin(phi)))
    t = []
    holes = set()
    for r0 in hole_rows:
        for j0 in range(0, sectors, hole_every):
            for dr in (0, 1):
                for dj in (0, 1):
                    holes.add((r0 + dr, j0 + dj))
    for r in range(rows):
        for j in range(sectors):
            if (r, j) in holes:
                continue
            a, b = r * sectors + j, r * sectors + (j + 1) % sectors
            c, d = b + sectors, a + sectors
            t += [(a, b, c), (a, c, d)]
    for r, sign in ((0, -1.0), (rows, 1.0)):  # end discs, fanned from a centre vertex
        centre = len(v)
        v.append((0.0, sign * 0.5 * length, 0.0))
        for j in range(sectors):
            a, b = r * sectors + j, r * sectors + (j + 1) % sectors
            t.append((centre, a, b) if sign > 0 else (centre, b, a))
    return v, t


def cup(width=0.12, height=0.10):
    h = 0.5 * width
    v = [(-h, -h, 0.0), (h, -h, 0.0), (h, h, 0.0), (-h, h, 0.0),
         (-h, -h, height), (h, -h, height), (h, h, height), (-h, h, height)]
    t = [(0, 2, 1), (0, 3, 2)]  # bottom
    for a in range(4):
        b = (a + 1) % 4
        t += [(a, b, b + 4), (a, b + 4, a + 4)]
    return v, t


def merge(*parts):
    v, t = [], []
    for pv, pt in parts:
        t += [tuple(i + len(v) for i in tri) for tri in pt]
        v += pv
    return v, t


def bar(phi, r0, r1, half_width, y0, y1):
    """Closed box, outward wound, radial extent r0..r1 at angle phi about the y axis."""
    c, s = math.cos(phi), math.sin(phi)
    v = []
    for i in range(8):
        r = r1 if i & 1 else r0
        w = half_width if i & 2 else -half_width
        y = y1 if i & 4 else y0
        # radial direction (c, 0, s), tangential (-s, 0, c)
        v.append((r * c - w * s, y, r * s + w * c))
    t = []
    for a, b, cc, d in [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]:
        t += [(a, b, cc), (a, cc, d)]
    # make every triangle face away from the box centre
    centre = [sum(p[k] for p in v) / 8 for k in range(3)]
    out = []
    for tri in t:
        n = normal(v, tri)
        m = [sum(v[i][k] for i in tri) / 3 - centre[k] for k in range(3)]
        out.append(tri if sum(n[k] * m[k] for k in range(3)) > 0 else (tri[0], tri[2], tri[1]))
    return v, out


def disc(radius, y0, y1, sides=32):
    """Closed regular prism about the y axis from y0 to y1, outward wound."""
    v = []
    for y in (y0, y1):
        for j in range(sides):
            phi = 2 * math.pi * (j + 0.5) / sides
            v.append((radius * math.cos(phi), y, radius * math.sin(phi)))
    v += [(0.0, y0, 0.0), (0.0, y1, 0.0)]
    lo, hi = 2 * sides, 2 * sides + 1
    t = []
    for j in range(sides):
        a, b = j, (j + 1) % sides
        t += [(a, b + sides, b), (a, a + sides, b + sides), (lo, a, b), (hi, b + sides, a + sides)]
    centre = (0.0, 0.5 * (y0 + y1), 0.0)
    out = []
    for tri in t:
        n = normal(v, tri)
        m = [sum(v[i][k] for i in tri) / 3 - centre[k] for k in range(3)]
        out.append(tri if sum(n[k] * m[k] for k in range(3)) > 0 else (tri[0], tri[2], tri[1]))
    return v, out


def cage(bars=16, r0=0.15, r1=0.17, bar_width=0.035, length=0.16, cap=0.02):
    """Closed solid drum: bars (radial 0.15-0.17 m, 0.035 m wide, gaps of about 0.024 m at the
    inner radius between them) along y from -length/2 to length/2, and two end discs of radius
    r1 and thickness cap; all parts closed and outward wound."""
    parts = [bar(2 * math.pi * (k + 0.5) / bars, r0, r1, 0.5 * bar_width, -0.5 * length, 0.5 * length)
             for k in range(bars)]
    parts += [disc(r1, -0.5 * length - cap, -0.5 * length), disc(r1, 0.5 * length, 0.5 * length + cap)]
    return merge(*parts)


if __name__ == "__main__":
    write_stl("drum.stl", *drum())
    write_stl("drum_cage.stl", *cage())
    write_stl("thin_cup.stl", *cup())
