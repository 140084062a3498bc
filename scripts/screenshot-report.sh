#!/usr/bin/env bash
# Renders an mtwin HTML report (or an SVG plot) in headless Chromium and saves a PNG
# screenshot, to check that the report renders and to look at it as a reader would.
# Usage: scripts/screenshot-report.sh REPORT.html [OUT.png] [HEIGHT] [WIDTH]
#   HEIGHT, WIDTH: the window in pixels (default 4000 x 1100); the screenshot is the
#   window, so a long report needs a tall one (identify.html of 18 poses: ~7200 with the
#   first pose open). scripts/docs-screenshots.sh makes the pictures in docs/img from it.
# Installs Debian's chromium when missing (needs root or sudo).
set -euo pipefail
report=${1:?usage: $0 REPORT.html [OUT.png] [HEIGHT] [WIDTH]}
out=${2:-${report%.*}.png}
height=${3:-4000}
width=${4:-1100}
if ! command -v chromium >/dev/null 2>&1; then
    echo "chromium not found: installing Debian's package" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium >/dev/null
fi
abs=$(cd "$(dirname "$report")" && pwd)/$(basename "$report")
chromium --headless --no-sandbox --disable-gpu --hide-scrollbars \
    --window-size="$width,$height" --screenshot="$out" "file://$abs" 2>/dev/null
test -s "$out"
echo "screenshot -> $out"
