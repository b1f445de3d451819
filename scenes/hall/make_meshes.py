#!/usr/bin/env python3
"""Writes the hall's finely tessellated meshes (binary little-endian PLY, triangles):
eight columns (48 sides x 40 rings each, 30,720 triangles) and a sphere on the floor
(96 x 48, 9,024 triangles). Run from anywhere; it writes next to itself in meshes/."""
import math
import struct
from pathlib import Path

OUT = Path(__file__).resolve().parent / "meshes"


def column(cx, cz, r, h, sides=48, rings=40):
    vs = [(cx + r * math.cos(2 * math.pi * i / sides), h * j / rings, cz + r * math.sin(2 * math.pi * i / sides))
          for j in range(rings + 1) for i in range(sides)]
    fs = []
    for j in range(rings):
        for i in range(sides):
            a, b = j * sides + i, j * sides + (i + 1) % sides
            c, d = b + sides, a + sides
            fs += [(a, d, c), (a, c, b)]  # wound outwards
    return vs, fs


def sphere(cx, cy, cz, r, nu=96, nv=48):
    vs = [(cx, cy + r, cz)]
    for j in range(1, nv):
        t = math.pi * j / nv
        vs += [(cx + r * math.sin(t) * math.cos(2 * math.pi * i / nu), cy + r * math.cos(t),
                cz + r * math.sin(t) * math.sin(2 * math.pi * i / nu)) for i in range(nu)]
    vs.append((cx, cy - r, cz))
    at = lambda j, i: 1 + (j - 1) * nu + i % nu
    fs = [(0, at(1, i + 1), at(1, i)) for i in range(nu)]
    for j in range(1, nv - 1):
        for i in range(nu):
            fs += [(at(j, i), at(j, i + 1), at(j + 1, i + 1)), (at(j, i), at(j + 1, i + 1), at(j + 1, i))]
    fs += [(len(vs) - 1, at(nv - 1, i), at(nv - 1, i + 1)) for i in range(nu)]
    return vs, fs


def write(name, parts):
    vs, fs = [], []
    for pv, pf in parts:
        fs += [tuple(k + len(vs) for k in f) for f in pf]
        vs += pv
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(vs)}\n"
            "property float x\nproperty float y\nproperty float z\n"
            f"element face {len(fs)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(OUT / f"{name}.ply", "wb") as f:
        f.write(head.encode())
        f.write(b"".join(struct.pack("<3f", *v) for v in vs))
        f.write(b"".join(struct.pack("<B3i", 3, *t) for t in fs))
    return len(fs)


if __name__ == "__main__":
    OUT.mkdir(exist_ok=True)
    n = write("columns", [column(x, z, 0.3, 5.0) for x in (-6, -2, 2, 6) for z in (-3, 3)])
    n += write("sphere", [sphere(0.0, 1.0, 0.0, 0.8)])
    print(f"{n} triangles in {OUT}")
