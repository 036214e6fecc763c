#!/usr/bin/env bash
# Event quality on generated scenarios (issue 13): `vigil gen` draws N scenarios of every family
# (or of the families named) with the chosen sensor on every camera, each is run and scored with
# `vigil eval`, and a table per family and per kind is printed and written to OUT/summary.md
# (and OUT/summary.json).
#   tools/eval_generated.sh [truth|truth-clean|sgbm|mser|platform] [N] [OUT_DIR] [--seed S] [--jobs J] [family ...]
# truth: the ground-truth sensor with 0.05 m noise, 5 % misses and 0.05 false tracks per tick
# (the issue's figure: at least 100 scenarios); sgbm: rendered frames, SGBM and the plan view;
# mser: rendered frames (each camera's left image) and the colour MSER system (docs/MSER.md);
# platform: the chapter's platform (10.6.1), sgbm on the corridor camera and the colour MSER
# system on the lab camera.
# VIGIL=PATH runs another build of vigil (default: build/tools/vigil).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mode="${1:-truth}"; n="${2:-10}"; out="${3:-$here/runs/generated_$mode}"
shift $(( $# > 3 ? 3 : $# )) || true
seed=1; jobs=2; fams=()
while [ $# -gt 0 ]; do
  case "$1" in
    --seed) seed="$2"; shift 2 ;;
    --jobs) jobs="$2"; shift 2 ;;
    *) fams+=("$1"); shift ;;
  esac
done
[ ${#fams[@]} -gt 0 ] || fams=(all)
vigil="${VIGIL:-$here/build/tools/vigil}"
[ -x "$vigil" ] || { echo "eval_generated: $vigil is not there: build first (tools/build.sh)" >&2; exit 2; }
case "$mode" in truth|truth-clean|sgbm|mser|platform) ;; *) echo "eval_generated: mode must be truth, truth-clean, sgbm, mser or platform" >&2; exit 2 ;; esac
# The generator writes the sensors it knows; the MSER system is put on every camera at run time.
gen_sensor="$mode"; run_args=()
if [ "$mode" = mser ]; then gen_sensor=none; run_args=(--sensor mser); fi
mkdir -p "$out/scenarios" "$out/runs"
"$vigil" gen "${fams[@]}" --seed "$seed" --count "$n" --sensor "$gen_sensor" --out "$out/scenarios" > "$out/scenarios.txt"
total=$(wc -l < "$out/scenarios.txt")
echo "eval_generated: $total scenarios ($mode) in $out; running with $jobs jobs" >&2
run_one() {
  local file="$1" vigil="$2" out="$3"; shift 3
  local name; name="$(basename "$file" .yaml)"
  if "$vigil" run "$file" --out "$out/runs/$name" --no-video -q "$@" >"$out/runs/$name.log" 2>&1 &&
     "$vigil" eval "$out/runs/$name" >>"$out/runs/$name.log" 2>&1; then
    echo "done $name" >&2
  else
    echo "FAILED $name (see $out/runs/$name.log)" >&2
  fi
}
export -f run_one
cut -d' ' -f1 "$out/scenarios.txt" | xargs -P "$jobs" -I{} bash -c 'run_one "$@"' _ {} "$vigil" "$out" "${run_args[@]}"
python3 - "$out" <<'PY'
import json, os, sys, collections
out = sys.argv[1]
lines = [l.rstrip('\n') for l in open(os.path.join(out, 'scenarios.txt')) if l.strip()]
fam = collections.OrderedDict()
kinds = collections.OrderedDict()
total = dict(truth=0, reported=0, matched=0)
failures, details, stalled = [], [], []
def add(d, k, e):
    s = d.setdefault(k, dict(scenarios=0, exact=0, truth=0, reported=0, matched=0))
    for x in ('truth', 'reported', 'matched'): s[x] += e[x]
    return s
for l in lines:
    path, summary = l.split('  ', 1)
    name = os.path.basename(path)[:-5]
    family = name.rsplit('_', 2)[0]
    ev_path = os.path.join(out, 'runs', name, 'eval.json')
    if not os.path.exists(ev_path):
        failures.append(name); continue
    # Every generated script ends with `leave`: a person who never left got stuck (a generator
    # fault, not the rules'): counted apart.
    appeared, left = set(), set()
    for gl in open(os.path.join(out, 'runs', name, 'ground_truth.jsonl')):
        if '"action"' not in gl: continue
        a = json.loads(gl)
        (appeared if a['action'] == 'appear' else left if a['action'] == 'leave' else set()).add(a['person'])
    if appeared - left:
        stalled.append('%s (%s)' % (name, ','.join(sorted(appeared - left))))
    ev = json.load(open(ev_path)).get('events')
    if ev is None:
        ev = dict(truth=0, reported=0, matched=0, per_kind={}, missed=[], false_reports=[])
    s = add(fam, family, ev)
    s['scenarios'] += 1
    exact = ev['truth'] == ev['matched'] == ev['reported']
    s['exact'] += exact
    for k, ke in ev.get('per_kind', {}).items(): add(kinds, k, ke)
    for x in ('truth', 'reported', 'matched'): total[x] += ev[x]
    if not exact:
        details.append('%s: missed %s, false %s  (%s)' % (name, [m['kind'] for m in ev['missed']],
                       [f['kind'] for f in ev['false_reports']], summary))
def pr(s):
    p = s['matched'] / s['reported'] if s['reported'] else 1.0
    r = s['matched'] / s['truth'] if s['truth'] else 1.0
    return p, r
rows = ['| family | scenarios | exact | truth | reported | matched | precision | recall |', '|---|---|---|---|---|---|---|---|']
for k, s in fam.items():
    p, r = pr(s)
    rows.append('| %s | %d | %d | %d | %d | %d | %.3f | %.3f |' % (k, s['scenarios'], s['exact'], s['truth'], s['reported'], s['matched'], p, r))
rows += ['', '| kind | truth | reported | matched | precision | recall |', '|---|---|---|---|---|---|']
for k, s in kinds.items():
    p, r = pr(s)
    rows.append('| %s | %d | %d | %d | %.3f | %.3f |' % (k, s['truth'], s['reported'], s['matched'], p, r))
p, r = pr(total)
rows.append('| **all** | %d | %d | %d | %.3f | %.3f |' % (total['truth'], total['reported'], total['matched'], p, r))
text = '\n'.join(rows) + '\n'
if failures: text += '\nruns that failed: ' + ', '.join(failures) + '\n'
if stalled: text += '\nscripts that did not finish (someone never left): ' + ', '.join(stalled) + '\n'
if details: text += '\nnot exact:\n' + '\n'.join('- ' + d for d in details) + '\n'
open(os.path.join(out, 'summary.md'), 'w').write(text)
json.dump(dict(families=fam, kinds=kinds, total=total, failures=failures), open(os.path.join(out, 'summary.json'), 'w'), indent=1)
print(text)
sys.exit(1 if failures else 0)
PY
