#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test with ctest.
#   tools/test.sh [ctest args]        the suite (Release, build/)
#   tools/test.sh --sanitize [...]    the whole suite under AddressSanitizer and
#                                     UndefinedBehaviorSanitizer (build-asan/), then the tests that
#                                     use threads or DDS under ThreadSanitizer (build-tsan/);
#                                     docs/RELIABILITY.md. Extra args go to both ctest runs.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jobs="$(nproc 2>/dev/null || echo 2)"
if [ "${1:-}" != "--sanitize" ]; then
  bash "$here/tools/build.sh"
  cd "$here/build"
  exec ctest --output-on-failure -j "$jobs" "$@"
fi
shift
bash "$here/tools/install_deps.sh"
# Findings stop the program (no recovery) and fail the test. Leaks are reported at exit.
# Suppressions only for third-party libraries, each with its reason: tools/sanitizers/.
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1"
export LSAN_OPTIONS="suppressions=$here/tools/sanitizers/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$here/tools/sanitizers/ubsan.supp"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$here/tools/sanitizers/tsan.supp"
start=$(date +%s)
cmake -S "$here" -B "$here/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=Release -DVIGIL_SANITIZE=address,undefined \
  -DVIGIL_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$here/build-asan" -j "$jobs"
built=$(date +%s)
echo "[sanitize] address,undefined build: $((built - start)) s"
status=0
(cd "$here/build-asan" && ctest --output-on-failure -j "$jobs" "$@") || status=1
tested=$(date +%s)
echo "[sanitize] address,undefined suite: $((tested - built)) s"
# ThreadSanitizer: the tests with threads (the camera rig's workers) or DDS (Cyclone's threads,
# several processes), and what they run.
tsan_tests=(dds_test dds_process_test team_test events_test fusion_test stereo_camera_test)
cmake -S "$here" -B "$here/build-tsan" -G Ninja -DCMAKE_BUILD_TYPE=Release -DVIGIL_SANITIZE=thread \
  -DVIGIL_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$here/build-tsan" -j "$jobs" --target "${tsan_tests[@]}" vigil vigil_plugin_waypoint_follower \
  vigil_plugin_wander vigil_plugin_navigator vigil_plugin_team
tbuilt=$(date +%s)
echo "[sanitize] thread build: $((tbuilt - tested)) s"
# ctest knows each test by its GoogleTest name; those executables' tests carry the label tsan.
(cd "$here/build-tsan" && ctest --output-on-failure -j "$jobs" -L tsan "$@") || status=1
echo "[sanitize] thread suite: $(( $(date +%s) - tbuilt )) s; total $(( $(date +%s) - start )) s"
exit $status
