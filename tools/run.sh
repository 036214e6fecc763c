#!/usr/bin/env bash
# Installs what is missing, builds, and runs the default scenario (dis_bag_taken) headless.
# Extra arguments go to `vigil run`, e.g. tools/run.sh --no-video --seed 7.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/tools/build.sh"
scenario="${VIGIL_SCENARIO:-$here/scenarios/dis_bag_taken.yaml}"
exec "$here/build/tools/vigil" run "$scenario" --out "$here/runs/$(basename "$scenario" .yaml)" "$@"
