#!/usr/bin/env bash
# Fails when a ROS-free gtest file (test/test_*.cpp that includes nothing of
# ROS and nothing of PCL) is missing from the one list both builds use
# (cmake/ros_free_tests.cmake), when the list names a file that does not
# exist, or when a build keeps a list of its own again.
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
list="$here/cmake/ros_free_tests.cmake"
status=0
listed=$(grep -o 'test_[A-Za-z0-9_]*\.cpp' "$list" | sort -u)
for f in "$here"/test/test_*.cpp; do
  name=$(basename "$f")
  if grep -qE '#include *[<"](ros/|rosbag/|tilt_laser_perception/ros/|pcl/|tilt_laser_perception/io/)' "$f"; then continue; fi
  if ! grep -qx "$name" <<<"$listed"; then
    echo "check_test_lists: $name is ROS-free but not in cmake/ros_free_tests.cmake (the sanitizer build would never run it)"
    status=1
  fi
done
for name in $listed; do
  [ -f "$here/test/$name" ] || { echo "check_test_lists: cmake/ros_free_tests.cmake names test/$name, which does not exist"; status=1; }
done
for cm in "$here/CMakeLists.txt" "$here/ros_free/CMakeLists.txt"; do
  grep -q 'tlp_add_ros_free_tests' "$cm" || { echo "check_test_lists: $cm does not use the one list (tlp_add_ros_free_tests)"; status=1; }
  for name in $listed; do
    if grep -q "$name" "$cm"; then echo "check_test_lists: $cm names $name itself: a second list"; status=1; fi
  done
done
[ "$status" -eq 0 ] && echo "check_test_lists: $(wc -w <<<"$listed") ROS-free test files, one list, both builds"
exit "$status"
