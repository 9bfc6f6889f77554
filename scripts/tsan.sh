#!/usr/bin/env bash
# The whole test suite under ThreadSanitizer, with a oneTBB built for it. Debian's libtbb is not
# instrumented, so TSan cannot see TBB's own synchronisation and reports races inside the flow
# graph and the partitioner that are not there; this builds Debian's own oneTBB source with
# TBB_SANITIZE=thread first. Run as root on Debian 12 (apt-get source needs a deb-src entry,
# added for the download and removed after); about 12 minutes on 2 cores.
#   bash scripts/tsan.sh [WORK_DIR]     (default /tmp/mocap-tsan)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
work=${1:-/tmp/mocap-tsan}
bash scripts/setup.sh >/dev/null
mkdir -p "$work"
if [ ! -f "$work/tbb-install/lib/cmake/TBB/TBBConfig.cmake" ]; then
  apt-get install -y -qq dpkg-dev >/dev/null
  sources=/etc/apt/sources.list.d/mocap-tsan-src.sources
  trap 'rm -f "$sources"; apt-get update -qq || true' EXIT
  printf 'Types: deb-src\nURIs: http://deb.debian.org/debian\nSuites: bookworm\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' >"$sources"
  apt-get update -qq
  (cd "$work" && apt-get source -qq onetbb)
  rm -f "$sources"
  apt-get update -qq
  trap - EXIT
  tbb_source=$(find "$work" -maxdepth 1 -type d -name 'onetbb-*' | head -1)
  cmake -S "$tbb_source" -B "$work/tbb-build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DTBB_SANITIZE=thread -DTBB_TEST=OFF -DTBB_EXAMPLES=OFF -DTBBMALLOC_BUILD=OFF -DTBB_STRICT=OFF \
    -DCMAKE_INSTALL_PREFIX="$work/tbb-install" >/dev/null
  ninja -C "$work/tbb-build" install >/dev/null
fi
cmake -S "$root" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DMOCAP_SANITIZE=thread -DTBB_DIR="$work/tbb-install/lib/cmake/TBB" >/dev/null
ninja -C "$work/build"
# A race report makes the process exit 66, so the test that ran it fails.
ctest --test-dir "$work/build" --output-on-failure -j "$(nproc)"
