#!/bin/bash
# Merges the shards docs/slurm/sweep-array.sh wrote, $OUT-1 ... $OUT-$SHARDS, into $OUT
# (penumbra merge: the files one run writes). Submit it to run once every array task succeeded:
#
#   sbatch --dependency=afterok:$job --export=ALL,SHARDS=8 docs/slurm/merge.sh [MERGE ARGUMENTS...]
#
# Environment: PENUMBRA and OUT as for sweep-array.sh; SHARDS, the array's size N (required).
#SBATCH --job-name=penumbra-merge
set -euo pipefail
PENUMBRA=${PENUMBRA:-penumbra}
OUT=${OUT:-sweep}
: "${SHARDS:?merge.sh: set SHARDS to the number of shards (sbatch --export=ALL,SHARDS=N)}"
shards=()
for k in $(seq 1 "$SHARDS"); do shards+=("$OUT-$k"); done
exec "$PENUMBRA" merge "${shards[@]}" --out "$OUT" "$@"
