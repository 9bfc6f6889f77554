#!/usr/bin/env bash
# Installs the Debian 12 packages mocap-clean needs (only those missing) and builds it.
# Environment: BUILD_DIR (default build), MOCAP_SANITIZE (e.g. address,undefined), BUILD_TYPE.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake ninja-build pkg-config git
  libtbb-dev libhdf5-dev libhwy-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev libfmt-dev nlohmann-json3-dev
  hdf5-filter-plugin liblz4-dev zlib1g-dev python3-h5py python3-numpy
  pybind11-dev python3-pybind11 python3-dev python3-pytest python3-scipy
  libopenmpi-dev openmpi-bin
  clang  # the libFuzzer targets in fuzz/ (-DMOCAP_FUZZ=ON with CXX=clang++)
  chromium python3-pil  # the review page's browser test (tests/review_page)
)
# npm fetches three.js for the review page (--report); any node install that has npm will do.
command -v npm >/dev/null 2>&1 || packages+=(npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# three.js, bundled into the program for the review page (web/review/package-lock.json pins it).
# Offline, the build goes on without it and `--report` says how to get it.
if [ ! -f web/review/node_modules/three/build/three.module.min.js ]; then
  if ! (cd web/review && npm ci --no-audit --no-fund --loglevel=error); then
    echo "setup: could not install three.js with npm (offline?): mocap-clean --report will be" \
      "unavailable until scripts/setup.sh runs again with the npm registry reachable" >&2
  fi
fi

build_dir="${BUILD_DIR:-build}"
cmake -S . -B "$build_dir" -G Ninja \
  -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" \
  -DMOCAP_SANITIZE="${MOCAP_SANITIZE:-}" \
  -DMOCAP_BUILD_BENCH="${MOCAP_BUILD_BENCH:-ON}" >/dev/null
cmake --build "$build_dir" -j "$(nproc)"
if ls "$build_dir"/python/mocap_clean*.so >/dev/null 2>&1; then
  echo "setup: the Python module is in $build_dir/python: export PYTHONPATH=$(cd "$build_dir/python" && pwd)" >&2
fi
