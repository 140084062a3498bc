#!/usr/bin/env bash
# Creates .venv with the pinned Python packages the FMU tests need (fmpy, pytest,
# numpy), the Python package's build (maturin), its fleet example (dask, distributed) and
# quickstart figure (matplotlib); libcosimpy as an optional second importer. Idempotent;
# fast when set up. The package itself: scripts/build-wheel.sh --install.
set -euo pipefail
cd "$(dirname "$0")/.."
req=tests/python/requirements.txt
stamp=.venv/.requirements.sha
want=$(sha256sum "$req" | cut -d' ' -f1)
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
    exit 0
fi
if ! python3 -m venv --help >/dev/null 2>&1 || ! python3 -c "import ensurepip" >/dev/null 2>&1; then
    echo "python3 venv/ensurepip missing: installing python3-venv" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq python3-venv >/dev/null
fi
python3 -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip >/dev/null
.venv/bin/python -m pip install -q -r "$req"
# optional second importer (Open Simulation Platform's libcosim); tests skip without it
.venv/bin/python -m pip install -q libcosimpy==0.0.6 >/dev/null 2>&1 \
    || echo "note: libcosimpy==0.0.6 did not install here; its test will be skipped" >&2
echo "$want" > "$stamp"
