#!/usr/bin/env bash
# Renders an eval report (REPORT_DIR/index.html, written by `mocap-clean eval`) to a PNG with
# headless Chromium, to look at what a reader of the report sees.
#
#   scripts/render_report.sh REPORT_DIR [OUT.png] [WIDTHxHEIGHT]
#
# OUT.png defaults to REPORT_DIR/index.png, the window to 1400x2400. Installs Debian's chromium
# when it is missing (needs root and the Debian package mirror).
set -euo pipefail

if [[ $# -lt 1 || $# -gt 3 ]]; then
  echo "usage: $0 REPORT_DIR [OUT.png] [WIDTHxHEIGHT]" >&2
  exit 2
fi
report_dir=$(cd "$1" && pwd)
page="$report_dir/index.html"
out=${2:-$report_dir/index.png}
size=${3:-1400x2400}
if [[ ! -f "$page" ]]; then
  echo "$0: $page not found (run mocap-clean eval first)" >&2
  exit 2
fi
case "$out" in /*) ;; *) out="$PWD/$out" ;; esac

browser=$(command -v chromium || command -v chromium-browser || true)
if [[ -z "$browser" ]]; then
  echo "$0: installing chromium (Debian package)" >&2
  apt-get update -qq >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
  browser=$(command -v chromium)
fi

profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
# No network, no first-run UI, no background services: a plain render of a local file.
"$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --user-data-dir="$profile" --hide-scrollbars --window-size="${size/x/,}" \
  --screenshot="$out" "file://$page" >/dev/null 2>&1
if [[ ! -s "$out" ]]; then
  echo "$0: chromium wrote no screenshot to $out" >&2
  exit 1
fi
echo "$out"
