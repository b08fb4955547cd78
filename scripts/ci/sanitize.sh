#!/usr/bin/env bash
# Builds the ROS-free libraries and their gtests (ros_free/CMakeLists.txt) with
# AddressSanitizer + UndefinedBehaviorSanitizer and runs them all, then the
# emulator-driven driver tests (test_drivers: laser and servo threads against
# the emulated UTM-30LX and MX-64) and segmentOrganized's two threads
# (test_core's and test_sim's OrganizedLines) with ThreadSanitizer. Build directories:
# build_asan/, build_tsan/. Exits non-zero on any report or failed test.
# usage: sanitize.sh [asan|tsan|all]
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
what="${1:-all}"
common="-fno-omit-frame-pointer -g -O1"
if [ "$what" = all ] || [ "$what" = asan ]; then
  echo "== AddressSanitizer + UndefinedBehaviorSanitizer: every ROS-free gtest"
  cmake -S "$here/ros_free" -B "$here/build_asan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DTLP_SANITIZED=ON \
    -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined $common" \
    -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
  cmake --build "$here/build_asan" -- -j2
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir "$here/build_asan" --output-on-failure
fi
if [ "$what" = all ] || [ "$what" = tsan ]; then
  echo "== ThreadSanitizer: the driver threads against the emulators"
  cmake -S "$here/ros_free" -B "$here/build_tsan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DTLP_SANITIZED=ON \
    -DCMAKE_CXX_FLAGS="-fsanitize=thread $common" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" >/dev/null
  cmake --build "$here/build_tsan" --target test_drivers test_core test_sim -- -j2
  TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" "$here/build_tsan/test_drivers"
  echo "== ThreadSanitizer: segmentOrganized's second thread (and the grouper's finish in two halves)"
  TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" "$here/build_tsan/test_core" --gtest_filter='OrganizedLines.*'
  TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" "$here/build_tsan/test_sim" --gtest_filter='OrganizedLines.*'
fi
