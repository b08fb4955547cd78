#!/usr/bin/env bash
# Takes a screenshot of rviz (rviz/tilt_laser.rviz, or CONFIG) showing a running
# pipeline, on a virtual display (Xvfb): no screen needed.
# usage: rviz_screenshot.sh OUT.png [SECONDS_TO_WAIT] [CONFIG]
# Needs a ROS master with the pipeline running (sim.launch, replay.launch ...).
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
out="$1"; wait_s="${2:-12}"; config="${3:-$here/rviz/tilt_laser.rviz}"
disp=":$(( 90 + RANDOM % 100 ))"
Xvfb "$disp" -screen 0 1280x800x24 -nolisten tcp >/dev/null 2>&1 &
xvfb=$!
rviz_pid=""
cleanup() { [ -n "$rviz_pid" ] && kill "$rviz_pid" 2>/dev/null; kill "$xvfb" 2>/dev/null; wait 2>/dev/null || true; }
trap cleanup EXIT
sleep 1
# software OpenGL (llvmpipe); rviz's log goes next to the picture
DISPLAY="$disp" LIBGL_ALWAYS_SOFTWARE=1 rviz -d "$config" >"${out%.png}_rviz.log" 2>&1 &
rviz_pid=$!
sleep "$wait_s"
kill -0 "$rviz_pid" 2>/dev/null || { echo "rviz exited early; see ${out%.png}_rviz.log" >&2; exit 1; }
/usr/bin/python3 -c "
import sys
from PIL import ImageGrab
ImageGrab.grab(xdisplay='$disp').save(sys.argv[1])" "$out"
echo "screenshot: $out"
