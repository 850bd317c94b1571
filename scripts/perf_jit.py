#!/usr/bin/env python3
"""Where llvmpipe's time goes inside lumen's kernels: `perf` samples mapped onto the JIT code.

`perf` sees llvmpipe's compiled kernels only as anonymous addresses. Mesa prints the same
code with offsets from each function's start (`GALLIVM_DEBUG=asm`), and llvmpipe compiles a
kernel to the same instructions in every process, so a kernel's base address in a perf
recording is the one base at which (nearly) every sampled address in its range falls on one
of its instruction boundaries. This script finds that base for every kernel function and
writes each one's listing with a sample count per instruction.

    mkdir -p /tmp/xdg; export XDG_RUNTIME_DIR=/tmp/xdg
    GALLIVM_DEBUG=asm LUMEN_PARALLEL_JIT=0 LUMEN_PIPELINE_CACHE=0 MESA_SHADER_CACHE_DIR=$(mktemp -d) \\
        target/release/lumen render scenes/cornell.sl --device gpu --one-device --width 8 --spp 1 \\
        -o /tmp/x.png > /tmp/kernels.asm 2>&1
    perf record -o /tmp/perf.data target/release/lumen render scenes/cornell.sl \\
        --device gpu --one-device --width 240 --spp 32 -o /tmp/x.png
    python3 scripts/perf_jit.py /tmp/perf.data /tmp/kernels.asm /tmp/annotated

prints each kernel found (its function's index in the listing, instructions, samples and
share of all JIT samples) and writes /tmp/annotated/kernel<index>.txt. Which kernel is
which: `LUMEN_PARALLEL_JIT=0` compiles a scene's kernels in the order `lumen shader`
prints them after sorting by WGSL length, longest first (src/gpu/parallel_jit.rs). Samples
land on the instruction after a slow one (skid): a `lock xadd` shows on the next line.
Works with Mesa 25's listings and Mesa 26.1's (run both commands through
`target/newer-lavapipe/run` for the latter). Used for BENCHMARKS.md "Unrolled lists"
(2026-12-04).
"""

import bisect
import collections
import os
import re
import subprocess
import sys


def jit_samples(perf_data):
    """Sample counts by address, for the addresses perf could not name (JIT code)."""
    out = subprocess.run(["perf", "script", "-i", perf_data, "-F", "ip,sym"], capture_output=True, text=True, check=True)
    counts = collections.Counter()
    for line in out.stdout.splitlines():
        fields = line.split()
        if len(fields) != 1 and not (len(fields) > 1 and fields[1].startswith("[unknown]")):
            continue
        try:
            counts[int(fields[0], 16)] += 1
        except ValueError:
            pass
    return counts


def functions(asm_listing):
    """(name, [(offset, line)]) for every function Mesa printed."""
    funcs = []
    for line in open(asm_listing, errors="replace"):
        name = re.match(r"^([A-Za-z_.][\w.]*):$", line.strip())
        if name:
            funcs.append((name.group(1), []))
            continue
        instr = re.match(r"^\s*([0-9a-f]+):\t", line)
        if instr and funcs:
            funcs[-1][1].append((int(instr.group(1), 16), line.rstrip()))
    return funcs


def locate(counts, addrs, offsets, total):
    """The base at which the most samples fall on instruction boundaries, if nearly all in
    its range do (else None), and the samples in that range."""
    size = max(offsets)
    candidates = {a - off for a, _ in counts.most_common(40) for off in offsets}
    best = None
    for base in candidates:
        lo, hi = bisect.bisect_left(addrs, base), bisect.bisect_right(addrs, base + size)
        inside = sum(counts[a] for a in addrs[lo:hi])
        aligned = sum(counts[a] for a in addrs[lo:hi] if a - base in offsets)
        if inside > 0.02 * total and aligned > 0.995 * inside and (best is None or inside > best[1]):
            best = (base, inside)
    return best


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    perf_data, asm_listing, out_dir = sys.argv[1:]
    counts = jit_samples(perf_data)
    total = sum(counts.values())
    if total == 0:
        sys.exit("no JIT samples in " + perf_data)
    addrs = sorted(counts)
    os.makedirs(out_dir, exist_ok=True)
    print(f"{total} samples in JIT code")
    funcs = functions(asm_listing)
    # Mesa 25 runs a kernel's body as a coroutine (`cs_co_variant`, beside a small
    # `cs_variant` that drives it); Mesa 26.1 compiles the body into `cs_variant` itself.
    body = "cs_co_variant" if any(name == "cs_co_variant" for name, _ in funcs) else "cs_variant"
    for index, (name, instrs) in enumerate(funcs):
        if name != body or len(instrs) < 50:
            continue
        offsets = {off for off, _ in instrs}
        found = locate(counts, addrs, offsets, total)
        if not found:
            continue
        base, inside = found
        path = os.path.join(out_dir, f"kernel{index}.txt")
        with open(path, "w") as f:
            for off, line in instrs:
                f.write(f"{counts.get(base + off, 0):6d} {line}\n")
        print(f"kernel {index}: {len(instrs)} instructions, {inside} samples ({100 * inside / total:.1f} %), {path}")


if __name__ == "__main__":
    main()
