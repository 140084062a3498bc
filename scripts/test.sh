#!/usr/bin/env bash
# Every test of mtwin, from a fresh clone: formatting, lints, Rust tests, docs, and the
# FMU in real importers (fmpy, libcosimpy) and the Python package `mtwin` (its wheel built
# and installed) from a pinned Python venv this script sets up.
set -euo pipefail
cd "$(dirname "$0")/.."
# every stage prints the seconds since the start, so a slow stage shows in the log
stage() { echo "== $* (at ${SECONDS} s)"; }
# cargo's rustc probes read /dev/null: replaced by a regular file (a rename onto it as
# root), it feeds them whatever other programs discarded and the build fails obscurely
if [ ! -c /dev/null ]; then
    echo "warning: /dev/null is not a character device (it was replaced by a regular file);" \
        "builds may fail in cargo's rustc probe; restore it as root:" \
        "rm /dev/null && mknod -m 666 /dev/null c 1 3" >&2
fi
./scripts/setup-rust.sh
stage "cargo fmt --check"
cargo fmt --all -- --check
stage "cargo clippy"
# in the release profile, as every build below: build scripts and proc macros are then
# compiled once for all stages (the dev profile builds them again, at opt-level 3)
cargo clippy --release --workspace --all-targets -- -D warnings
# release: the build the importers' tests below use too, and the CLI tests run identify
# on real-size data (the debug build cost ~8 of the suite's 20 minutes)
stage "cargo test (release)"
cargo test --workspace --release
stage "cargo doc"
RUSTDOCFLAGS="-D warnings" cargo doc --release --workspace --no-deps
stage "FMU in real importers (pytest: fmpy, libcosimpy), the Python package, its fleet on Dask"
./scripts/setup-python.sh
cargo build --release --workspace --bins --examples
./scripts/build-wheel.sh --install
.venv/bin/python -m pytest -q tests/python
stage "all tests passed"
