#!/usr/bin/env bash
# Renders an mtwin HTML report in headless Chromium and saves a PNG screenshot, to check
# that the report renders (and to look at it).
# Usage: scripts/screenshot-report.sh REPORT.html [OUT.png]
# Installs Debian's chromium when missing (needs root or sudo).
set -euo pipefail
report=${1:?usage: $0 REPORT.html [OUT.png]}
out=${2:-${report%.html}.png}
if ! command -v chromium >/dev/null 2>&1; then
    echo "chromium not found: installing Debian's package" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium >/dev/null
fi
abs=$(cd "$(dirname "$report")" && pwd)/$(basename "$report")
chromium --headless --no-sandbox --disable-gpu --hide-scrollbars \
    --window-size=1100,4000 --screenshot="$out" "file://$abs" 2>/dev/null
test -s "$out"
echo "screenshot -> $out"
