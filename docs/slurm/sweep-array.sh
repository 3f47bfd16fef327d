#!/bin/bash
# A penumbra sweep as a Slurm job array: array task K of N runs shard K/N into $OUT-K
# (docs/sweep.md, "Shards"). tests/cli/slurm_sweep_test.sh submits this file as it is.
#
#   job=$(sbatch --parsable --array=1-8 docs/slurm/sweep-array.sh [SWEEP ARGUMENTS...])
#   sbatch --dependency=afterok:$job --export=ALL,SHARDS=8 docs/slurm/merge.sh
#
# Environment (sbatch passes the submitting shell's, --export=ALL):
#   PENUMBRA  the penumbra binary (default: penumbra on PATH)
#   SCENARIO  the scenario JSON (default: scene.json)
#   OUT       shard K writes the folder $OUT-K (default: sweep); merge.sh writes $OUT
#   CACHE     the oracle cache folder, on storage every node sees; trace the oracle into it once
#             before submitting (penumbra validate "$SCENARIO" --out /tmp/v --cache "$CACHE")
#             so that no task traces it again (default: penumbra's own, $PENUMBRA_CACHE_DIR else
#             ~/.cache/penumbra)
#   SHARDS    N (default: the array's size, which must then be 1-N); set it to run some shards
#             again (sbatch --array=3,5 with SHARDS=8)
# Arguments after the script are sweep's (--vary, --configs, --repeat, --preset, --set, ...);
# without any, the default sweep below. Relative paths are from the submission's folder.
# Each task writes slurm-task.txt into its shard folder: the job, the task and the node.
#SBATCH --job-name=penumbra-sweep
set -euo pipefail
PENUMBRA=${PENUMBRA:-penumbra}
SCENARIO=${SCENARIO:-scene.json}
OUT=${OUT:-sweep}
if [[ -z ${SLURM_ARRAY_TASK_ID:-} ]]; then
    echo "sweep-array.sh: not an array task: submit it with sbatch --array=1-N" >&2
    exit 2
fi
k=$SLURM_ARRAY_TASK_ID
if [[ -n ${SHARDS:-} ]]; then
    n=$SHARDS
elif ((SLURM_ARRAY_TASK_MIN == 1 && SLURM_ARRAY_TASK_MAX == SLURM_ARRAY_TASK_COUNT)); then
    n=$SLURM_ARRAY_TASK_COUNT
else
    echo "sweep-array.sh: the array is not 1-N ($SLURM_ARRAY_TASK_MIN-$SLURM_ARRAY_TASK_MAX," \
        "$SLURM_ARRAY_TASK_COUNT tasks): set SHARDS=N" >&2
    exit 2
fi
if ((k < 1 || k > n)); then
    echo "sweep-array.sh: array task $k is not a shard of $n (--array=1-$n)" >&2
    exit 2
fi
if (($# == 0)); then
    set -- --vary resolution=1024,2048,4096,8192 --vary filter.type=none,hw2x2,pcf,poisson
fi
cache=()
if [[ -n ${CACHE:-} ]]; then cache=(--cache "$CACHE"); fi
rm -f "$OUT-$k/slurm-task.txt"  # a failed task leaves none
"$PENUMBRA" sweep "$SCENARIO" --out "$OUT-$k" --shard "$k/$n" "${cache[@]}" "$@"
echo "job=$SLURM_JOB_ID array_job=${SLURM_ARRAY_JOB_ID} task=$k shards=$n node=${SLURMD_NODENAME:-$(hostname)}" \
    >"$OUT-$k/slurm-task.txt"
