#!/usr/bin/env bash
# Sets up (Debian packages), builds, and runs every test: through colcon/ctest
# the gtests of the ROS-free core and simulator, the rostests of the nodelets
# and the python tests (record/replay, screenshot check); then the ROS-free
# gtests under AddressSanitizer + UndefinedBehaviorSanitizer and the driver
# tests under ThreadSanitizer (scripts/ci/sanitize.sh), and each libFuzzer target
# for TLP_FUZZ_SECONDS (default 30) after its kept crash inputs (scripts/ci/fuzz.sh).
# Runs them all; exits non-zero when any fails.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bash "$here/scripts/setup.sh"
bash "$here/scripts/ci/check_test_lists.sh"
bash "$here/scripts/ci/check_report.sh"
bash "$here/scripts/build.sh"
export PATH="/usr/bin:$PATH"
ws="${TLP_WS:-$here/build_ws}"
cd "$ws"
rm -rf build/tilt_laser_perception/test_results
# rostest needs a writable ROS_HOME for its logs
export ROS_HOME="${ROS_HOME:-$ws/ros_home}"
status=0
run_ctest() { colcon test --packages-select tilt_laser_perception --event-handlers console_direct+ \
  --return-code-on-test-failure --ctest-args "$@"; }
# Every test once, but those that time the driver's stamps against the
# emulator: the drift rostests (1 ms at the 99th percentile) and test_head's
# client (0.3 ms rms). They fail when this shared 2-core machine stalls the
# emulator and the driver for milliseconds (2026-12-03: p99 2.8 ms in one CI
# run, 0.1-0.35 ms usually; 2026-12-05: the client's rms 0.313 ms at -1000
# ppm in one CI run), so one that fails runs once more and must pass then.
timed='driver_drift|gtest_test_head'
run_ctest ' -E' "$timed" || status=1
run_ctest ' -R' "$timed" ' --repeat' 'until-pass:2' || status=1
colcon test-result --verbose --test-result-base build/tilt_laser_perception || status=1
bash "$here/scripts/ci/sanitize.sh" all || { echo "sanitizer tests FAILED"; status=1; }
bash "$here/scripts/ci/fuzz.sh" "${TLP_FUZZ_SECONDS:-30}" || { echo "fuzzing FAILED"; status=1; }
[ "$status" -eq 0 ] || python3 "$here/scripts/ci/test_failures.py" build/tilt_laser_perception/test_results || true
[ "$status" -eq 0 ] && echo "all tests passed" || echo "SOME TESTS FAILED"
exit "$status"
