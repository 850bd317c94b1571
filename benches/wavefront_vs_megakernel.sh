#!/usr/bin/env bash
# Side-by-side samples/s of two lumen builds on every scene, alternating per scene so that
# both see the same machine load: `lumen bench --device gpu` of build A, then of build B,
# then the CPU reference once (from build B). Used for BENCHMARKS.md's "Wavefront renderer
# against the megakernel" table, with A = the last megakernel commit (7eced3b) built in a
# worktree and B = this tree:
#   git worktree add ../lumen-mk 7eced3b && (cd ../lumen-mk && cargo build --release)
#   benches/wavefront_vs_megakernel.sh ../lumen-mk/target/release/lumen target/release/lumen
set -euo pipefail
a=$1
b=$2
for scene in scenes/*.sl; do
    for bin in "$a" "$b"; do
        echo "## $bin"
        "$bin" bench --device gpu --scenes "$scene" --max-spheres 0 2>/dev/null | grep '| gpu |'
    done
    echo "## cpu"
    "$b" bench --device cpu --scenes "$scene" --max-spheres 0 2>/dev/null | grep '| cpu |'
done
