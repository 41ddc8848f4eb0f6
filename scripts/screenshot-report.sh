#!/usr/bin/env bash
# Looks at a report in a real browser: renders REPORT.html with headless Chromium (Debian's
# package, installed if missing) into a PNG.
#   bash scripts/screenshot-report.sh out/demo/report.html out/demo/report.png
set -euo pipefail
html="${1:-out/demo/report.html}"
png="${2:-${html%.html}.png}"
if ! command -v chromium >/dev/null 2>&1; then
    apt-get update -qq && apt-get install -y -qq chromium >/dev/null
fi
profile=$(mktemp -d)
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --user-data-dir="$profile" --window-size=1000,2400 \
    --screenshot="$png" "file://$(realpath "$html")" 2>/dev/null
rm -rf "$profile"
echo "screenshot: $png"
