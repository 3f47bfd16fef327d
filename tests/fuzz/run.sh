#!/usr/bin/env bash
# Runs one libFuzzer target from build-fuzz for SECONDS (docs/testing.md, "Fuzzing"): seeds from
# tests/fuzz/seeds, data/ and Debian's assimp-testmodels, the target's dictionary, inputs up to
# 1 MB so deep nesting is reachable. Crashes land in build-fuzz/artifacts/.
# Usage: run.sh TARGET SECONDS [libFuzzer options...]
#   (TARGET: gltf glb scenario technique gate sweep_shard sweep_vary diff cache_entry units)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
target=$1
seconds=$2
shift 2
build=${PENUMBRA_FUZZ_BUILD:-$root/build-fuzz}
bin=$build/tests/fuzz/fuzz_$target
seeds=$build/seeds/$target
corpus=$build/corpus/$target
mkdir -p "$seeds" "$corpus" "$build/artifacts"
assimp=/usr/share/assimp/models
copy_seeds() {  # files of at most 1 MB
    find "$@" -type f -size -1025k -exec cp -t "$seeds" {} + 2>/dev/null || true
}
# The targets write each input into this folder; external buffers of the seeds lie beside it.
export PENUMBRA_FUZZ_SCRATCH=$build/scratch/$target
mkdir -p "$PENUMBRA_FUZZ_SCRATCH"
case $target in
    gltf)
        dict=gltf.dict
        if [ -d "$assimp" ]; then
            copy_seeds "$assimp/glTF2" "$assimp/glTF" -name '*.gltf'
            find "$assimp/glTF2" "$assimp/glTF" -type f -name '*.bin' -size -1025k \
                -exec cp -t "$PENUMBRA_FUZZ_SCRATCH" {} + 2>/dev/null || true
        fi
        ;;
    glb)
        dict=gltf.dict
        copy_seeds "$root/data" -name '*.glb'
        [ -d "$assimp" ] && copy_seeds "$assimp/glTF2" "$assimp/glTF" -name '*.glb'
        ;;
    scenario)
        dict=scenario.dict
        copy_seeds "$root/tests/fuzz/seeds/scenario" "$root/data" -name '*.json'
        ;;
    technique | gate | sweep_shard | sweep_vary | diff | units)
        dict=$target.dict
        copy_seeds "$root/tests/fuzz/seeds/$target"
        ;;
    cache_entry)
        # No dictionary: the target stores a valid entry among the seeds as it starts.
        dict=
        export PENUMBRA_FUZZ_SEEDS=$seeds
        ;;
    *)
        echo "unknown target $target (gltf glb scenario technique gate sweep_shard sweep_vary diff cache_entry units)" >&2
        exit 2
        ;;
esac
# -rss_limit_mb: a finding is any input that makes the loader use 4 GB (the targets cap scenes
# at 1 GB); -timeout: any input that takes 20 s.
# With -jobs, libFuzzer writes fuzz-<n>.log into the current folder: one folder per target, so
# that campaigns of two targets at once do not write into each other's log.
mkdir -p "$build/logs/$target"
cd "$build/logs/$target"
exec "$bin" "$corpus" "$seeds" ${dict:+-dict="$root/tests/fuzz/$dict"} -max_len=1048576 -timeout=20 -rss_limit_mb=4096 \
    -max_total_time="$seconds" -artifact_prefix="$build/artifacts/$target-" -print_final_stats=1 "$@"
