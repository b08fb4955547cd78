#!/usr/bin/env bash
# The cost of running: the whole pipeline (driver, splitter, grouper in one
# nodelet manager) on the emulated head at the sensor's 40 Hz with the grouper
# on. Measures the nodelet manager's CPU time over a window after a warm-up and
# its resident memory, and prints them (the emulator, robot_state_publisher and
# the neck relay are separate processes: printed apart, not counted).
# usage: bench_pipeline.sh [SECONDS=30] [WARMUP=10]
# Goals (issue 6): under 10 % of one core, under 150 MB resident.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
window="${1:-30}"; warmup="${2:-10}"
export PATH="/usr/bin:$PATH"
ws="${TLP_WS:-$here/build_ws}"
set +u; source "$ws/install/setup.bash"; set -u
export ROS_HOME="${ROS_HOME:-$ws/ros_home}"; mkdir -p "$ROS_HOME"
port=$(( 13000 + RANDOM % 1000 ))
export ROS_MASTER_URI="http://localhost:$port"
roslaunch -p "$port" tilt_laser_perception sim.launch port:=$(( port + 1000 )) \
  servo_link:=/tmp/tlp_bench_servo_$port >/tmp/tlp_bench_$port.log 2>&1 &
launch=$!
trap 'kill -INT $launch 2>/dev/null; wait $launch 2>/dev/null || true' EXIT
sleep "$warmup"
pid_of() { pgrep -f "$1" | while read -r p; do [ "$(ps -o ppid= -p "$p" | tr -d ' ')" = "$launch" ] && echo "$p"; done | head -1 || true; }
manager=$(pid_of "nodelet manager")
[ -n "$manager" ] || { echo "no nodelet manager running; see /tmp/tlp_bench_$port.log"; exit 1; }
tick=$(getconf CLK_TCK)
cpu() { awk '{print $14 + $15}' "/proc/$1/stat"; }
declare -A names=([manager]="$manager" [emulator]="$(pid_of tilt_laser_sim)" [rsp]="$(pid_of robot_state_publisher)" [neck]="$(pid_of neck_joint_states)")
declare -A c0
for k in "${!names[@]}"; do [ -n "${names[$k]}" ] && c0[$k]=$(cpu "${names[$k]}"); done
t0=$(date +%s.%N)
peak=0
end=$(( $(date +%s) + window ))
while [ "$(date +%s)" -lt "$end" ]; do
  rss=$(awk '/VmRSS/ {print $2}' "/proc/$manager/status")
  [ "$rss" -gt "$peak" ] && peak=$rss
  sleep 1
done
t1=$(date +%s.%N)
sweeps=$(timeout 5 rostopic echo -n4 /diagnostics 2>/dev/null | grep -A1 '"sweeps published"' | awk -F'"' '/value/ {print $2}' | head -1 || true)
echo "pipeline on the emulated head (stairs scene, 40 Hz scans, 1081 beams, grouper on), ${window} s after ${warmup} s warm-up:"
for k in manager emulator rsp neck; do
  p="${names[$k]}"; [ -n "$p" ] || continue
  pct=$(awk -v a="${c0[$k]}" -v b="$(cpu "$p")" -v t0="$t0" -v t1="$t1" -v hz="$tick" 'BEGIN {printf "%.1f", 100 * (b - a) / hz / (t1 - t0)}')
  r=$(awk '/VmRSS/ {printf "%.1f", $2 / 1024}' "/proc/$p/status")
  case $k in
    manager) label="nodelet manager (driver, splitter, grouper)";;
    emulator) label="emulator (tilt_laser_sim; not the pipeline)";;
    rsp) label="robot_state_publisher";;
    neck) label="neck_joint_states.py";;
  esac
  printf "  %-46s cpu %5s %% of one core, resident %6s MB\n" "$label" "$pct" "$r"
  [ "$k" = manager ] && mpct=$pct
done
echo "  sweeps published so far: ${sweeps:-?}"
printf "cpu_percent=%s rss_peak_mb=%.1f (goals: < 10 %%, < 150 MB)\n" "$mpct" "$(awk -v p="$peak" 'BEGIN {print p / 1024}')"
