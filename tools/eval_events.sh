#!/usr/bin/env bash
# Event quality of the shipped DIS scenarios with a chosen vision sensor on every camera:
# runs each scenario (copied to scenarios/tmp_events_<name>.yaml with the sensor attached),
# then `vigil eval`, and prints one line per scenario (reported / true events, precision,
# recall, latency, localisation error) from each run's eval.json.
#   tools/eval_events.sh [truth|sgbm|gt-depth] [OUT_DIR] [scenario ...]
# sgbm: the rendered plan-view pipeline with SGBM disparity (the issue's target);
# gt-depth: the same with true depth; truth: the fast ground-truth sensor model.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mode="${1:-sgbm}"
out="${2:-$here/runs/events_$mode}"
shift $(( $# > 2 ? 2 : $# )) || true
scenarios=("$@")
[ ${#scenarios[@]} -gt 0 ] || scenarios=(dis_left_bag dis_bag_taken dis_lab_unauthorised dis_bag_stay dis_walk_past dis_walk_together dis_occlusion)
vigil="$here/build/tools/vigil"
case "$mode" in
  truth) plugin="    plugin: truth" ;;
  sgbm) plugin=$'    plugin: planview\n    params: {disparity: sgbm}' ;;
  gt-depth) plugin=$'    plugin: planview\n    params: {disparity: truth}' ;;
  *) echo "eval_events: mode must be truth, sgbm or gt-depth" >&2; exit 2 ;;
esac
mkdir -p "$out"
for s in "${scenarios[@]}"; do
  copy="$here/scenarios/tmp_events_$s.yaml"
  python3 - "$here/scenarios/$s.yaml" "$copy" "$plugin" <<'PY'
import re, sys
src, dst, plugin = sys.argv[1], sys.argv[2], sys.argv[3]
out = []
for line in open(src).read().split('\n'):
    out.append(line)
    if re.match(r'^  - id: cam_\w+$', line):
        out.append(plugin)
open(dst, 'w').write('\n'.join(out))
PY
  "$vigil" run "$copy" --out "$out/$s" --no-video -q >/dev/null
  "$vigil" eval "$out/$s" >/dev/null
  rm -f "$copy"
  python3 - "$out/$s/eval.json" "$s" <<'PY'
import json, sys
e = json.load(open(sys.argv[1]))['events']
lat = e['latency_s']; err = e['localisation_error_m']
f = lambda v: '-' if v is None else '%.2f' % v
print('%-22s truth %d reported %d matched %d precision %.2f recall %.2f latency_s %s error_m %s missed %s false %s' % (
    sys.argv[2], e['truth'], e['reported'], e['matched'], e['precision'], e['recall'], f(lat), f(err),
    [m['kind'] for m in e['missed']], [x['kind'] for x in e['false_reports']]))
PY
done
