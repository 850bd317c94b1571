#!/usr/bin/env bash
# Two builds side by side on a lent hardware GPU: a speed claim there is a ratio measured in
# one run, the builds alternating, like everywhere else (BENCHMARKS.md "Second lease" was
# measured so). The device machine cannot reach crates.io, so both binaries are built here
# (`scripts/device_prepare.sh A` does it, or by hand):
#
#   mkdir -p target/devab
#   strip -o target/devab/lumen-a <the build before the change>/lumen
#   cargo build --release && strip -o target/devab/lumen-b target/release/lumen
#
# then, on the device machine (carry: target/devab and the loader's .gl, as
# scripts/device_check.sh's header says):
#
#   for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig; scripts/device_ab.sh "$OUT" spheres_10k meshes
#
# It writes to OUT_DIR (default: $OUT, else target/device_ab):
# - cornell.txt  scenes/cornell.sl at 1024×1024 and 1024 spp (issue 12's goal 4), ROUNDS
#                renders of each build, alternating: each render's summary line and the
#                whole process's wall time;
# - bench.txt    `lumen bench --device gpu --width 1024 --spp 256` of each named scene
#                (default: every scene), ROUNDS rounds, the builds alternating;
# - profile.txt  each named scene once per build with `--profile`: the stage times.
# ROUNDS defaults to 3; each command has a time limit, and all stay within BUDGET seconds
# (default 300). QUICK=1 shrinks every size (to try the script anywhere, lavapipe included).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${1:-${OUT:-target/device_ab}}
shift || true
mkdir -p "$out"
a=${LUMEN_A:-target/devab/lumen-a}
b=${LUMEN_B:-target/devab/lumen-b}
for bin in "$a" "$b"; do
    [ -x "$bin" ] || { echo "no binary at $bin (see this script's header)" >&2; exit 2; }
done
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=($(basename -s .sl -a scenes/*.sl))
rounds=${ROUNDS:-3}
if [ "${QUICK:-0}" = 1 ]; then
    cornell=(--width 64 --height 64 --spp 16)
    large=(--width 64 --spp 4)
else
    cornell=(--width 1024 --height 1024 --spp 1024)
    large=(--width 1024 --spp 256)
fi
deadline=$((SECONDS + ${BUDGET:-300}))
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

# run LIMIT COMMAND...: COMMAND with a time limit cut to what is left of the budget.
run() {
    local limit=$1 left=$((deadline - SECONDS))
    shift
    [ "$left" -lt "$limit" ] && limit=$left
    if [ "$limit" -le 0 ]; then
        echo "(skipped: the budget is spent)"
        return 1
    fi
    timeout "$limit" "$@"
}

: > "$out/cornell.txt"
for ((i = 1; i <= rounds; i++)); do
    for bin in "$a" "$b"; do
        echo "== $bin, round $i" >> "$out/cornell.txt"
        run 60 bash -c 'TIMEFORMAT="wall %R s (the whole process)"; { time "$@" 2>&1 | grep -v "^wrote"; } 2>&1' _ \
            "$bin" render scenes/cornell.sl --device gpu "${cornell[@]}" -o "$scratch/c.exr" >> "$out/cornell.txt"
    done
done
: > "$out/bench.txt"
for s in "${scenes[@]}"; do
    for ((i = 1; i <= rounds; i++)); do
        for bin in "$a" "$b"; do
            echo "== $bin, $s, round $i" >> "$out/bench.txt"
            if run 60 "$bin" bench --device gpu --scenes "scenes/$s.sl" --max-spheres 0 "${large[@]}" \
                -o "$scratch/b.md" > /dev/null 2> "$scratch/err"; then
                grep "^| $s.sl" "$scratch/b.md" >> "$out/bench.txt"
            else
                tail -3 "$scratch/err" >> "$out/bench.txt"
            fi
        done
    done
done
: > "$out/profile.txt"
for s in "${scenes[@]}"; do
    for bin in "$a" "$b"; do
        echo "== $bin, $s" >> "$out/profile.txt"
        run 60 "$bin" render "scenes/$s.sl" --device gpu "${large[@]}" --profile -o "$scratch/p.exr" 2>&1 |
            grep -E '^\| [a-z]|busy|samples in' >> "$out/profile.txt"
    done
done
cat "$out/cornell.txt" "$out/bench.txt"
