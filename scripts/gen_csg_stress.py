#!/usr/bin/env python3
"""Writes the CSG stress scenes of BENCHMARKS.md ("GPU CSG sweeps") into a directory.

- chainK.sl: `a_k = DIFF(a_{k-1}, a_{k-1})` from one sphere (2^K copies, an empty solid
  whose crossings all tie and stay hidden), fused with a sphere behind it; Flat, 12x8.
- fuse1000.sl: a path-traced FUSE of 1,000 disjoint spheres in a 10x10x10 block, 48x32.

Usage: python3 scripts/gen_csg_stress.py OUT_DIR [K ...]   (K defaults to 10 12 14 16)
"""
import pathlib
import sys


def chain(k):
    lines = ["SET", "    m Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.3, 0.2>)))",
             "    a0 Shape.Sphere(.material m)"]
    lines += [f"    a{i} DIFF(a{i - 1}, a{i - 1})" for i in range(1, k + 1)]
    lines += ["SPAWN",
              f"    FUSE(a{k}, Shape.Sphere(.material m, .transformation TRANSLATE(.X 2.5)),"
              " .transformation TRANSLATE(.X 3))",
              "USING", "    Camera.Perspective(.aspect_ratio 1.5, .screen_distance 1)", "    Image(12, 8)",
              "    Renderer.Flat()", "    Tracer(.samples_per_side 1)", ""]
    return "\n".join(lines)


def fuse1000():
    spheres = []
    for i in range(1000):
        x, y, z = i % 10, (i // 10) % 10, i // 100
        m = "grey" if i % 2 == 0 else "red"
        spheres.append(f"Shape.Sphere(.material {m}, .transformation "
                       f"TRANSLATE({0.2 + 0.2 * x:.2f}, {-0.9 + 0.2 * y:.2f}, {-0.9 + 0.2 * z:.2f}) * SCALE 0.12)")
    lines = ["SET", "    grey Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.7, 0.7, 0.7>)))",
             "    red Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.2, 0.1>)))", "SPAWN",
             "    FUSE(" + ",\n         ".join(spheres) + ", .transformation TRANSLATE(.X 2))",
             "    Shape.Plane(.material grey, .transformation TRANSLATE(.Z -1.5))", "USING",
             "    Camera.Perspective(.aspect_ratio 1.5, .screen_distance 1)", "    Image(48, 32)",
             "    Renderer.PathTracer(.n 1, .max_depth 3)", "    Tracer(.samples_per_side 1)",
             "    Environment.Uniform(<0.3, 0.35, 0.4>)", ""]
    return "\n".join(lines)


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    for k in [int(a) for a in sys.argv[2:]] or [10, 12, 14, 16]:
        (out / f"chain{k}.sl").write_text(chain(k))
    (out / "fuse1000.sl").write_text(fuse1000())


if __name__ == "__main__":
    main()
