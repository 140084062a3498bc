#!/usr/bin/env bash
# Creates .venv-bench with the pinned Python tools that scripts/bench_peers.py compares
# mtwin with (numpy, scipy, sdypy-EMA, scikit-rf). Idempotent; fast when set up.
set -euo pipefail
cd "$(dirname "$0")/.."
req=scripts/requirements-bench.txt
stamp=.venv-bench/.requirements.sha
want=$(sha256sum "$req" | cut -d' ' -f1)
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
    exit 0
fi
if ! python3 -m venv --help >/dev/null 2>&1 || ! python3 -c "import ensurepip" >/dev/null 2>&1; then
    echo "python3 venv/ensurepip missing: installing python3-venv" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq python3-venv >/dev/null
fi
python3 -m venv .venv-bench
.venv-bench/bin/python -m pip install -q --upgrade pip >/dev/null
.venv-bench/bin/python -m pip install -q -r "$req"
echo "$want" > "$stamp"
