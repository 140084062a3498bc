#!/usr/bin/env bash
# Builds the Python package `mtwin` (python/, PyO3 abi3: one wheel for CPython >= 3.9 on
# linux x86_64) with the pinned maturin of .venv (scripts/setup-python.sh) into
# $CARGO_TARGET_DIR/wheels (default target/wheels). With --install, installs it into .venv.
# The wheel ships the FMU slave library (libmtwin_fmu.so) for Twin.export_fmu.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup-python.sh
target=${CARGO_TARGET_DIR:-$PWD/target}
cargo build --release -p mtwin-fmu --lib
cp "$target/release/libmtwin_fmu.so" python/python/mtwin/libmtwin_fmu.so
rm -f "$target"/wheels/mtwin-*.whl
.venv/bin/maturin build --release --quiet -m python/Cargo.toml --out "$target/wheels" \
    --interpreter .venv/bin/python
wheel=$(ls "$target"/wheels/mtwin-*.whl)
echo "wheel: $wheel"
if [ "${1:-}" = "--install" ]; then
    .venv/bin/python -m pip install -q --force-reinstall --no-deps "$wheel"
fi
