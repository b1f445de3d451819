#!/usr/bin/env python3
"""Splits the conference room OBJ into one binary little-endian PLY per material.

Usage: python3 convert.py PATH/TO/conference.obj PATH/TO/conference.mtl [OUT_DIR]

Plain Python 3, no packages, no network. For each `usemtl` material it writes
OUT_DIR/meshes/<material>.ply with only the vertices that material's faces use
(positions scaled by 0.003 to metres, float32) and triangles only: each OBJ face
is fan-triangulated, (0, 1, 2), (0, 2, 3), ..., in its own winding (the OBJ has
342 quads among its triangles, and Mitsuba 3's PLY reader takes triangles only);
texture coordinates are dropped. It prints one line per material: name, OBJ
faces, triangles written, vertices, and the MTL's Kd, which the scene file uses
as the diffuse reflectance. Empty materials are skipped.
"""

import os
import struct
import sys

SCALE = 0.003  # the model's units to metres (copyright.txt)


def read_mtl(path):
    kd = {}
    name = None
    with open(path, encoding="latin-1") as f:
        for line in f:
            t = line.split()
            if not t:
                continue
            if t[0] == "newmtl":
                name = t[1]
            elif t[0] == "Kd" and name is not None:
                # mesh29_SG has two Kd lines (a dark wood, then 1 1 1); keep the first.
                kd.setdefault(name, tuple(float(x) for x in t[1:4]))
    return kd


def read_obj(path):
    positions = []
    faces = {}  # material -> list of faces (0-based position indices)
    order = []
    current = "default"
    with open(path, encoding="latin-1") as f:
        for line in f:
            if line.startswith("v "):
                x, y, z = (float(v) for v in line.split()[1:4])
                positions.append((x * SCALE, y * SCALE, z * SCALE))
            elif line.startswith("usemtl "):
                current = line.split()[1]
            elif line.startswith("f "):
                idx = []
                for corner in line.split()[1:]:
                    i = int(corner.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(positions) + i)
                if current not in faces:
                    faces[current] = []
                    order.append(current)
                faces[current].append(idx)
    return positions, faces, order


def write_ply(path, positions, faces):
    remap = {}
    verts = []
    out_faces = []
    for face in faces:
        g = []
        for i in face:
            if i not in remap:
                remap[i] = len(verts)
                verts.append(positions[i])
            g.append(remap[i])
        # Fan-triangulate (Mitsuba 3 reads triangle PLYs only).
        out_faces.extend([g[0], g[k], g[k + 1]] for k in range(1, len(g) - 1))
    header = (
        "ply\n"
        "format binary_little_endian 1.0\n"
        "comment conference room (LBNL), one material; metres, y up; see SOURCE.md\n"
        f"element vertex {len(verts)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        f"element face {len(out_faces)}\n"
        "property list uchar int vertex_indices\n"
        "end_header\n"
    )
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(b"".join(struct.pack("<3f", *v) for v in verts))
        f.write(b"".join(struct.pack("<B3i", 3, *g) for g in out_faces))
    return len(verts), len(out_faces)


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    obj, mtl = sys.argv[1], sys.argv[2]
    out = sys.argv[3] if len(sys.argv) == 4 else os.path.dirname(os.path.abspath(__file__))
    os.makedirs(os.path.join(out, "meshes"), exist_ok=True)
    kd = read_mtl(mtl)
    positions, faces, order = read_obj(obj)
    lo = [min(p[k] for p in positions) for k in range(3)]
    hi = [max(p[k] for p in positions) for k in range(3)]
    print(f"bounds (m): {lo} .. {hi}")
    total = 0
    for name in order:
        n, tris = write_ply(os.path.join(out, "meshes", name + ".ply"), positions, faces[name])
        total += tris
        k = kd.get(name, (0.5, 0.5, 0.5))
        print(f"{name:12} {len(faces[name]):7} faces {tris:7} triangles {n:7} vertices  Kd {k[0]:.6f} {k[1]:.6f} {k[2]:.6f}")
    print(f"{total} triangles in all")


if __name__ == "__main__":
    main()
