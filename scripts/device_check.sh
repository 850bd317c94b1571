#!/usr/bin/env bash
# Issue 12, goal 4: lumen's figures on a hardware GPU, in one run. A lent GPU machine is held
# for minutes, cannot reach crates.io, and may lack the Vulkan loader, so everything is
# prepared here and this script only measures there:
#
#   cargo build --release && mkdir -p target/device && strip -o target/device/lumen target/release/lumen
#   # optional, the megakernel side of the comparison (its last commit, 7eced3b):
#   git worktree add ../lumen-mk 7eced3b && (cd ../lumen-mk && cargo build --release) \
#       && strip -o target/device/lumen-megakernel ../lumen-mk/target/release/lumen
#   # the loader, once (as the device tool's notes say): .gl/*.deb, ignored by git
#
# then, on the device machine (carry: target/device and .gl):
#
#   for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig; scripts/device_check.sh "$OUT"
#
# It writes to OUT_DIR (default: $OUT, else target/device_check; relative paths, here and in
# LUMEN_BIN and MEGAKERNEL_BIN, are from the repository's root), at most six files:
# - device.txt      the GPU (nvidia-smi) and the adapters lumen sees;
# - bench.md        `lumen bench` of every scene on the GPU and the CPU reference (the
#                   scenes' own sizes and samples), with each GPU/CPU ratio;
# - bench_large.md  every scene on the GPU alone at 1024 px wide and 256 spp: batches large
#                   enough to fill a datacenter GPU;
# - cornell.txt     scenes/cornell.sl at 1024×1024 and 1024 spp (goal: under 2 s), the
#                   per-stage device times and the device's busy fraction (`--profile`);
# - megakernel.md   when target/device/lumen-megakernel exists: its GPU bench of every
#                   scene, to set beside bench.md's GPU rows;
# - log.txt         how each step ended.
# Each step has a time limit, so a slow step costs its own figures, not the others'.
# QUICK=1 shrinks every size and accepts a software adapter (to try the script anywhere;
# tests/device_check.rs runs it so in CI).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${1:-${OUT:-target/device_check}}
mkdir -p "$out"
quick=${QUICK:-0}
if [ "$quick" = 1 ]; then
    bench=(--quick --max-spheres 0)
    large=(--width 64 --spp 4)
    cornell=(--width 64 --height 64 --spp 16)
else
    bench=(--max-spheres 0)
    large=(--width 1024 --spp 256)
    cornell=(--width 1024 --height 1024 --spp 1024)
fi
bin=${LUMEN_BIN:-target/device/lumen}
[ -x "$bin" ] || bin=target/release/lumen
mega=${MEGAKERNEL_BIN:-target/device/lumen-megakernel}
log=$out/log.txt
: > "$log"
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

# step NAME SECONDS COMMAND...: COMMAND with a time limit; how it ended goes to log.txt.
step() {
    local name=$1 limit=$2
    shift 2
    local t0=$SECONDS
    timeout "$limit" "$@"
    echo "$name: exit $? after $((SECONDS - t0)) s" >> "$log"
}

{ nvidia-smi 2>&1 || echo "(no nvidia-smi)"; } > "$out/device.txt"
"$bin" devices >> "$out/device.txt" 2>&1
if [ "$quick" != 1 ] && ! grep -qE "type: (discrete|integrated) GPU" "$out/device.txt"; then
    echo "no hardware GPU adapter: see device.txt" | tee -a "$log" >&2
    exit 1
fi
step bench 240 "$bin" bench --device gpu,cpu --scenes scenes "${bench[@]}" -o "$out/bench.md" > /dev/null 2>&1
step bench_large 240 "$bin" bench --device gpu --scenes scenes --max-spheres 0 "${large[@]}" \
    -o "$out/bench_large.md" > /dev/null 2>&1
# The whole process's wall time (start-up and kernel creation included) after the render's
# own summary line and the stage profile.
step cornell 120 bash -c 'TIMEFORMAT="wall %R s (the whole process)"; time "$@"' _ \
    "$bin" render scenes/cornell.sl --device gpu "${cornell[@]}" --profile -o "$scratch/cornell.exr" \
    > "$out/cornell.txt" 2>&1
if [ -x "$mega" ]; then
    step megakernel 240 "$mega" bench --device gpu --scenes scenes --max-spheres 0 -o "$out/megakernel.md" > /dev/null 2>&1
fi
cat "$log"
