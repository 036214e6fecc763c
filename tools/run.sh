#!/usr/bin/env bash
# Installs what is missing, builds, and runs the default scenario (dis_team_bag_taken) headless
# with the whole loop: every camera rendered, the plan-view tracker on SGBM disparity, activity
# rules, events over DDS to the video server, incidents over DDS to the patrolling robot team,
# token passing, the chosen robot drives there, guards and (bag taken) takes its picture; then
# scores tracks, events, navigation, patrol idleness and the response against the ground truth
# (vigil eval), and writes report.html (vigil report). Extra arguments go to `vigil run`, e.g. tools/run.sh --no-video --seed 7.
# VIGIL_SCENARIO picks another scenario; VIGIL_SENSOR=truth uses the fast ground-truth sensor;
# VIGIL_EVAL_CAMERA the camera whose view the tracking is scored in (default cam_corridor).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/tools/build.sh"
scenario="${VIGIL_SCENARIO:-$here/scenarios/dis_team_bag_taken.yaml}"
out="$here/runs/$(basename "$scenario" .yaml)"
"$here/build/tools/vigil" run "$scenario" --sensor "${VIGIL_SENSOR:-planview}" --out "$out" "$@"
# Tracking is scored where one camera looks (people and bags within 8 m, in its field of view,
# carried bags left out); events over the whole run. VIGIL_EVAL_CAMERA picks the camera.
camera="${VIGIL_EVAL_CAMERA:-cam_corridor}"
if grep -Eq "^[[:space:]]*- id: ${camera}[[:space:]]*$" "$scenario"; then
  "$here/build/tools/vigil" eval "$out" --camera "$camera" --scenario "$scenario" --max-range 8 --in-view \
    --exclude-carried --classes person,bag
else
  "$here/build/tools/vigil" eval "$out"
fi
# One page with the run: the top-down view over time, the cameras' videos, the tables and plots.
"$here/build/tools/vigil" report "$out" --scenario "$scenario"
echo "report: $out/report.html (open it in a browser; it reads the videos beside it)"
