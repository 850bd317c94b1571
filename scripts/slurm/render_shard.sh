#!/usr/bin/env bash
# Renders one shard of an image: the command each task of a Slurm job array and each pod
# of a Kubernetes Indexed Job runs (deploy/kubernetes/ uses this very script).
#
#   render_shard.sh SCENE SHARDS OUT_DIR [lumen render options...]
#
# The shard index comes from SLURM_ARRAY_TASK_ID, else JOB_COMPLETION_INDEX (Kubernetes),
# else SHARD_INDEX; the part is written to OUT_DIR/part_NNNN.exr (EXR: it records the
# sample range for `lumen merge`). LUMEN names the binary (default: lumen on PATH).
set -euo pipefail

scene=${1:?usage: render_shard.sh SCENE SHARDS OUT_DIR [lumen render options...]}
shards=${2:?usage: render_shard.sh SCENE SHARDS OUT_DIR [lumen render options...]}
out=${3:?usage: render_shard.sh SCENE SHARDS OUT_DIR [lumen render options...]}
shift 3
index=${SLURM_ARRAY_TASK_ID:-${JOB_COMPLETION_INDEX:-${SHARD_INDEX:-}}}
if [ -z "$index" ]; then
    echo "render_shard.sh: no shard index (set SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX or SHARD_INDEX)" >&2
    exit 2
fi
mkdir -p "$out"
exec "${LUMEN:-lumen}" render "$scene" --shard "$index/$shards" -o "$out/$(printf 'part_%04d.exr' "$index")" "$@"
