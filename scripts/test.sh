#!/usr/bin/env bash
# Every test of mtwin, from a fresh clone: formatting, lints, Rust tests, docs, and the
# FMU in real importers (fmpy, libcosimpy) from a pinned Python venv this script sets up.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup-rust.sh
echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --workspace --all-targets -- -D warnings
echo "== cargo test"
cargo test --workspace
echo "== cargo doc"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps
echo "== FMU in real importers (pytest: fmpy, libcosimpy)"
./scripts/setup-python.sh
cargo build --release --workspace --bins --examples
.venv/bin/python -m pytest -q tests/python
