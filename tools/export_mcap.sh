#!/usr/bin/env bash
# Writes a run's MCAP for Foxglove; `vigil export-mcap RUN_DIR` calls it with the scene it read
# (tools/vigil/cmd_export_mcap.cpp). Makes a Python virtual environment the first time
# (${VIGIL_VENV:-build/venv}, the packages of tools/requirements-mcap.txt from PyPI), then runs
# tools/export_mcap.py with the arguments. `tools/export_mcap.sh --check RUN.mcap` prints what a
# file holds (topics, schemas, counts, time order; tools/check_mcap.py) instead. docs/FOXGLOVE.md.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${VIGIL_VENV:-$here/build/venv}"
if ! "$venv/bin/python" -c "import mcap, mcap_protobuf, foxglove, cv2" >/dev/null 2>&1; then
  if ! python3 -c "import venv, ensurepip" >/dev/null 2>&1; then
    echo "export_mcap: python3's venv module is missing (tools/install_deps.sh installs python3-venv)" >&2
    exit 1
  fi
  echo "[mcap] making the Python environment $venv (tools/requirements-mcap.txt from PyPI)" >&2
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q --disable-pip-version-check -r "$here/tools/requirements-mcap.txt" >&2
fi
if [ "${1:-}" = "--check" ]; then
  shift
  exec "$venv/bin/python" "$here/tools/check_mcap.py" "$@"
fi
exec "$venv/bin/python" "$here/tools/export_mcap.py" "$@"
