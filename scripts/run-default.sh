#!/usr/bin/env bash
# Sets up, builds, and runs penumbra on the bundled default scenario (data/default).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/build.sh"
out="$root/out/default"
rm -rf "$out"
"$root/build/app/penumbra" oracle "$root/data/default/scenario.json" --out "$out"
echo "open $out/oracle.png for a preview; $out/oracle.json says what the oracle did"
