#!/usr/bin/env bash
# Every test of mtwin, from a fresh clone: formatting, lints, Rust tests, docs.
# (Python importer tests join here once the FMU exists.)
set -euo pipefail
cd "$(dirname "$0")/.."
echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --workspace --all-targets -- -D warnings
echo "== cargo test"
cargo test --workspace
echo "== cargo doc"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps
