#!/usr/bin/env python3
"""Where a render's noise is: each pixel's variance over renders with different seeds.

Renders SCENE with every given lumen binary once per seed (`--seed 1000 ...`), reads the
PFM images and prints, per binary, the image mean, the per-pixel variance over the seeds
(averaged over pixels and channels: the MSE one render has against the expectation) and
the mean render time; then the pixels holding most of the last binary's variance, with
their means, so a lamp's silhouette, a near-field hot spot or a firefly shows by where it
sits. Side by side, two binaries (a base built in a worktree and the change) give the
variance ratio of a sampling change at the same time per sample.

    mkdir -p /tmp/xdg; export XDG_RUNTIME_DIR=/tmp/xdg
    python3 scripts/seed_variance.py scenes/cornell.sl --lumen /tmp/base-target/release/lumen \\
        --lumen target/release/lumen --device gpu --width 64 --spp 64 --seeds 8
    # only the direct light: a copy of the scene with max_depth 1; a region's share:
    python3 scripts/seed_variance.py /tmp/cornell_d1.sl --lumen target/release/lumen \\
        --device cpu --region 24,6,40,13

Used for BENCHMARKS.md "Visible cube faces and multi-jittered camera samples" and
"Solid-angle sampling of cube faces" (2026-12-05). Needs numpy.
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile

import numpy as np


def read_pfm(path):
    """A PFM image as an (rows, columns, 3) float64 array, top row first."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise ValueError(f"{path}: not a colour PFM")
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    # PFM stores the bottom row first.
    return data.reshape(height, width, 3)[::-1].astype(np.float64)


def render(binary, args, seed, out):
    cmd = [binary, "render", args.scene, "--device", args.device, "--width", str(args.width), "--spp", str(args.spp)]
    cmd += ["--seed", str(seed), "-o", out]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{done.stderr}")
    # "… samples in 1.54 s (…)" on the GPU, "… samples, 6574 rays in 0.01 s (…)" on the CPU.
    seconds = re.search(r" in ([0-9.]+) s \(", done.stderr)
    return read_pfm(out), float(seconds.group(1)) if seconds else float("nan")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("--lumen", action="append", required=True, help="a lumen binary (repeat to compare)")
    p.add_argument("--device", default="gpu", choices=["gpu", "cpu", "auto"])
    p.add_argument("--width", type=int, default=64)
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--seeds", type=int, default=8, help="renders per binary (at least 2)")
    p.add_argument("--hot", type=int, default=12, help="how many of the noisiest pixels to list")
    p.add_argument("--region", help="x0,y0,x1,y1 (pixels, top-left origin, exclusive ends): its share")
    args = p.parse_args()
    if args.seeds < 2:
        sys.exit("--seeds must be at least 2")
    with tempfile.TemporaryDirectory() as tmp:
        for binary in args.lumen:
            images, seconds = [], []
            for k in range(args.seeds):
                image, s = render(binary, args, 1000 + k, os.path.join(tmp, f"{k}.pfm"))
                images.append(image)
                seconds.append(s)
            stack = np.stack(images)
            mean = stack.mean(0)
            variance = stack.var(0, ddof=1).mean(-1)
            line = f"{binary}: mean {mean.mean():.5f}, per-pixel variance {variance.mean():.4e}, "
            print(line + f"{np.mean(seconds):.3f} s per render ({min(seconds):.2f}-{max(seconds):.2f})")
            if args.region:
                x0, y0, x1, y1 = map(int, args.region.split(","))
                inside = variance[y0:y1, x0:x1].sum()
                print(f"  region {args.region}: {inside / variance.sum():.1%} of the variance")
    order = np.argsort(variance.ravel())[::-1][: args.hot]
    total, running = variance.sum(), 0.0
    print(f"noisiest pixels of {args.lumen[-1]} (x, y from the top left):")
    for i in order:
        y, x = divmod(int(i), variance.shape[1])
        running += variance[y, x]
        rgb = ", ".join(f"{c:.3f}" for c in mean[y, x])
        print(f"  ({x}, {y}): variance {variance[y, x]:.4g}, mean ({rgb}), cumulative {running / total:.1%}")


if __name__ == "__main__":
    main()
