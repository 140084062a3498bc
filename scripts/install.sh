#!/usr/bin/env bash
# Installs the mtwin binary AND the FMU slave library side by side (so `mtwin export`
# finds libmtwin_fmu.so next to the executable), into ${CARGO_HOME:-~/.cargo}/bin or $1.
set -euo pipefail
cd "$(dirname "$0")/.."
dest=${1:-${CARGO_HOME:-$HOME/.cargo}/bin}
cargo build --release -p mtwin -p mtwin-fmu
mkdir -p "$dest"
install -m 755 target/release/mtwin "$dest/mtwin"
install -m 644 target/release/libmtwin_fmu.so "$dest/libmtwin_fmu.so"
echo "installed $dest/mtwin and $dest/libmtwin_fmu.so"
