#!/usr/bin/env bash
# Instructions executed, counted by valgrind (cachegrind), for A/B comparisons on lavapipe
# that this shared, noisy machine's clocks cannot resolve (BENCHMARKS.md "How the numbers are
# defined": a count is the same from run to run to about 0.05 %, whatever else runs; it is
# not a time, so a speed claim still needs the side-by-side timings):
#
#   scripts/instructions.sh render BIN SCENE [WIDTH] [SPP]
#       the instructions a GPU render of SCENE on one device spends on SPP samples per pixel
#       (default 96 px, 16 spp): the count of a (1 + SPP)-spp render minus that of a 1-spp
#       one, both with a warm Mesa cache (a first, uncounted run under valgrind fills it,
#       since valgrind's CPU has other features than the host and so other cache keys).
#       Both counts are cachegrind's "???" bucket, code without symbols: llvmpipe's JIT code
#       (the kernels) and lavapipe's stripped driver, whose translation of every kernel to
#       NIR, done even when the compiled code comes from its cache, is a third of the bucket
#       in a 16-spp spheres_10k.sl render and four fifths in skybox.sl's. The difference
#       leaves that out (and scene loading, naga, and the host's threads, whose idle spinning
#       varies): what remains is the kernels' code and the driver's work per workgroup, at
#       the same launches (both renders are one batch at the default size).
#   scripts/instructions.sh cold BIN SCENE
#       all instructions of an 8x8, 1-spp render with every cache cold and the kernels
#       compiled one after another on one device (LUMEN_PARALLEL_JIT=0): the cost of
#       kernel creation (goal 3), mostly LLVM's.
#
# MESA_SHADER_CACHE_DIR for `render` defaults to target/instructions-mesa-cache (per width:
# set LP_NATIVE_VECTOR_WIDTH and a cache directory of its own to compare widths). Needs
# valgrind (Debian: `apt-get install valgrind`).
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:?render or cold}
bin=${2:?binary}
scene=${3:?scene}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
out=$(mktemp)
trap 'rm -f "$out"' EXIT
case $mode in
render)
    width=${4:-96}
    spp=${5:-16}
    export MESA_SHADER_CACHE_DIR=${MESA_SHADER_CACHE_DIR:-$PWD/target/instructions-mesa-cache}
    export LUMEN_PIPELINE_CACHE=0
    count() {
        valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file="$out" "$bin" render "$scene" \
            --device gpu --width "$width" --spp "$1" --one-device -o "$out.pfm" >/dev/null 2>&1
        cg_annotate "$out" | awk '$NF == "???:???" && !done { gsub(",", "", $1); print $1; done = 1 }'
    }
    count 1 >/dev/null
    one=$(count 1)
    more=$(count $((1 + spp)))
    rm -f "$out.pfm"
    echo $((more - one))
    ;;
cold)
    cache=$(mktemp -d)
    trap 'rm -f "$out"; rm -rf "$cache"' EXIT
    MESA_SHADER_CACHE_DIR=$cache LUMEN_PIPELINE_CACHE=0 LUMEN_PARALLEL_JIT=0 valgrind --tool=cachegrind \
        --cache-sim=no --cachegrind-out-file="$out" "$bin" render "$scene" --device gpu --width 8 --spp 1 \
        -o "$out.png" >/dev/null 2>&1
    rm -rf "$cache" "$out.png"
    cg_annotate "$out" | awk '/PROGRAM TOTALS/ && !done { print $1; done = 1 }'
    ;;
*)
    echo "usage: $0 render|cold BIN SCENE [WIDTH] [SPP]" >&2
    exit 2
    ;;
esac
