#!/usr/bin/env bash
# Builds the package with colcon into ./build_ws (RelWithDebInfo, tests enabled).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
export PATH="/usr/bin:$PATH"   # catkin needs Debian's python3
ws="${TLP_WS:-$here/build_ws}"
mkdir -p "$ws/src"
ln -sfn "$here" "$ws/src/tilt_laser_perception"
cd "$ws"
colcon build --packages-select tilt_laser_perception \
  --cmake-args -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCATKIN_ENABLE_TESTING=ON \
  --event-handlers console_cohesion+ "$@"
