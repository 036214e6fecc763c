#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test with ctest.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/tools/build.sh"
jobs="$(nproc 2>/dev/null || echo 2)"
cd "$here/build"
ctest --output-on-failure -j "$jobs" "$@"
