#!/usr/bin/env bash
# Installs what is missing, builds, and runs the default scenario (dis_bag_taken) headless with
# the whole pipeline: every camera rendered, the plan-view tracker on SGBM disparity, activity
# rules, events over DDS to the video server; then scores tracks and events against the ground
# truth (vigil eval). Extra arguments go to `vigil run`, e.g. tools/run.sh --no-video --seed 7.
# VIGIL_SCENARIO picks another scenario; VIGIL_SENSOR=truth uses the fast ground-truth sensor.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/tools/build.sh"
scenario="${VIGIL_SCENARIO:-$here/scenarios/dis_bag_taken.yaml}"
out="$here/runs/$(basename "$scenario" .yaml)"
"$here/build/tools/vigil" run "$scenario" --sensor "${VIGIL_SENSOR:-planview}" --out "$out" "$@"
"$here/build/tools/vigil" eval "$out"
