#!/usr/bin/env bash
# Installs missing Debian packages, then configures and builds Vigil (Release) into build/.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/tools/install_deps.sh"
jobs="$(nproc 2>/dev/null || echo 2)"
cmake -S "$here" -B "$here/build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$here/build" -j "$jobs"
