#!/usr/bin/env bash
# Submits a sharded render to Slurm: a job array of SHARDS tasks (each renders its shard
# with render_shard.sh) and a merge job that runs only once every task has succeeded
# (--dependency=afterok). Prints the two job ids.
#
#   submit.sh SCENE SHARDS OUT_DIR OUTPUT.exr [lumen render options...]
#
# e.g. submit.sh scenes/cornell.sl 16 /shared/cornell /shared/cornell.exr --spp 4096 --device gpu
# sbatch options (partition, account, GPUs per task…) come from the usual SBATCH_*
# environment variables, e.g. SBATCH_PARTITION=gpu SBATCH_GPUS_PER_TASK=1. Logs go to
# OUT_DIR/logs/. Paths must be visible from every node (a shared file system). A task that
# Slurm ends (time limit, scancel: SIGTERM) exits with status 143 and leaves no partial
# part; pass --time-limit SECONDS below the job's limit to keep what a task rendered.
set -euo pipefail

usage="usage: submit.sh SCENE SHARDS OUT_DIR OUTPUT.exr [lumen render options...]"
scene=${1:?$usage}
shards=${2:?$usage}
out=${3:?$usage}
output=${4:?$usage}
shift 4
case "$shards" in
'' | *[!0-9]* | 0) echo "submit.sh: SHARDS must be a positive whole number, got '$shards'" >&2; exit 2 ;;
esac
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out/logs"
array=$(sbatch --parsable --array="0-$((shards - 1))" --job-name=lumen-shards \
    --output="$out/logs/shard_%a.log" "$here/render_shard.sh" "$scene" "$shards" "$out" "$@")
array=${array%%;*}
merge=$(sbatch --parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes --job-name=lumen-merge \
    --output="$out/logs/merge.log" "$here/merge.sh" "$out" "$output")
echo "$array ${merge%%;*}"
