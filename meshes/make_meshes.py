#!/usr/bin/env python3
"""Writes the meshes of the shipped scenes (binary STL, metres) into this folder:

    paddle_base.stl   closed box 0.12 x 0.12 x 0.06, centred        (urdf/paddle_robot.urdf, link base)
    paddle_arm.stl    closed beam 0.04 x 0.04 x 0.25 hanging down    (link arm)
    paddle_blade.stl  open, zero-thickness blade 0.16 x 0.12         (link paddle: a thin shell)
    octagon_tank.stl  closed octagonal prism, radius 0.3, 0.4 high   (config/mesh_tank.yaml, inside)

The files are committed; this script documents them and remakes them:
    python3 meshes/make_meshes.py
Standard library only.
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def box(lo, hi):
    v = [(hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1], hi[2] if i & 4 else lo[2]) for i in range(8)]
    t = []
    for a, b, c, d in [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]:
        t += [(a, b, c), (a, c, d)]
    return v, t


def prism(radius, height, sides):
    """Closed regular prism about the z axis from z = 0 to height, outward."""
    v = []
    for z in (0.0, height):
        for j in range(sides):
            phi = 2 * math.pi * (j + 0.5) / sides
            v.append((radius * math.cos(phi), radius * math.sin(phi), z))
    v += [(0.0, 0.0, 0.0), (0.0, 0.0, height)]
    bottom, top = 2 * sides, 2 * sides + 1
    t = []
    for j in range(sides):
        a, b = j, (j + 1) % sides
        t += [(a, b, b + sides), (a, b + sides, a + sides), (bottom, b, a), (top, a + sides, b + sides)]
    return v, t


def normal(v, tri):
    a, b, c = (v[i] for i in tri)
    u = [b[k] - a[k] for k in range(3)]
    w = [c[k] - a[k] for k in range(3)]
    n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
    length = math.sqrt(sum(x * x for x in n)) or 1.0
    return [x / length for x in n]


def write_stl(name, v, t, folder=HERE, title=None):
    """Binary STL `folder/name` from vertices v and triangles t (80-byte header `title`)."""
    with open(os.path.join(folder, name), "wb") as f:
        f.write((title or f"fluid_sim {name}").encode().ljust(80, b" "))
        f.write(struct.pack("<I", len(t)))
        for tri in t:
            f.write(struct.pack("<3f", *normal(v, tri)))
            for i in tri:
                f.write(struct.pack("<3f", *v[i]))
            f.write(struct.pack("<H", 0))


def main():
    write_stl("paddle_base.stl", *box((-0.06, -0.06, -0.03), (0.06, 0.06, 0.03)))
    write_stl("paddle_arm.stl", *box((-0.02, -0.02, -0.25), (0.02, 0.02, 0.0)))
    # The blade: a single sheet in the x-z plane, 0.16 wide, from z = 0 down to z = -0.12; its two
    # triangles share a diagonal, its four edges are open.
    write_stl("paddle_blade.stl", [(-0.08, 0.0, 0.0), (0.08, 0.0, 0.0), (0.08, 0.0, -0.12), (-0.08, 0.0, -0.12)],
              [(0, 1, 2), (0, 2, 3)])
    write_stl("octagon_tank.stl", *prism(0.3, 0.4, 8))


if __name__ == "__main__":
    main()
