"""Issue 14's comparison with Mitsuba 3: one sphere of a rough material under a uniform sky.

Why: lumen's microfacet materials (GGX, Smith height-correlated masking, visible-normal
sampling) are meant to be the standard ones, so with lumen's energy compensation turned off
(`.multiple_scattering 0`) a sphere must render as Mitsuba's `roughconductor`,
`roughdielectric` and `roughplastic` render it: this script checks that the image means
agree within 1 %, and shows what the compensation adds on top.

    python3 benches/mitsuba/rough_sphere.py --lumen ./target/release/lumen [--device cpu|gpu]

Scene (both sides): the default lumen camera (eye at (-1, 0, 0) looking along +x, z up,
vertical field of view 2 atan(1/1) = 90 degrees, square image), a sphere of radius 1.5 at
(2, 0, 0), a uniform environment of radiance 1, a path tracer without Russian roulette and
with lumen max_depth 64 (Mitsuba max_depth 65: Mitsuba counts segments, lumen scattering
vertices; see cornell.py), box-filtered pixel samples. Roughness is GGX alpha on both sides.

Masking-shadowing differs at high roughness: Mitsuba 3's `MicrofacetDistribution::G` is the
separable product G1(wi) G1(wo), lumen's the height-correlated 1/(1 + L(wi) + L(wo)) (Heitz
2014, what issue 14 asks for), which is never smaller (at alpha = 1, wi = (0.6, 0, 0.8),
wo = (-0.28, 0, 0.96): 0.87075 against 0.87273). The gap grows with alpha, so the means are
asserted within 1 % up to alpha = 0.5 and reported at alpha = 1.

The plastics are different models: lumen's base is seen through the coat with the coat's
directional albedo (1 - E_R(mu_o))(1 - E_R(mu_i)), Mitsuba's `roughplastic` weighs it by the
Fresnel transmittance of a precomputed table and its own internal-reflection term; their
means are reported, not asserted.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")

import mitsuba as mi  # noqa: E402

ROUGHNESS = [0.05, 0.2, 0.5, 1.0]
# Gold, as src/optics/metals.rs tabulates it (both renderers get these RGB values).
GOLD_ETA = (0.1431189557, 0.3749570432, 1.4424785571)
GOLD_K = (3.9831604247, 2.3857207478, 1.6032152899)
PLASTIC_RGB = (0.7, 0.12, 0.1)


def materials(alpha: float):
    """(name, lumen SceneLang BRDF, Mitsuba BSDF dict, whether the means must agree)."""
    rgb = lambda v: {"type": "rgb", "value": list(v)}  # noqa: E731
    eta, k = "<%g, %g, %g>" % GOLD_ETA, "<%g, %g, %g>" % GOLD_K
    return [
        (
            "conductor F = 1",
            f"Brdf.Conductor(.roughness {alpha}, .multiple_scattering 0)",
            {"type": "roughconductor", "distribution": "ggx", "alpha": alpha, "material": "none"},
            True,
        ),
        (
            "gold",
            f"Brdf.Conductor(.roughness {alpha}, .eta {eta}, .k {k}, .multiple_scattering 0)",
            {"type": "roughconductor", "distribution": "ggx", "alpha": alpha, "eta": rgb(GOLD_ETA), "k": rgb(GOLD_K)},
            True,
        ),
        (
            "glass ior 1.5",
            f"Brdf.Dielectric(.ior 1.5, .roughness {alpha}, .multiple_scattering 0)",
            {"type": "roughdielectric", "distribution": "ggx", "alpha": alpha, "int_ior": 1.5, "ext_ior": 1.0},
            True,
        ),
        (
            "red plastic ior 1.5",
            "Brdf.Plastic(.pigment <%g, %g, %g>, .ior 1.5, .roughness %g)" % (*PLASTIC_RGB, alpha),
            {
                "type": "roughplastic",
                "distribution": "ggx",
                "alpha": alpha,
                "int_ior": 1.5,
                "ext_ior": 1.0,
                "diffuse_reflectance": rgb(PLASTIC_RGB),
                "nonlinear": False,
            },
            False,
        ),
    ]


def mitsuba_mean(bsdf: dict, size: int, spp: int) -> float:
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 65, "rr_depth": 1000},
            "sensor": {
                "type": "perspective",
                "fov": 90.0,
                "fov_axis": "y",
                "near_clip": 1.0,
                "to_world": mi.ScalarTransform4f().look_at(origin=[-1, 0, 0], target=[0, 0, 0], up=[0, 0, 1]),
                "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}},
                "sampler": {"type": "independent", "sample_count": spp},
            },
            "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}},
            "ball": {"type": "sphere", "center": [2, 0, 0], "radius": 1.5, "bsdf": bsdf},
        }
    )
    return float(np.mean(np.array(mi.render(scene, spp=spp))))


def read_pfm(path: Path) -> np.ndarray:
    data = path.read_bytes()
    header, rest = data.split(b"\n", 1)
    dims, rest = rest.split(b"\n", 1)
    scale, rest = rest.split(b"\n", 1)
    w, h = map(int, dims.split())
    endian = "<" if float(scale) < 0 else ">"
    return np.frombuffer(rest[: w * h * 12], dtype=endian + "f4").reshape(h, w, 3)


def lumen_mean(lumen: str, device: str, brdf: str, size: int, spp: int, tmp: Path) -> float:
    side = max(1, int(round(spp**0.5)))
    script = tmp / "ball.sl"
    script.write_text(
        f"SPAWN Shape.Sphere(Material({brdf}), .transformation TRANSLATE(2, 0, 0) * SCALE 1.5)\n"
        f"USING Camera.Perspective() Image({size}, {size}) Tracer(.samples_per_side {side})\n"
        "      Renderer.PathTracer(.n 1, .max_depth 64, .roulette_depth 1000)\n"
        "      Environment.Uniform(.color <1, 1, 1>)\n"
    )
    out = tmp / "ball.pfm"
    subprocess.run([lumen, "render", str(script), "--device", device, "-o", str(out)], check=True, capture_output=True)
    return float(np.mean(read_pfm(out)))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--lumen", default="./target/release/lumen")
    p.add_argument("--device", default="cpu", choices=["cpu", "gpu"])
    p.add_argument("--variant", default="llvm_ad_rgb")
    p.add_argument("--size", type=int, default=64)
    p.add_argument("--spp", type=int, default=1024)
    a = p.parse_args(argv)
    mi.set_variant(a.variant)
    failed = []
    print(f"| material | alpha | lumen single scattering ({a.device}) | Mitsuba {a.variant} | difference | lumen compensated |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for alpha in ROUGHNESS:
            for name, brdf, bsdf, strict in materials(alpha):
                ours = lumen_mean(a.lumen, a.device, brdf, a.size, a.spp, tmp)
                theirs = mitsuba_mean(bsdf, a.size, a.spp)
                compensated = lumen_mean(a.lumen, a.device, brdf.replace(", .multiple_scattering 0", ""), a.size, a.spp, tmp)
                diff = ours / theirs - 1.0
                strict = strict and alpha <= 0.5
                mark = "" if not strict or abs(diff) < 0.01 else " **over 1 %**"
                if strict and abs(diff) >= 0.01:
                    failed.append(f"{name} alpha {alpha}")
                print(f"| {name} | {alpha} | {ours:.4f} | {theirs:.4f} | {100 * diff:+.2f} %{mark} | {compensated:.4f} |")
                sys.stdout.flush()
    if failed:
        print("means differ by 1 % or more: " + ", ".join(failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
