#!/usr/bin/env bash
# Installs what the Rust tests need beyond the toolchain: libclang, for the bindgen build
# of fmi-sys (rust-fmi, the importer of fmu/tests/importer.rs). Idempotent; fast when
# set up.
set -euo pipefail
[ -n "${LIBCLANG_PATH:-}" ] && exit 0
for f in /usr/lib/llvm-*/lib/libclang.so* /usr/lib/*/libclang.so* /usr/lib/*/libclang-[0-9]*.so*; do
    [ -e "$f" ] && exit 0
done
echo "libclang missing (bindgen of fmi-sys needs it): installing libclang-dev" >&2
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libclang-dev >/dev/null
