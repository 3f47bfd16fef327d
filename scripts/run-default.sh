#!/usr/bin/env bash
# Sets up, builds, and runs penumbra validate on the bundled default scenario (data/default):
# the oracle, the raster path with the scenario's technique, the metrics and the report.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/build.sh"
out="$root/out/default"
rm -rf "$out"
"$root/build/app/penumbra" validate "$root/data/default/scenario.json" --out "$out"
echo "open $out/report.html: where the scenario's technique (on lavapipe) is wrong, and why;"
echo "report.json has the numbers; add --errors for errors.exr (the error per pixel), --frames for"
echo "oracle.exr and raster.exr too (the frames behind them)"
