"""Mitsuba 3 twin of lumen's `scenes/cornell.sl`, for issue 12's performance goal 2.

Why: to compare lumen with an established renderer, both must render the *same* image,
so this module rebuilds the Cornell box as a Mitsuba scene dict by hand, converting every
lumen convention explicitly (each one is explained where it is applied, and
`benches/mitsuba_vs_lumen.py` checks them by comparing images). Import it and call
`scene_dict(...)`, or run it to write one render:

    python3 benches/mitsuba/cornell.py --width 128 --spp 64 -o cornell_mitsuba.pfm

Conventions converted (lumen side: src/scene/*.rs, src/cpu/path_tracer.rs):
- Shape.Cube is the unit cube [-0.5, 0.5]^3; Mitsuba's `cube` spans [-1, 1]^3, so every
  cube gets an extra scale(0.5) applied first. SceneLang's `A * B` applies B first, as a
  Mitsuba `Transform4f` product does; ROTATE is right-handed in degrees, like `rotate`.
- Materials are Lambertian with linear RGB albedos; in an `*_rgb` variant Mitsuba uses
  `rgb` values as given (no spectral upsampling), for reflectance and for radiance.
- The lamp is a closed flat cube whose material emits on every face (lumen's emission does
  not depend on the side, but only the outward sides of a closed cube can be seen from
  outside it), so a Mitsuba `area` emitter on the cube mesh (outward faces) is the same
  light. It also reflects (diffuse 0.78), so it gets a `diffuse` BSDF as well.
- Camera.Perspective(screen_distance d, aspect_ratio a): in camera space the eye is at
  (-d, 0, 0), looking along +x with z up, through a screen at x = 0 spanning y in [-a, a]
  and z in [-1, 1]; u = 0 (the image's left) is +y. So the vertical field of view is
  2 atan(1/d), the sensor sits at the camera transform's image of (-d, 0, 0) and looks
  along its +x with its +z up (Mitsuba's `look_at` puts +y on the image's left too).
  Points before the screen are not seen (camera rays start at t = 1), i.e. a near clip
  plane at distance d.
- Pixel samples are jittered uniformly inside their pixel (a box filter of one pixel).
- lumen's max_depth counts scattering vertices (0: only emitters seen directly), Mitsuba's
  counts path segments (1: only emitters seen directly): mitsuba = lumen + 1. Likewise
  Russian roulette starts after lumen's vertex `roulette_depth` (0 = the first surface),
  which is Mitsuba's rr_depth = roulette_depth + 1. (The two renderers' roulette
  probabilities differ; both are unbiased, so only the noise differs.)
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

# Mitsuba's LLVM backend finds libLLVM through this variable; Debian's libllvm19 puts it here.
os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")

import mitsuba as mi  # noqa: E402  (after the environment is set)

# The values of scenes/cornell.sl (keep in step with that file).
ALBEDO = {
    "white": (0.73, 0.73, 0.73),
    "red": (0.65, 0.05, 0.05),
    "green": (0.12, 0.45, 0.15),
    "lamp": (0.78, 0.78, 0.78),
}
LAMP_RADIANCE = (17.0, 12.0, 4.0)
THICKNESS = 0.05
SCREEN_DISTANCE = 2.5
ASPECT_RATIO = 1.0
CAMERA_TRANSLATION = (-0.15, 0.0, 1.0)
MAX_DEPTH = 6
ROULETTE_DEPTH = 3
WIDTH = HEIGHT = 400


def _cubes():
    """(name, material, translation, rotation about z in degrees, scale) of each cube."""
    t = THICKNESS
    return [
        ("floor", "white", (1, 0, -t / 2), 0, (2.1, 2.1, t)),
        ("ceiling", "white", (1, 0, 2 + t / 2), 0, (2.1, 2.1, t)),
        ("back", "white", (2 + t / 2, 0, 1), 0, (t, 2.1, 2.1)),
        ("left", "red", (1, 1 + t / 2, 1), 0, (2.1, t, 2.1)),
        ("right", "green", (1, -1 - t / 2, 1), 0, (2.1, t, 2.1)),
        ("lamp", "lamp", (1, 0, 1.99), 0, (0.5, 0.4, 0.02)),
        ("tall_block", "white", (1.3, 0.35, 0.6), 17, (0.6, 0.6, 1.2)),
        ("short_block", "white", (0.7, -0.4, 0.3), -18, (0.6, 0.6, 0.6)),
    ]


def cube_to_world(translation, rot_z_deg, scale):
    """TRANSLATE * ROTATE(.Z) * SCALE of lumen's unit cube, as a transform of Mitsuba's."""
    T = mi.ScalarTransform4f
    return (
        T().translate(list(map(float, translation)))
        @ T().rotate([0.0, 0.0, 1.0], float(rot_z_deg))
        @ T().scale(list(map(float, scale)))
        @ T().scale(0.5)  # Mitsuba's cube is [-1, 1]^3, lumen's [-0.5, 0.5]^3
    )


def sensor_dict(width: int, height: int, spp: int, sampler: str):
    """lumen's Camera.Perspective as a Mitsuba perspective sensor (see the module docstring)."""
    if abs(width / height - ASPECT_RATIO) > 1e-9:
        # lumen keeps the script's aspect ratio whatever the image size (it stretches);
        # Mitsuba derives it from the film: only equal ratios give the same image.
        raise ValueError(f"image {width}x{height} does not have the camera's aspect ratio {ASPECT_RATIO}")
    cx, cy, cz = CAMERA_TRANSLATION
    eye = [cx - SCREEN_DISTANCE, cy, cz]  # camera-space (-d, 0, 0), translated
    target = [eye[0] + 1.0, cy, cz]  # looking along +x
    return {
        "type": "perspective",
        "fov_axis": "y",
        "fov": math.degrees(2.0 * math.atan(1.0 / SCREEN_DISTANCE)),
        "near_clip": SCREEN_DISTANCE,  # nothing before lumen's screen plane is seen
        "far_clip": 1e4,
        "to_world": mi.ScalarTransform4f().look_at(origin=eye, target=target, up=[0.0, 0.0, 1.0]),
        "film": {
            "type": "hdrfilm",
            "width": width,
            "height": height,
            "pixel_format": "rgb",
            "rfilter": {"type": "box"},
        },
        "sampler": {"type": sampler, "sample_count": spp},
    }


def scene_dict(
    width: int = WIDTH,
    height: int = HEIGHT,
    spp: int = 64,
    lumen_max_depth: int = MAX_DEPTH,
    lumen_roulette_depth: int = ROULETTE_DEPTH,
    sampler: str = "independent",
):
    """The Mitsuba scene dict of cornell.sl; depths are given in lumen's convention."""
    scene = {
        "type": "scene",
        "integrator": {
            "type": "path",
            "max_depth": lumen_max_depth + 1,
            "rr_depth": lumen_roulette_depth + 1,
            "hide_emitters": False,
        },
        "sensor": sensor_dict(width, height, spp, sampler),
    }
    for name, material, translation, rot, scale in _cubes():
        shape = {
            "type": "cube",
            "to_world": cube_to_world(translation, rot, scale),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(ALBEDO[material])}},
        }
        if material == "lamp":
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": list(LAMP_RADIANCE)}}
        scene[name] = shape
    return scene


def write_pfm(path: str, image) -> None:
    """Writes an (height, width, 3) float array as a little-endian PFM (rows bottom to top)."""
    import numpy as np

    a = np.ascontiguousarray(np.asarray(image, dtype="<f4")[::-1])
    h, w = a.shape[:2]
    with open(path, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1.0\n".encode("ascii"))
        f.write(a.tobytes())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--variant", default="llvm_ad_rgb")
    p.add_argument("--width", type=int, default=WIDTH)
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-depth", type=int, default=MAX_DEPTH, help="lumen's convention")
    p.add_argument("--roulette-depth", type=int, default=ROULETTE_DEPTH, help="lumen's convention")
    p.add_argument("--sampler", default="independent")
    p.add_argument("-o", "--output", default="cornell_mitsuba.pfm")
    a = p.parse_args(argv)
    mi.set_variant(a.variant)
    scene = mi.load_dict(scene_dict(a.width, a.width, a.spp, a.max_depth, a.roulette_depth, a.sampler))
    t0 = time.perf_counter()
    image = mi.render(scene, spp=a.spp, seed=a.seed)
    import numpy as np

    image = np.array(image)
    seconds = time.perf_counter() - t0
    write_pfm(a.output, image)
    print(f"{a.width}x{a.width} Mitsuba {a.variant}, {a.spp} spp in {seconds:.3f} s -> {a.output}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
