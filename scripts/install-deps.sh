#!/usr/bin/env bash
# Installs exactly the Debian packages rrslam needs, and only those missing.
# Does nothing (and needs no root) when every package is already installed.
# Usage: scripts/install-deps.sh [build|all] [--print]
#   build  what building the tools and running them needs (`make demo`, `make tools`)
#   all    build's, plus what only the tests and fuzzers need (`make test`); the default
#   --print  lists the group's packages and exits
set -euo pipefail

group=all
print=0
for arg in "$@"; do
  case "$arg" in
    build | all) group=$arg ;;
    --print) print=1 ;;
    *) echo "install-deps: unknown argument '$arg' (expected build, all or --print)" >&2; exit 64 ;;
  esac
done

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config git
  libopencv-dev libopencv-contrib-dev libeigen3-dev libceres-dev libflann-dev libopenimageio-dev
  libhdf5-dev libcli11-dev libspdlog-dev libgtest-dev nlohmann-json3-dev
  libxxhash-dev libpng-dev libjpeg-dev
  liboctomap-dev  # render's octomap and grid commands
  nodejs     # node and npm: bundle the render stage's browser viewer (three.js, esbuild)
)
# Debian's nodejs comes without npm (a package of its own); a Node.js that
# brings its own npm (NodeSource's, as on the project's machines) conflicts
# with that package, so it is only asked for when there is no npm.
if ! command -v npm >/dev/null; then
  PACKAGES+=(npm)
fi
if [[ "$group" == all ]]; then
  PACKAGES+=(
    clang libclang-rt-14-dev   # libFuzzer for `make fuzz` and the fuzz smoke tests
    chromium   # headless WebGL test of that viewer (render/html_viewer)
    slurm-wlm munge  # LAUNCHER=srun: the e2e/slurm test starts a one-node Slurm of its own
    cloudcompare     # render's PLY test reads rrslam's PLY with CloudCompare's command line
    colmap           # render's COLMAP test reads rrslam's model with COLMAP's model_analyzer
    octomap-tools    # render's OctoMap test reads rrslam's .bt with convert_octree
  )
fi

if [[ $print -eq 1 ]]; then
  printf '%s\n' "${PACKAGES[@]}"
  exit 0
fi

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  exit 0
fi

echo "install-deps: installing ${#missing[@]} Debian packages ($group): ${missing[*]}" >&2
echo "install-deps: this takes a minute or two (the build group took 85 s on the project's 2-core machine)" >&2
SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null; then SUDO="sudo"; else
    echo "install-deps: need root to install: ${missing[*]}" >&2; exit 77; fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
