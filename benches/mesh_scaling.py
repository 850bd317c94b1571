#!/usr/bin/env python3
"""Triangle-mesh scaling of lumen on the CPU and the GPU (issue 13, "Scenes and benchmarks").

Why: issue 13 asks BENCHMARKS.md for BVH build time and rays/s against triangle count
(1 k -> 1 M triangles, one mesh and many instances) on lavapipe and the CPU, and for peak
memory per million triangles. This script measures all of it end to end through the
`lumen` CLI, each size on both devices one after the other, so that both see the same
machine load (the machine this was written on is a shared, noisy 2-core VM).

What it does (everything in a temporary folder, deleted at the end unless --keep):

1. Writes icospheres as OBJ (positions + `f` faces): a subdivided icosahedron on the unit
   sphere, levels 3..8 = 1 280, 5 120, 20 480, 81 920, 327 680 and 1 310 720 triangles
   (20 * 4^level; midpoints cached per edge, so each level is linear in its size).
2. One mesh: for each size a SceneLang script with that icosphere at x = 3 (radius 1, in
   front of the default camera) over a plane, 128x128, 2x2 samples per pixel, path tracer
   n 1, max_depth 3, no roulette, uniform white sky; rendered with `lumen render --device
   cpu` and `--device gpu`, at `--spp 64` (--spp; the scripts' own 2x2 = 4 spp takes
   0.05 s on the CPU, too close to the 0.01 s resolution of lumen's report, and is
   dwarfed by the BVH build at 1 M triangles). From lumen's report line
   ("... 1048576 samples, N rays in S s") it takes seconds, rays (CPU) and
   samples (both; the GPU report does not count rays). Rates are differential, as in
   BENCHMARKS.md: (rays or samples of the 128x128 render - those of the 8x8 1-spp render
   of item 4) / (the difference of their reported seconds), so that loading, BVH build,
   packing and GPU kernel creation cancel. The "s" columns are lumen's reported seconds of
   the 128x128 render. Peak RSS comes from `/usr/bin/time -f %M` (else from
   getrusage(RUSAGE_CHILDREN), whose ru_maxrss is the largest child so far: less exact);
   wall times from the script's own clock.
3. Many instances: the 20 480-triangle icosphere placed 1, 16, 64, 256 and 1 024 times
   (`Shape.Mesh` of the same file, SCALE 0.4, on a k x k grid in the y-z plane at x = 6,
   1.0 apart, so that the spheres never overlap; from 16 x 16 on, the grid is wider than
   the view and part of it is off screen; the plane lies below the lowest row). lumen
   loads the file once and shares its BVH, so memory should stay nearly flat.
4. "BVH build + setup": `lumen render --width 8 --height 8 --spp 1` (64 samples, so the
   render itself is negligible). Its reported seconds start after loading: on the CPU
   they are the BVH build (World::new) and light set-up, on the GPU packing (BVH
   included), kernel creation and upload; BVH M triangles/s = triangles / the CPU figure.
   Also shown: its wall time minus the wall time of `lumen check` (which loads and parses
   the scene and its meshes but builds no BVH), the cruder proxy; `lumen render` loads
   the script twice (once to fail fast before opening a device), so that difference also
   holds one more load. For the bare BVH build rate without the CLI, the repo has
   `LUMEN_BENCH_QUICK=1 cargo bench --bench mesh_bvh` (not run by this script).
5. Prints Markdown tables: one mesh, many instances, peak memory per million triangles
   (peak RSS at the largest sizes minus that of the 1 280-triangle scene, over the extra
   triangles), and the setup times. Warnings printed by lumen (NaN, fallbacks) are listed.

Usage: python3 benches/mesh_scaling.py [--lumen ./target/release/lumen] [--timeout 180]
       [--spp 64] [--max-level 8] [--keep DIR] [--no-gpu]
Python 3 standard library only. The GPU is whatever `lumen render --device gpu` picks
(lavapipe on a machine without one); XDG_RUNTIME_DIR is set to a temporary folder if unset.
About two minutes on 2 cores, most of it lavapipe on the largest scenes.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time

LEVELS = range(3, 9)  # 1 280 ... 1 310 720 triangles
INSTANCE_LEVEL = 5  # 20 480 triangles
INSTANCE_COUNTS = [1, 16, 64, 256, 1024]

RENDER_SETTINGS = """USING
    Camera.Perspective()
    Image(128, 128)
    Tracer(.samples_per_side 2)
    Renderer.PathTracer(.n 1, .max_depth 3, .roulette_depth 100)
    Environment.Uniform(.color <1, 1, 1>)
"""

# lumen's report line, e.g.
# 128×128 PathTracer on the CPU (2 threads): 4 of 4 samples per pixel, 65536 samples, 180000 rays in 0.52 s (0.35 Mrays/s)
# 128×128 PathTracer on the GPU (llvmpipe ...): 4 of 4 samples per pixel, 65536 samples in 1.23 s (0.05 Msamples/s)
REPORT = re.compile(r"(\d+) samples(?:, (\d+) rays)? in ([0-9.]+) s")


# --------------------------------------------------------------------------- icospheres


def icosphere_levels(max_level: int):
    """Yields (level, vertices, faces) for levels 0..max_level of a unit icosphere."""
    t = (1.0 + math.sqrt(5.0)) / 2.0
    verts = [
        (-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
        (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
        (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1),
    ]
    verts = [normalize(v) for v in verts]
    faces = [
        (0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
        (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
        (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
        (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1),
    ]
    yield 0, verts, faces
    for level in range(1, max_level + 1):
        cache: dict[tuple[int, int], int] = {}

        def midpoint(a: int, b: int) -> int:
            key = (a, b) if a < b else (b, a)
            i = cache.get(key)
            if i is None:
                va, vb = verts[a], verts[b]
                verts.append(normalize(((va[0] + vb[0]) * 0.5, (va[1] + vb[1]) * 0.5,
                                        (va[2] + vb[2]) * 0.5)))
                i = len(verts) - 1
                cache[key] = i
            return i

        new_faces = []
        for a, b, c in faces:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            new_faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new_faces
        yield level, verts, faces


def normalize(v):
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / n, v[1] / n, v[2] / n)


def write_obj(path: str, verts, faces) -> None:
    with open(path, "w") as f:
        f.write(f"# unit icosphere, {len(faces)} triangles, {len(verts)} vertices\n")
        f.write("".join(f"v {x:.9f} {y:.9f} {z:.9f}\n" for x, y, z in verts))
        f.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces))


# --------------------------------------------------------------------------- scenes


def one_mesh_scene(obj: str) -> str:
    return f"""# mesh_scaling.py: one icosphere mesh
SPAWN
    Shape.Plane(.material Material(Brdf.Diffuse(<0.5, 0.5, 0.5>)), .transformation TRANSLATE(0, 0, -1))
    Shape.Mesh(.file "{obj}", .material Material(Brdf.Diffuse(<0.6, 0.6, 0.6>)),
               .transformation TRANSLATE(3, 0, 0))
{RENDER_SETTINGS}"""


def instances_scene(obj: str, n: int) -> str:
    k = int(round(math.sqrt(n)))
    assert k * k == n
    lines = []
    for i in range(k):
        for j in range(k):
            y = (i - (k - 1) / 2) * 1.0
            z = (j - (k - 1) / 2) * 1.0
            lines.append(f"    Shape.Mesh(.file \"{obj}\", .material grey, "
                         f".transformation TRANSLATE(6, {y:g}, {z:g}) * SCALE 0.4)")
    floor = -((k - 1) / 2 + 1.0)
    return f"""# mesh_scaling.py: {n} instances of one icosphere
SET
    grey Material(Brdf.Diffuse(<0.6, 0.6, 0.6>))
SPAWN
    Shape.Plane(.material Material(Brdf.Diffuse(<0.5, 0.5, 0.5>)), .transformation TRANSLATE(0, 0, {floor:g}))
""" + "\n".join(lines) + "\n" + RENDER_SETTINGS


# --------------------------------------------------------------------------- running lumen

TIME_BIN = "/usr/bin/time" if os.access("/usr/bin/time", os.X_OK) else None


class Run:
    def __init__(self):
        self.ok = False
        self.timeout = False
        self.error = ""
        self.wall = math.nan
        self.rss_mb = math.nan
        self.seconds = math.nan
        self.samples = None
        self.rays = None
        self.warnings: list[str] = []

    def rate(self, what: str, base: "Run | None" = None) -> float:
        """Millions of rays or samples per second; with `base` (the 8x8 1-spp render of the
        same scene) the differential rate: extra rays or samples over extra seconds."""
        n = self.rays if what == "rays" else self.samples
        if not self.ok or n is None or not self.seconds > 0:
            return math.nan
        if base is None:
            return n / self.seconds / 1e6
        n0 = base.rays if what == "rays" else base.samples
        if not base.ok or n0 is None or not self.seconds - base.seconds > 0:
            return math.nan
        return (n - n0) / (self.seconds - base.seconds) / 1e6


def run_lumen(args: list[str], cwd: str, timeout: float, tag: str) -> Run:
    r = Run()
    tfile = os.path.join(cwd, "time.out")
    cmd = list(args)
    if TIME_BIN:
        cmd = [TIME_BIN, "-f", "%e %M", "-o", tfile] + cmd
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, start_new_session=True)
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)  # the time wrapper and lumen under it
        p.communicate()
        r.timeout = True
        r.error = f"timeout after {timeout:g} s"
        print(f"  {tag}: TIMEOUT", flush=True)
        return r
    r.wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    text = out + err
    for line in text.splitlines():
        if re.search(r"warn|\bnan\b|fall(ing)? back|error", line, re.IGNORECASE):
            r.warnings.append(line.strip())
    if p.returncode != 0:
        r.error = f"exit {p.returncode}: " + " | ".join(text.strip().splitlines()[-3:])
        print(f"  {tag}: FAILED {r.error}", flush=True)
        return r
    r.ok = True
    if TIME_BIN and os.path.exists(tfile):
        fields = open(tfile).read().split()
        try:
            r.rss_mb = int(fields[-1]) / 1024.0
        except (IndexError, ValueError):
            pass
    if math.isnan(r.rss_mb) and after.ru_maxrss > before.ru_maxrss:
        r.rss_mb = after.ru_maxrss / 1024.0  # largest child so far (Linux: KiB)
    m = REPORT.search(err) or REPORT.search(out)
    if m:
        r.samples = int(m.group(1))
        r.rays = int(m.group(2)) if m.group(2) else None
        r.seconds = float(m.group(3))
    print(f"  {tag}: wall {r.wall:.2f} s, RSS {r.rss_mb:.0f} MB"
          + (f", report: {m.group(0)}" if m else ""), flush=True)
    return r


def measure(lumen: str, script: str, cwd: str, timeout: float, gpu: bool, spp: int,
            tag: str) -> dict:
    res = {}
    devices = ["cpu", "gpu"] if gpu else ["cpu"]
    res["check"] = run_lumen([lumen, "check", script], cwd, timeout, f"{tag} check")
    for dev in devices:
        res[dev] = run_lumen([lumen, "render", script, "--device", dev, "-o", f"out_{dev}.pfm",
                              "--spp", str(spp)],
                             cwd, timeout, f"{tag} {dev}")
    for dev in devices:
        res[dev + "8"] = run_lumen([lumen, "render", script, "--device", dev, "--width", "8",
                                    "--height", "8", "--spp", "1", "-o", f"out8_{dev}.pfm"],
                                   cwd, timeout, f"{tag} {dev} 8x8")
    return res


# --------------------------------------------------------------------------- output


def fmt(x: float, digits: int = 2) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    return f"{x:.{digits}f}".replace("-0.00", "0.00")


def cell(run: Run | None, value: float, digits: int = 2) -> str:
    if run is None:
        return "not run"
    if run.timeout:
        return "timeout"
    if not run.ok:
        return "error"
    return fmt(value, digits)


def rate_table(first: str, rows: list[tuple[str, dict]]) -> str:
    out = [f"| {first} | CPU Mrays/s | CPU Msamples/s | GPU Msamples/s (lavapipe) | CPU s | GPU s "
           "| peak RSS CPU MB | peak RSS GPU MB |",
           "|---|---|---|---|---|---|---|---|"]
    for label, res in rows:
        c, g = res.get("cpu"), res.get("gpu")
        c8, g8 = res.get("cpu8"), res.get("gpu8")
        out.append(f"| {label} | {cell(c, c.rate('rays', c8) if c else 0, 3)} "
                   f"| {cell(c, c.rate('samples', c8) if c else 0, 3)} "
                   f"| {cell(g, g.rate('samples', g8) if g else 0, 3)} "
                   f"| {cell(c, c.seconds if c else 0)} | {cell(g, g.seconds if g else 0)} "
                   f"| {cell(c, c.rss_mb if c else 0, 0)} | {cell(g, g.rss_mb if g else 0, 0)} |")
    return "\n".join(out)


def setup_table(first: str, rows: list[tuple[str, int | None, dict]]) -> str:
    """rows: (label, triangles built into a BVH or None, results)."""
    out = [f"| {first} | `check` wall s | CPU 8x8 wall s | CPU wall - `check` wall s "
           "| CPU 8x8 reported s (BVH build + setup) | BVH M triangles/s "
           "| GPU 8x8 wall s | GPU 8x8 reported s (pack + BVH + kernels) | peak RSS `check` MB |",
           "|---|---|---|---|---|---|---|---|---|"]
    for label, tris, res in rows:
        k, c8, g8 = res.get("check"), res.get("cpu8"), res.get("gpu8")
        dc = c8.wall - k.wall if (c8 and k and c8.ok and k.ok) else math.nan
        build = (tris / c8.seconds / 1e6 if tris and c8 and c8.ok and c8.seconds > 0
                 else math.nan)
        out.append(f"| {label} | {cell(k, k.wall if k else 0)} | {cell(c8, c8.wall if c8 else 0)} "
                   f"| {fmt(dc)} | {cell(c8, c8.seconds if c8 else 0)} "
                   f"| {fmt(build) if tris else '(shared mesh)'} "
                   f"| {cell(g8, g8.wall if g8 else 0)} | {cell(g8, g8.seconds if g8 else 0)} "
                   f"| {cell(k, k.rss_mb if k else 0, 0)} |")
    return "\n".join(out)


def memory_table(sizes: list[tuple[int, dict]]) -> str:
    base_n, base = sizes[0]
    out = [f"| triangles | `check` MB / M triangles | CPU render MB / M triangles "
           f"| GPU render MB / M triangles |", "|---|---|---|---|"]
    for n, res in sizes[1:][-2:]:
        cells = []
        for key in ("check", "cpu", "gpu"):
            a, b = res.get(key), base.get(key)
            if a and b and a.ok and b.ok:
                cells.append(fmt((a.rss_mb - b.rss_mb) / (n - base_n) * 1e6, 0))
            else:
                cells.append("timeout" if a and a.timeout else "n/a")
        out.append(f"| {n:,} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lumen", default="./target/release/lumen")
    ap.add_argument("--timeout", type=float, default=180.0, help="seconds per lumen run")
    ap.add_argument("--max-level", type=int, default=8, help="largest icosphere level (8: 1.3 M)")
    ap.add_argument("--keep", help="work in this folder and keep it (default: a temporary one)")
    ap.add_argument("--spp", type=int, default=64,
                    help="samples per pixel of the timed 128x128 renders (the scripts say 4)")
    ap.add_argument("--no-gpu", action="store_true")
    a = ap.parse_args()

    lumen = os.path.abspath(a.lumen)
    if not os.access(lumen, os.X_OK):
        print(f"no lumen binary at {lumen} (cargo build --release)", file=sys.stderr)
        return 2
    if a.keep:
        work = os.path.abspath(a.keep)
        os.makedirs(work, exist_ok=True)
    else:
        work = tempfile.mkdtemp(prefix="lumen_mesh_scaling_")
    if not os.environ.get("XDG_RUNTIME_DIR") or not os.path.isdir(os.environ["XDG_RUNTIME_DIR"]):
        xdg = os.path.join(work, "xdg")
        os.makedirs(xdg, mode=0o700, exist_ok=True)
        os.environ["XDG_RUNTIME_DIR"] = xdg
    gpu = not a.no_gpu
    t_start = time.perf_counter()
    try:
        print(f"work folder {work}; time wrapper: {TIME_BIN or 'none (getrusage)'}", flush=True)
        levels = [lv for lv in LEVELS if lv <= a.max_level]
        objs: dict[int, tuple[str, int]] = {}
        for level, verts, faces in icosphere_levels(max(levels)):
            if level in levels:
                t0 = time.perf_counter()
                name = f"ico_{len(faces)}.obj"
                write_obj(os.path.join(work, name), verts, faces)
                objs[level] = (name, len(faces))
                print(f"wrote {name} ({len(verts)} vertices) in {time.perf_counter() - t0:.1f} s",
                      flush=True)

        one: list[tuple[int, dict]] = []
        for level in levels:
            name, n = objs[level]
            script = os.path.join(work, f"one_{n}.sl")
            with open(script, "w") as f:
                f.write(one_mesh_scene(name))
            print(f"one mesh, {n} triangles", flush=True)
            one.append((n, measure(lumen, script, work, a.timeout, gpu, a.spp, f"{n}")))

        inst: list[tuple[int, dict]] = []
        if INSTANCE_LEVEL in objs:
            name, n_tri = objs[INSTANCE_LEVEL]
            for n in INSTANCE_COUNTS:
                script = os.path.join(work, f"inst_{n}.sl")
                with open(script, "w") as f:
                    f.write(instances_scene(name, n))
                print(f"{n} instances of {n_tri} triangles", flush=True)
                inst.append((n, measure(lumen, script, work, a.timeout, gpu, a.spp, f"{n}x")))

        print(f"\n(total {time.perf_counter() - t_start:.0f} s)\n")
        print("### One mesh\n")
        print(rate_table("triangles", [(f"{n:,}", r) for n, r in one]))
        if inst:
            n_tri = objs[INSTANCE_LEVEL][1]
            print(f"\n### Instances of one {n_tri:,}-triangle mesh\n")
            print(rate_table("instances", [(f"{n:,} ({n * n_tri:,} tris)", r) for n, r in inst]))
        print("\n### Peak memory per million triangles (minus the 1,280-triangle scene)\n")
        print(memory_table(one))
        print("\n### Loading, BVH build and setup (seconds; 8x8 = `--width 8 --height 8 --spp 1`)\n")
        print(setup_table("scene", [(f"{n:,} triangles", n, r) for n, r in one]
                          + [(f"{n:,} instances", None, r) for n, r in inst]))
        warnings = sorted({f"{w}" for _, r in one + inst for run in r.values()
                           for w in run.warnings})
        errors = [f"{label}: {key}: {run.error}" for label, r in
                  [(f"{n} tris", r) for n, r in one] + [(f"{n} inst", r) for n, r in inst]
                  for key, run in r.items() if run.error]
        if warnings or errors:
            print("\n### Warnings and errors\n")
            for line in errors + warnings:
                print(f"- {line}")
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
