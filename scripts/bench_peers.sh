#!/usr/bin/env bash
# mtwin side by side with scipy, sdypy-EMA and scikit-rf on the same data: one Markdown
# table (fit % vs the analytic truth, time, speed-up). One thread everywhere.
# Usage: scripts/bench_peers.sh [--out bench/peers.md] [--dir DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup-bench.sh
export RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
export TQDM_DISABLE=1  # sdypy-EMA progress bars
exec .venv-bench/bin/python scripts/bench_peers.py "$@"
