#!/usr/bin/env bash
# Runs one libFuzzer target (or all) for a bounded time: tools/fuzz.sh TARGET SECONDS
#   TARGET: scenario map_yaml map_image stage_world floorplan stereo_calibration patrol_graph
#           event_string dds_messages, or "all" (SECONDS each); --list names them.
# Installs clang if missing, builds build-fuzz/ (clang, AddressSanitizer, UndefinedBehaviorSanitizer,
# coverage), starts from the seeds (fuzz/corpus/TARGET, fuzz/regressions/TARGET and the shipped
# files of that kind) and keeps the grown corpus in build-fuzz/corpus/TARGET between runs. Prints
# the executions, the coverage and the findings; exits 1 when something was found (the input is
# in build-fuzz/findings/TARGET/: fix the bug, then add the input to fuzz/regressions/TARGET/,
# which the test suite replays). docs/RELIABILITY.md.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
targets=(scenario map_yaml map_image stage_world floorplan stereo_calibration patrol_graph event_string dds_messages)
if [ "${1:-}" = "--list" ]; then printf '%s\n' "${targets[@]}"; exit 0; fi
if [ $# -ne 2 ]; then
  echo "usage: tools/fuzz.sh TARGET SECONDS   (TARGET: ${targets[*]} or all; --list)" >&2
  exit 2
fi
target="$1"
seconds="$2"
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || [ "$seconds" -lt 1 ]; then
  echo "tools/fuzz.sh: SECONDS must be a whole number of seconds, got '$seconds'" >&2
  exit 2
fi
if [ "$target" = all ]; then
  status=0
  for t in "${targets[@]}"; do bash "$0" "$t" "$seconds" || status=1; done
  exit $status
fi
if ! printf '%s\n' "${targets[@]}" | grep -qx "$target"; then
  echo "tools/fuzz.sh: no target '$target' (targets: ${targets[*]})" >&2
  exit 2
fi

bash "$here/tools/install_deps.sh" >/dev/null
if ! command -v clang++-14 >/dev/null || ! ls /usr/lib/llvm-14/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "[fuzz] installing clang-14 and its runtime (libFuzzer)"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends clang-14 libclang-rt-14-dev >/dev/null
fi

bdir="$here/build-fuzz"
if [ ! -f "$bdir/build.ninja" ]; then
  CC=clang-14 CXX=clang++-14 cmake -S "$here" -B "$bdir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVIGIL_FUZZ=ON \
    -DVIGIL_BUILD_TESTS=OFF -DVIGIL_BUILD_BENCHMARKS=OFF >/dev/null
fi
echo "[fuzz] building fuzz_$target (first time: the libraries too, some minutes)"
cmake --build "$bdir" -j "$(nproc 2>/dev/null || echo 2)" --target "fuzz_$target" >"$bdir/build_$target.log" 2>&1 ||
  { tail -30 "$bdir/build_$target.log"; exit 1; }

# The seeds: committed ones, found ones, and the shipped files of that kind.
corpus="$bdir/corpus/$target"
seeds="$bdir/seeds/$target"
findings="$bdir/findings/$target"
mkdir -p "$corpus" "$findings"
rm -rf "$seeds"
mkdir -p "$seeds"
for d in "$here/fuzz/corpus/$target" "$here/fuzz/regressions/$target"; do
  [ -d "$d" ] && find "$d" -maxdepth 1 -type f -exec cp {} "$seeds/" \;
done
shared="$here/../shared/data/maps"
shipped=()
case "$target" in
  scenario) shipped=("$here"/scenarios/*.yaml) ;;
  map_yaml) shipped=("$here/maps/dis_labs.yaml" "$shared"/*/*.yaml) ;;
  stage_world) shipped=("$shared"/*/*.world) ;;
  floorplan) shipped=("$here"/maps/*.floorplan.yaml) ;;
  patrol_graph) shipped=("$here"/maps/*.graph "$shared"/*/*.graph) ;;
  map_image)  # the entry's first byte picks PGM (even) or PNG (odd)
    for f in "$here"/maps/*.pgm; do { printf '\0'; cat "$f"; } >"$seeds/shipped_$(basename "$f")"; done ;;
esac
for f in "${shipped[@]}"; do [ -f "$f" ] && cp "$f" "$seeds/shipped_$(basename "$f")"; done

log="$bdir/fuzz_$target.log"
echo "[fuzz] fuzz_$target for $seconds s: $(ls "$seeds" | wc -l) seeds, corpus $corpus"
set +e
(cd "$bdir" && "./fuzz/fuzz_$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
  -print_final_stats=1 -artifact_prefix="$findings/" "$corpus" "$seeds") >"$log" 2>&1
rc=$?
set -e
execs="$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)"
cov="$(grep -Eo 'cov: [0-9]+ ft: [0-9]+' "$log" | tail -1)"
corp="$(ls "$corpus" | wc -l)"
found="$(find "$findings" -maxdepth 1 -type f | wc -l)"
echo "[fuzz] $target: ${execs:-0} executions in $seconds s, ${cov:-cov: ?}, corpus $corp inputs, findings $found (exit $rc)"
if [ "$rc" -ne 0 ] || [ "$found" -ne 0 ]; then
  grep -E "ERROR|vigil fuzz finding|SUMMARY|==[0-9]+==|runtime error" "$log" | head -20
  echo "[fuzz] inputs in $findings; the whole log: $log"
  exit 1
fi
