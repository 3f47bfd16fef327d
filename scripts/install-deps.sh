#!/usr/bin/env bash
# Installs every Debian 12 package penumbra needs to build, run and test.
# Idempotent: packages already present are left alone. Needs root (or sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libembree-dev libtbb-dev libglm-dev
  libopenimageio-dev libopenexr-dev libpng-dev zlib1g-dev libxxhash-dev
  libtinygltf-dev nlohmann-json3-dev libstb-dev
  libcli11-dev libfmt-dev libspdlog-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libvulkan-dev mesa-vulkan-drivers glslang-tools vulkan-validationlayers vulkan-tools
  python3 assimp-testmodels assimp-utils  # tests: third-party models, converted to glTF (tests/cli/init_test.sh)
  chromium libxml2-utils  # tests: report.html in a headless browser, JUnit against its schema
  clang libclang-rt-14-dev  # tests: the libFuzzer targets (tests/fuzz, docs/testing.md)
  valgrind  # tests: the oracle under memcheck (tests/cli/valgrind_oracle.sh)
  xxhash  # tests: xxhsum remakes a crafted cache entry's checksum (tests/cli/files_under_attack.sh)
  slurm-wlm munge  # tests: sweeps as a Slurm job array (tests/cli/slurm_sweep_test.sh)
  nodejs  # tests/engines: real engines in chromium (npm installs what its package-lock.json pins; below)
)

# tests/engines' npm packages, exactly as its lockfile pins them (from the npm registry), once
# per lockfile change.
engine_packages() {
  local dir
  dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/tests/engines"
  # Debian's nodejs comes without npm (a package of its own); a Node.js from elsewhere brings its own.
  if ! command -v npm >/dev/null; then
    echo "install-deps: installing Debian's npm for tests/engines"
    "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends npm >/dev/null ||
      { echo "install-deps: npm did not install: tests/engines will fail"; return 0; }
  fi
  cmp -s "$dir/package-lock.json" "$dir/node_modules/.penumbra-lock" && return 0
  (cd "$dir" && npm ci --no-audit --no-fund --ignore-scripts >/dev/null && cp package-lock.json node_modules/.penumbra-lock)
  echo "install-deps: tests/engines npm packages installed"
}

sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages present"
  engine_packages
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
engine_packages
