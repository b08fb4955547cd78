#!/usr/bin/env bash
# Sets up (Debian packages), builds, and runs every test through colcon/ctest:
# gtests of the ROS-free core and simulator, and the rostests of the nodelets.
# Exits non-zero when any test fails.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bash "$here/scripts/setup.sh"
bash "$here/scripts/build.sh"
export PATH="/usr/bin:$PATH"
ws="${TLP_WS:-$here/build_ws}"
cd "$ws"
rm -rf build/tilt_laser_perception/test_results
# rostest needs a writable ROS_HOME for its logs
export ROS_HOME="${ROS_HOME:-$ws/ros_home}"
colcon test --packages-select tilt_laser_perception --event-handlers console_direct+ --return-code-on-test-failure
colcon test-result --verbose --test-result-base build/tilt_laser_perception
