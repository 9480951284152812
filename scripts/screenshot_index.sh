#!/usr/bin/env bash
# Render an output folder's index.html in headless Chromium and save a screenshot, to check
# by eye that a page opens in a browser with its plots and numbers.
#   usage: scripts/screenshot_index.sh [OUTDIR=grainmech-out/run] [PNG=OUTDIR/index-screenshot.png]
# Needs Debian's chromium (apt-get install chromium). No network access is used.
set -euo pipefail
out="${1:-grainmech-out/run}"
png="${2:-$out/index-screenshot.png}"
[ -f "$out/index.html" ] || { echo "no $out/index.html (run grainmech run or grainmech reproduce first)" >&2; exit 2; }
browser="$(command -v chromium || command -v chromium-browser || true)"
[ -n "$browser" ] || { echo "chromium not found (apt-get install chromium)" >&2; exit 2; }
profile="$(mktemp -d)"
trap 'rm -rf "$profile"' EXIT
"$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --user-data-dir="$profile" --window-size=1200,1600 \
  --screenshot="$(realpath -m "$png")" "file://$(realpath "$out")/index.html" 2>/dev/null
echo "wrote $png"
