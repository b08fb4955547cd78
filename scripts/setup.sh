#!/usr/bin/env bash
# Installs every Debian bookworm package that building, running and testing
# tilt_laser_perception needs. Idempotent; needs root (or sudo).
set -euo pipefail
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
PKGS=(
  # build tools
  build-essential cmake python3-catkin-pkg catkin
  colcon python3-colcon-core python3-colcon-ros python3-colcon-cmake
  python3-colcon-test-result python3-colcon-output python3-colcon-library-path
  python3-colcon-package-selection python3-colcon-parallel-executor
  python3-colcon-recursive-crawl python3-colcon-metadata python3-colcon-bash
  python3-colcon-pkg-config python3-colcon-defaults
  # ROS 1 (Debian's packages)
  ros-cmake-modules ros-message-generation ros-message-runtime
  python3-genmsg python3-gencpp python3-genpy
  libroscpp-dev libnodeletlib-dev libnodelet-dev libnodeletlib-tools pluginlib-dev
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  libstd-msgs-dev libsensor-msgs-dev libgeometry-msgs-dev libvisualization-msgs-dev libnav-msgs-dev
  libdiagnostic-msgs-dev libdiagnostic-updater-dev libmessage-filters-dev
  librosbag-dev librosbag-storage-dev librostest-dev python3-rostest python3-rosunit
  python3-roslaunch python3-rosmaster rosout rosbash python3-rostopic
  python3-rosnode python3-rosparam python3-rosbag python3-rosgraph
  python3-sensor-msgs python3-std-msgs python3-diagnostic-msgs
  python3-yaml
  ros-std-msgs ros-geometry-msgs ros-sensor-msgs ros-visualization-msgs ros-diagnostic-msgs ros-nav-msgs python3-nav-msgs
  libtf2-msgs-dev ros-tf2-msgs libtf2-dev libtf2-ros-dev libtf2-eigen-dev python3-tf2-ros
  liburdf-dev liburdfdom-dev liburdfdom-headers-dev ros-robot-state-publisher
  # libraries
  libeigen3-dev libyaml-cpp-dev libgtest-dev libbenchmark-dev
  libpcl-dev   # PCD files (segment_cloud) and the comparison with PCL (compare_pcl)
  # hardening: sanitizer builds (gcc) and libFuzzer targets (clang)
  clang libclang-rt-14-dev ninja-build
  # python tests and scripts
  python3-pytest python3-numpy python3-pil python3-rospy
  # rviz (the launch files start it on request; the main job takes a screenshot under Xvfb)
  rviz xvfb
)
export DEBIAN_FRONTEND=noninteractive
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
