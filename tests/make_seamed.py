#!/usr/bin/env python3
"""A seamed copy of a generated binary PLY (float x y z, uchar/int face
lists) for the out-of-core tests: each vertex split by the quadrant
(in x and y about the mean) of the triangles that use it, with texture
coordinates linear in the position plus the quadrant's offset (seams that
cross each other and the chunks' cuts) and colors linear in the position.
With --bare, the same split vertices without attributes (an export that
did not weld its vertices); with --normals, smooth vertex normals too (the
area-weighted normal of each position's triangles).
Standard library only.  usage: make_seamed.py [--bare|--normals] IN.ply OUT.ply"""
import struct
import sys


def smooth_normals(pos, tris, nv):
    acc = [0.0] * (3 * nv)
    for a, b, c in tris:
        ux, uy, uz = (pos[3 * b + k] - pos[3 * a + k] for k in range(3))
        vx, vy, vz = (pos[3 * c + k] - pos[3 * a + k] for k in range(3))
        n = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx)
        for v in (a, b, c):
            for k in range(3):
                acc[3 * v + k] += n[k]
    for v in range(nv):
        x, y, z = acc[3 * v:3 * v + 3]
        ln = (x * x + y * y + z * z) ** 0.5 or 1.0
        acc[3 * v:3 * v + 3] = [x / ln, y / ln, z / ln]
    return acc


def main(src, dst, bare=False, normals=False):
    data = open(src, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").split("\n")
    nv = nf = 0
    for line in header:
        if line.startswith("element vertex"):
            nv = int(line.split()[2])
        elif line.startswith("element face"):
            nf = int(line.split()[2])
    pos = struct.unpack_from("<%df" % (3 * nv), data, end)
    at = end + 12 * nv
    tris = []
    for _ in range(nf):
        n = data[at]
        if n != 3:
            raise SystemExit("%s: only triangles" % src)
        tris.append(struct.unpack_from("<3i", data, at + 1))
        at += 13
    cx = sum(pos[0::3]) / nv
    cy = sum(pos[1::3]) / nv
    ids = {}
    verts = []
    faces = []
    for a, b, c in tris:
        x = (pos[3 * a] + pos[3 * b] + pos[3 * c]) / 3
        y = (pos[3 * a + 1] + pos[3 * b + 1] + pos[3 * c + 1]) / 3
        side = (x > cx) + 2 * (y > cy)
        face = []
        for v in (a, b, c):
            key = 4 * v + side
            if key not in ids:
                ids[key] = len(verts)
                verts.append((v, side))
            face.append(ids[key])
        faces.append(face)
    out = bytearray()
    out += ("ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
            "property float x\nproperty float y\nproperty float z\n"
            % len(verts)).encode("ascii")
    if normals:
        out += b"property float nx\nproperty float ny\nproperty float nz\n"
        nrm = smooth_normals(pos, tris, nv)
    if not bare:
        out += (b"property float s\nproperty float t\n"
                b"property uchar red\nproperty uchar green\nproperty uchar blue\n")
    out += ("element face %d\nproperty list uchar int vertex_indices\nend_header\n"
            % len(faces)).encode("ascii")
    for v, side in verts:
        x, y, z = pos[3 * v:3 * v + 3]
        u = x * 0.01 + 0.5 * (side & 1)
        w = y * 0.01 + 0.5 * (side >> 1)
        r = max(0, min(255, int(128 + x)))
        g = max(0, min(255, int(128 + y)))
        if normals:
            out += struct.pack("<6f", x, y, z, *nrm[3 * v:3 * v + 3])
        else:
            out += struct.pack("<3f", x, y, z)
        if not bare:
            out += struct.pack("<2f3B", u, w, r, g, 64)
    for f in faces:
        out += struct.pack("<B3i", 3, *f)
    open(dst, "wb").write(bytes(out))


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a not in ("--bare", "--normals")]
    if len(args) != 2:
        raise SystemExit(__doc__)
    main(args[0], args[1], bare="--bare" in sys.argv[1:], normals="--normals" in sys.argv[1:])
