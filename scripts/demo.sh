#!/usr/bin/env bash
# Set-up as needed, then the main job on the built-in library: `mocap-clean demo`.
# Extra arguments go to the demo, e.g. `bash scripts/demo.sh --method nlpm`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec "${BUILD_DIR:-build}/app/mocap-clean" demo "$@"
