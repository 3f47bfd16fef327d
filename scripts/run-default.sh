#!/usr/bin/env bash
# Sets up, builds, and runs penumbra on the bundled default scenario (data/default): the oracle,
# then the raster path with the scenario's technique.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/build.sh"
out="$root/out/default"
rm -rf "$out"
"$root/build/app/penumbra" oracle "$root/data/default/scenario.json" --out "$out"
"$root/build/app/penumbra" raster "$root/data/default/scenario.json" --out "$out"
echo "compare $out/oracle.png (the truth) with $out/raster.png (the scenario's technique, on lavapipe);"
echo "oracle.json and raster.json say what each did and how long it took"
