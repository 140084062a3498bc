#!/usr/bin/env bash
# The pictures in docs/img: every report of `mtwin demo` rendered in headless Chromium
# (scripts/screenshot-report.sh), cut to the part each picture shows and reduced to 96
# colours with ImageMagick's `convert` (each well under 200 kB).
# Usage: scripts/docs-screenshots.sh [DEMO_DIR]   (default: runs `mtwin demo` into a
#        temporary folder; MTWIN=path/to/mtwin, default target/release/mtwin)
# The cuts are pixel offsets into the demo's pages as they are today: after a change to
# a report, look at the pictures (and move an offset) before committing them.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
mtwin=${MTWIN:-$root/target/release/mtwin}
command -v convert >/dev/null || { echo "needs ImageMagick's convert" >&2; exit 1; }
demo=${1:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ -z "$demo" ]; then
    # a relative folder: the pages then name their files `mtwin-demo/data/...`
    (cd "$work" && "$mtwin" demo --out mtwin-demo -q)
    demo=$work/mtwin-demo
fi
demo=$(cd "$demo" && pwd)
# the same campaign's report with real and imaginary parts
(cd "$demo" && "$mtwin" identify data/campaign --fmin 30 --fmax 2500 --frf-plot re-im \
    --out "$work/reim.json" --report "$work/identify_reim.html" -q)
# `mtwin frf --report` on the first pose's two hammer records
# (relative paths: the page names its files as a user typing the command would)
ln -sfn "$demo/data" "$work/data"
(cd "$work" && "$mtwin" frf data/campaign/pose01_hammer_x.csv data/campaign/pose01_hammer_y.csv \
    --out frf.csv --report frf.html -q)
shot() { "$here/screenshot-report.sh" "$1" "$work/$2.png" "$3" "${4:-1100}" >/dev/null; }
shot "$demo/identify.html" identify 7300
shot "$work/identify_reim.html" reim 5200
shot "$demo/refit.html" refit 5500
shot "$demo/diagnosis/report.html" diagnosis 1400
shot "$demo/lobes_before.svg" lobes 440 920
shot "$demo/index.html" index 1000
shot "$work/frf.html" frf 760
img=$root/docs/img
mkdir -p "$img"
cut() { # SOURCE GEOMETRY NAME
    convert "$work/$1.png" -crop "$2" +repage -strip -colors 96 "png8:$img/$3.png"
    echo "docs/img/$3.png $(stat -c %s "$img/$3.png") bytes"
}
cut identify 1100x1000+0+0 identify-modes
cut identify 1100x700+0+1480 identify-poses
cut identify 1100x590+0+3440 identify-tracked-modes
cut identify 1100x625+0+4405 identify-frf-mag-phase
cut reim 1100x600+0+4405 identify-frf-re-im
cut identify 1100x475+0+6688 identify-stabilization
cut refit 1100x1250+0+0 refit
cut refit 1100x740+0+4695 refit-history
cut diagnosis 1100x1300+0+0 diagnosis
cut lobes 920x440+0+0 lobes
cut index 1100x1000+0+0 demo-index
cut frf 1100x760+0+0 frf
