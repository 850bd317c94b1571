#!/usr/bin/env bash
# Issue 12, goal 4: lumen's figures on a hardware GPU, in one run. A lent GPU machine is held
# for minutes, cannot reach crates.io, and may lack the Vulkan loader, so everything is
# prepared here and this script only measures there (`scripts/device_prepare.sh` does all
# of it, for this script, device_tests.sh and device_ab.sh; by hand:)
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
# LUMEN_BIN and MEGAKERNEL_BIN, are from the repository's root), at most nine files:
# - device.txt      the GPU (nvidia-smi) and the adapters lumen sees;
# - cornell.txt     scenes/cornell.sl at 1024×1024 and 1024 spp (goal: under 2 s), the
#                   per-stage device times and the device's busy fraction (`--profile`);
# - shards.txt      cornell.sl at 1024×1024, 256 spp, with every queue in 1, 8 and 32 shards
#                   (`--queue-shards`; hardware's default is 1), each with `--profile`: what
#                   a datacenter GPU's pushes to one counter per queue cost its stages;
# - bench_large.md  every scene on the GPU alone at 1024 px wide and 256 spp: batches large
#                   enough to fill a datacenter GPU;
# - bench.md        `lumen bench` of every scene on the GPU and the CPU reference (160 px,
#                   16 spp), with each GPU/CPU ratio;
# - megakernel.md   when target/device/lumen-megakernel exists: its GPU bench of every
#                   scene at bench_large.md's settings, to set beside those rows (25 s
#                   a scene: a timeout bounds its samples/s; scenes newer than it fail);
# - batch.txt       cornell.sl at 1024×1024, 256 spp, with 2^20 to 2^23 paths per batch (the
#                   hardware default is 2^21): what a datacenter GPU wants in flight;
# - log.txt         how each step (and each scene) ended;
# - stderr.txt      the steps' standard error (progress, warnings, errors).
# The steps run in that order, most wanted first. Each has a time limit, and all together
# stay within BUDGET seconds (default 500, under one device call's 600): a slow step costs
# its own figures and what comes after it, and the bench steps run one process per scene, so
# a timeout loses one scene's row, not the table.
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
    batch=(--width 64 --height 64 --spp 4)
    batches=(4096)
    shards=(--width 64 --height 64 --spp 4)
else
    bench=(--max-spheres 0)
    large=(--width 1024 --spp 256)
    cornell=(--width 1024 --height 1024 --spp 1024)
    batch=(--width 1024 --height 1024 --spp 256)
    batches=(1048576 2097152 4194304 8388608)
    shards=(--width 1024 --height 1024 --spp 256)
fi
bin=${LUMEN_BIN:-target/device/lumen}
[ -x "$bin" ] || bin=target/release/lumen
mega=${MEGAKERNEL_BIN:-target/device/lumen-megakernel}
log=$out/log.txt
err=$out/stderr.txt
: > "$log"
: > "$err"
deadline=$((SECONDS + ${BUDGET:-500}))
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

# step NAME SECONDS COMMAND...: COMMAND with a time limit, cut to what is left of the
# budget; how it ended goes to log.txt, its standard error to stderr.txt.
step() {
    local name=$1 limit=$2
    shift 2
    local left=$((deadline - SECONDS))
    [ "$left" -lt "$limit" ] && limit=$left
    if [ "$limit" -le 0 ]; then
        echo "$name: skipped, the budget is spent" >> "$log"
        return 1
    fi
    echo "== $name" >> "$err"
    local t0=$SECONDS
    timeout "$limit" "$@" 2>> "$err"
    local rc=$?
    echo "$name: exit $rc after $((SECONDS - t0)) s" >> "$log"
    return $rc
}

# bench_each NAME FILE SECONDS_PER_SCENE BIN ARGS...: `BIN bench ARGS` once per scene, each
# scene's table appended to FILE; the step's own line says whether every scene ended well.
bench_each() {
    local name=$1 file=$2 limit=$3 b=$4
    shift 4
    : > "$file"
    local t0=$SECONDS failed=0 s
    for s in scenes/*.sl; do
        step "$name $(basename "$s")" "$limit" "$b" bench --scenes "$s" "$@" -o "$scratch/one.md" > /dev/null \
            && cat "$scratch/one.md" >> "$file" || failed=1
        echo >> "$file"
    done
    echo "$name: exit $failed after $((SECONDS - t0)) s" >> "$log"
}

hardware() { grep -qE "type: (discrete|integrated) GPU" "$out/device.txt"; }
{ nvidia-smi 2>&1 || echo "(no nvidia-smi)"; } > "$out/device.txt"
"$bin" devices >> "$out/device.txt" 2>&1
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ "$quick" != 1 ] && ! hardware && [ -f "$icd" ]; then
    # The loader found no driver by itself: name NVIDIA's (the device tool's notes).
    export VK_DRIVER_FILES=$icd
    echo "VK_DRIVER_FILES=$icd" >> "$out/device.txt"
    "$bin" devices >> "$out/device.txt" 2>&1
fi
if [ "$quick" != 1 ] && ! hardware; then
    echo "no hardware GPU adapter: see device.txt" | tee -a "$log" >&2
    exit 1
fi
# The whole process's wall time (start-up and kernel creation included) after the render's
# own summary line and the stage profile.
step cornell 120 bash -c 'TIMEFORMAT="wall %R s (the whole process)"; { time "$@"; } 2>&1' _ \
    "$bin" render scenes/cornell.sl --device gpu "${cornell[@]}" --profile -o "$scratch/cornell.exr" \
    > "$out/cornell.txt"
: > "$out/shards.txt"
for n in 1 8 32; do
    echo "--queue-shards $n" >> "$out/shards.txt"
    step "shards $n" 40 bash -c '"$@" 2>&1' _ "$bin" render scenes/cornell.sl --device gpu "${shards[@]}" \
        --queue-shards "$n" --profile -o "$scratch/shards.exr" >> "$out/shards.txt"
done
bench_each bench_large "$out/bench_large.md" 60 "$bin" --device gpu --max-spheres 0 "${large[@]}"
bench_each bench "$out/bench.md" 40 "$bin" --device gpu,cpu "${bench[@]}"
if [ -x "$mega" ]; then
    bench_each megakernel "$out/megakernel.md" 25 "$mega" --device gpu --max-spheres 0 "${large[@]}"
fi
: > "$out/batch.txt"
for n in "${batches[@]}"; do
    echo "--batch-paths $n" >> "$out/batch.txt"
    step "batch $n" 40 bash -c '"$@" 2>&1' _ "$bin" render scenes/cornell.sl --device gpu "${batch[@]}" \
        --batch-paths "$n" -o "$scratch/batch.exr" >> "$out/batch.txt"
done
cat "$log"
