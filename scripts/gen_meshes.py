#!/usr/bin/env python3
"""Generate the triangle meshes that scenes/meshes.sl renders (issue 13).

Writes, into scenes/meshes/ (next to this repository's scenes/):

- torus_knot.obj  A (p=2, q=3) torus knot (the trefoil) swept as a round tube: 448
                  segments along the knot x 32 around the tube = 28 672 triangles.
                  Smooth: every vertex has a normal (`vn`) and a uv (`vt`), faces are
                  `f v/vt/vn`. Its box, 1.85 x 1.94 x 0.84 units, is centred at the origin,
                  z up (the knot winds around the z axis). The tube is swept
                  along a rotation-minimising frame (double reflection, Wang et al. 2008),
                  closed up by spreading the loop's residual twist evenly, so its facets do
                  not spiral. Normals are analytic: a tube of constant radius rho about a
                  curve c has, at the point c + rho*n, the unit normal n. u runs along the
                  knot, v around the tube; positions and normals are shared across the
                  seams, uvs are not (u = 1 and v = 1 get their own `vt`).
- panel.ply       An ASCII PLY of the flat square [-0.5, 0.5]^2 in the z = 0 plane as a
                  4 x 4 grid of quads (25 vertices, 32 triangles), normals +z, uvs in
                  [0, 1]^2: an emissive mesh light (scenes/meshes.sl turns it face down).
- icosphere.ply   A binary little-endian PLY of the unit sphere: an icosahedron subdivided 3
                  times (642 vertices, 1280 triangles), vertices on the sphere, normals equal
                  to the positions. With panel.ply, both PLY encodings are exercised.

Why generated rather than downloaded: the repository ships no third-party model whose
licence would need tracking, and the files are reproducible. The script uses the Python 3
standard library only and is deterministic: no randomness, fixed vertex order, fixed
decimal precision (-0 written as 0), so running it again rewrites byte-identical files.
All faces wind counter-clockwise seen from outside (the geometric normal agrees with the
vertex normals), and no triangle is degenerate.

Usage: python3 scripts/gen_meshes.py [OUTPUT_DIR]   (default: scenes/meshes)
"""

import math
import os
import struct
import sys

# Torus knot: the curve ((R + a cos(q t)) cos(p t), (R + a cos(q t)) sin(p t), a sin(q t)),
# t in [0, 2 pi), swept by a circle of radius RHO.
P, Q = 2, 3
R_MAJOR, R_MINOR, RHO = 0.6, 0.3, 0.12
SEGMENTS, SIDES = 448, 32  # 2 * 448 * 32 = 28 672 triangles

DECIMALS = 6


# --- small vector helpers (tuples of floats) -----------------------------------------------


def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def mul(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normalize(a):
    n = math.sqrt(dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def fmt(x, decimals=DECIMALS):
    s = f"{x:.{decimals}f}"
    if s.startswith("-") and float(s) == 0.0:
        s = s[1:]  # no "-0.000000"
    return s


def fmt3(v, decimals=DECIMALS):
    return " ".join(fmt(c, decimals) for c in v)


# --- torus knot ----------------------------------------------------------------------------


def knot_point(t):
    r = R_MAJOR + R_MINOR * math.cos(Q * t)
    return (r * math.cos(P * t), r * math.sin(P * t), R_MINOR * math.sin(Q * t))


def knot_tangent(t):
    r = R_MAJOR + R_MINOR * math.cos(Q * t)
    dr = -Q * R_MINOR * math.sin(Q * t)
    return normalize(
        (
            dr * math.cos(P * t) - P * r * math.sin(P * t),
            dr * math.sin(P * t) + P * r * math.cos(P * t),
            Q * R_MINOR * math.cos(Q * t),
        )
    )


def rotate_about(v, axis, angle):
    """Rodrigues' rotation of v about the unit axis."""
    c, s = math.cos(angle), math.sin(angle)
    return add(add(mul(v, c), mul(cross(axis, v), s)), mul(axis, dot(axis, v) * (1.0 - c)))


def knot_frames():
    """Points, tangents and normal vectors n_i (n_i . t_i = 0) of a closed
    rotation-minimising frame at t_i = 2 pi i / SEGMENTS, i = 0 .. SEGMENTS - 1."""
    ts = [2.0 * math.pi * i / SEGMENTS for i in range(SEGMENTS + 1)]
    pts = [knot_point(t) for t in ts]
    tans = [knot_tangent(t) for t in ts]
    # First normal: the component of +z orthogonal to the tangent (never parallel here).
    t0 = tans[0]
    n = normalize(sub((0.0, 0.0, 1.0), mul(t0, t0[2])))
    normals = [n]
    for i in range(SEGMENTS):  # double reflection (Wang, Juettler, Zheng, Liu 2008)
        v1 = sub(pts[i + 1], pts[i])
        c1 = dot(v1, v1)
        n_l = sub(n, mul(v1, 2.0 * dot(v1, n) / c1))
        t_l = sub(tans[i], mul(v1, 2.0 * dot(v1, tans[i]) / c1))
        v2 = sub(tans[i + 1], t_l)
        c2 = dot(v2, v2)
        n = sub(n_l, mul(v2, 2.0 * dot(v2, n_l) / c2))
        # Re-orthonormalise against the exact tangent (removes round-off drift).
        n = normalize(sub(n, mul(tans[i + 1], dot(n, tans[i + 1]))))
        normals.append(n)
    # After the loop the frame has turned by `twist` about the (same) tangent; undo it
    # progressively so that frame SEGMENTS equals frame 0.
    end = normals[SEGMENTS]
    twist = math.atan2(dot(cross(end, normals[0]), tans[0]), dot(end, normals[0]))
    frames = []
    for i in range(SEGMENTS):
        ni = rotate_about(normals[i], tans[i], twist * i / SEGMENTS)
        frames.append((pts[i], tans[i], ni))
    return frames


def write_torus_knot(path):
    frames = knot_frames()
    positions, normals = [], []
    for c, t, n in frames:
        b = cross(t, n)
        for j in range(SIDES):
            phi = 2.0 * math.pi * j / SIDES
            d = add(mul(n, math.cos(phi)), mul(b, math.sin(phi)))
            positions.append(add(c, mul(d, RHO)))
            normals.append(d)
    # The trefoil is 3-fold symmetric, so its box is not centred on the axis: centre it.
    lo = [min(p[k] for p in positions) for k in range(3)]
    hi = [max(p[k] for p in positions) for k in range(3)]
    centre = tuple(0.5 * (lo[k] + hi[k]) for k in range(3))
    positions = [sub(p, centre) for p in positions]

    def vid(i, j):  # 1-based position/normal index, wrapping at the seams
        return (i % SEGMENTS) * SIDES + (j % SIDES) + 1

    def tid(i, j):  # 1-based uv index, (SEGMENTS + 1) x (SIDES + 1), no wrap
        return i * (SIDES + 1) + j + 1

    lines = [
        "# (2, 3) torus knot tube, generated by scripts/gen_meshes.py; do not edit.",
        f"# {len(positions)} vertices, {2 * SEGMENTS * SIDES} triangles; z up, centred at the origin.",
        "o torus_knot",
    ]
    lines += ["v " + fmt3(p) for p in positions]
    lines += [
        "vt " + fmt(i / SEGMENTS) + " " + fmt(j / SIDES) for i in range(SEGMENTS + 1) for j in range(SIDES + 1)
    ]
    lines += ["vn " + fmt3(n) for n in normals]
    lines.append("s 1")

    def corner(i, j):
        v = vid(i, j)
        return f"{v}/{tid(i, j)}/{v}"

    # Quad (i, j) -> (i+1, j+1). The side angle phi turns anticlockwise about the tangent
    # t (d = cos(phi) n + sin(phi) b, b = t x n), so dP/dphi x dP/dt points along +d,
    # outwards: the order (i,j), (i,j+1), (i+1,j+1) winds counter-clockwise seen from
    # outside the tube.
    for i in range(SEGMENTS):
        for j in range(SIDES):
            a, b, c, d = corner(i, j), corner(i, j + 1), corner(i + 1, j + 1), corner(i + 1, j)
            lines.append(f"f {a} {b} {c}")
            lines.append(f"f {a} {c} {d}")
    write_text(path, lines)
    return len(positions), 2 * SEGMENTS * SIDES


# --- panel ---------------------------------------------------------------------------------

PANEL_N = 4


def write_panel(path):
    verts = []
    for j in range(PANEL_N + 1):
        for i in range(PANEL_N + 1):
            u, v = i / PANEL_N, j / PANEL_N
            verts.append((u - 0.5, v - 0.5, 0.0, u, v))
    faces = []
    for j in range(PANEL_N):
        for i in range(PANEL_N):
            a = j * (PANEL_N + 1) + i
            b, c, d = a + 1, a + PANEL_N + 2, a + PANEL_N + 1
            faces += [(a, b, c), (a, c, d)]  # counter-clockwise seen from +z
    lines = [
        "ply",
        "format ascii 1.0",
        "comment 1 x 1 panel in the z = 0 plane, normal +z; generated by scripts/gen_meshes.py",
        f"element vertex {len(verts)}",
        "property float x",
        "property float y",
        "property float z",
        "property float nx",
        "property float ny",
        "property float nz",
        "property float u",
        "property float v",
        f"element face {len(faces)}",
        "property list uchar int vertex_indices",
        "end_header",
    ]
    for x, y, z, u, v in verts:
        lines.append(" ".join(fmt(c, 4) for c in (x, y, z, 0.0, 0.0, 1.0, u, v)))
    for f in faces:
        lines.append("3 " + " ".join(str(k) for k in f))
    write_text(path, lines)
    return len(verts), len(faces)


# --- icosphere -----------------------------------------------------------------------------

ICO_SUBDIVISIONS = 3


def icosphere(levels):
    g = (1.0 + math.sqrt(5.0)) / 2.0
    verts = [
        normalize(v)
        for v in [
            (-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0),
            (0, -1, g), (0, 1, g), (0, -1, -g), (0, 1, -g),
            (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1),
        ]  # fmt: skip
    ]
    faces = [
        (0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
        (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
        (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
        (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1),
    ]  # fmt: skip
    for _ in range(levels):
        mid = {}

        def midpoint(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                mid[key] = len(verts)
                verts.append(normalize(mul(add(verts[a], verts[b]), 0.5)))
            return mid[key]

        new_faces = []
        for a, b, c in faces:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            new_faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new_faces
    return verts, faces


def write_icosphere(path):
    verts, faces = icosphere(ICO_SUBDIVISIONS)
    header = "\n".join(
        [
            "ply",
            "format binary_little_endian 1.0",
            f"comment unit icosphere, {ICO_SUBDIVISIONS} subdivisions; generated by scripts/gen_meshes.py",
            f"element vertex {len(verts)}",
            "property float x",
            "property float y",
            "property float z",
            "property float nx",
            "property float ny",
            "property float nz",
            f"element face {len(faces)}",
            "property list uchar int vertex_indices",
            "end_header",
        ]
    )
    out = bytearray(header.encode("ascii") + b"\n")
    for v in verts:
        out += struct.pack("<6f", *v, *v)
    for f in faces:
        out += struct.pack("<B3i", 3, *f)
    write_bytes(path, bytes(out))
    return len(verts), len(faces)


# --- output --------------------------------------------------------------------------------


def write_text(path, lines):
    write_bytes(path, ("\n".join(lines) + "\n").encode("ascii"))


def write_bytes(path, data):
    with open(path, "wb") as f:
        f.write(data)


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "scenes", "meshes")
    os.makedirs(out, exist_ok=True)
    for name, write in [
        ("torus_knot.obj", write_torus_knot),
        ("panel.ply", write_panel),
        ("icosphere.ply", write_icosphere),
    ]:
        path = os.path.join(out, name)
        nv, nt = write(path)
        print(f"{path}: {nv} vertices, {nt} triangles, {os.path.getsize(path)} bytes")


if __name__ == "__main__":
    main()
