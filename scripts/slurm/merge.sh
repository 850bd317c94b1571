#!/usr/bin/env bash
# Merges the parts render_shard.sh wrote into one image (run after every shard is done).
#
#   merge.sh OUT_DIR OUTPUT.exr
set -euo pipefail

out=${1:?usage: merge.sh OUT_DIR OUTPUT.exr}
output=${2:?usage: merge.sh OUT_DIR OUTPUT.exr}
shopt -s nullglob
parts=("$out"/part_*.exr)
if [ ${#parts[@]} -eq 0 ]; then
    echo "merge.sh: no parts in $out" >&2
    exit 1
fi
exec "${LUMEN:-lumen}" merge -o "$output" "${parts[@]}"
