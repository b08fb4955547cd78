#!/usr/bin/env bash
# The cost of running: the whole pipeline (sim.launch: driver, splitter,
# grouper and the neck relay in one nodelet manager, robot_state_publisher) on
# the emulated head at the sensor's 40 Hz with the grouper on. Measures every
# process roslaunch started over a window after a warm-up (CPU time as a share
# of one core, resident memory, voluntary context switches a second) and prints them with the package's total (the
# emulator and ROS's own rosmaster and rosout are printed apart, not counted).
# With a second workspace (an earlier release, built by scripts/build.sh with
# TLP_WS=DIR) both pipelines run at the same time under their own masters, so
# that a noisy machine weighs on both alike, and the ratio is printed.
# With TLP_ROBOT_HZ=N a stand-in for the robot's controller
# (robot_joint_states.py: its 34 joints, the neck among them, N a second from
# a process of its own, not counted) publishes to each pipeline.
# usage: bench_pipeline.sh [SECONDS=30] [WARMUP=10] [BASELINE_WS]
# Goals (issue 18): the package under 5 % of one core, under 100 MB resident.
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
window="${1:-30}"; warmup="${2:-10}"; baseline="${3:-}"
export PATH="/usr/bin:$PATH"
ws="${TLP_WS:-$here/build_ws}"
export ROS_HOME="${ROS_HOME:-$ws/ros_home}"; mkdir -p "$ROS_HOME"
tick=$(getconf CLK_TCK)
pids=()
start() {  # workspace, port: starts sim.launch from that workspace; prints roslaunch's pid
  local w="$1" port="$2"
  ( set +u; source "$w/install/setup.bash"; set -u
    export ROS_MASTER_URI="http://localhost:$port"
    exec roslaunch -p "$port" tilt_laser_perception sim.launch port:=$(( port + 1000 )) \
      servo_link:=/tmp/tlp_bench_servo_$port ) >/tmp/tlp_bench_$port.log 2>&1 &
  echo $!
}
robot() {  # port: the robot's joint states to the pipeline under that master
  ( set +u; source "$ws/install/setup.bash"; set -u
    export ROS_MASTER_URI="http://localhost:$1"
    sleep 3; exec python3 "$here/scripts/bench/robot_joint_states.py" --rate "$TLP_ROBOT_HZ" ) >/tmp/tlp_bench_robot_$1.log 2>&1 &
  echo $!
}
base_port=$(( 13000 + RANDOM % 500 ))
runs=("$ws")
[ -n "$baseline" ] && runs+=("$baseline")
declare -A launch_of
for i in "${!runs[@]}"; do
  launch_of[$i]=$(start "${runs[$i]}" $(( base_port + 2 * i )))
  pids+=("${launch_of[$i]}")
  [ -n "${TLP_ROBOT_HZ:-}" ] && pids+=("$(robot $(( base_port + 2 * i )))")
done
trap 'for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null; done; wait 2>/dev/null || true' EXIT
sleep "$warmup"
children() { ps -o pid= --ppid "$1" | tr -d ' '; }
cpu() { awk '{print $14 + $15}' "/proc/$1/stat" 2>/dev/null || echo 0; }
# voluntary context switches of all its threads: how often it sleeps and is woken
wakes() { cat /proc/"$1"/task/*/status 2>/dev/null | awk '/^voluntary_ctxt_switches/ {s += $2} END {print s + 0}'; }
label() {
  local cmd; cmd=$(tr '\0' ' ' < "/proc/$1/cmdline" 2>/dev/null | cut -c1-200)
  case "$cmd" in
    *tilt_laser_sim*) echo "emulator";;
    *rosmaster*) echo "ros:rosmaster";;
    *rosout*) echo "ros:rosout";;
    *tilt_laser_head*) echo "tilt_laser_head (driver, splitter, grouper, tf)";;
    *"nodelet manager"*) echo "nodelet manager (driver, splitter, grouper)";;
    *"nodelet load"*) echo "nodelet loader ($(echo "$cmd" | awk '{print $3}' | sed 's|.*/||'))";;
    *robot_state_publisher*) echo "robot_state_publisher";;
    *neck_joint_states*) echo "neck_joint_states.py";;
    *) echo "$(basename "$(echo "$cmd" | awk '{print ($1 ~ /python/ ? $2 : $1)}')")";;
  esac
}
declare -A c0 w0 procs
for i in "${!runs[@]}"; do
  procs[$i]=$(children "${launch_of[$i]}" | tr '\n' ' ')
  [ -n "${procs[$i]// /}" ] || { echo "nothing running for ${runs[$i]}; see /tmp/tlp_bench_$(( base_port + 2 * i )).log"; exit 1; }
  for p in ${procs[$i]}; do c0[$p]=$(cpu "$p"); w0[$p]=$(wakes "$p"); done
done
t0=$(date +%s.%N)
sleep "$window"
t1=$(date +%s.%N)
declare -A total_cpu total_rss
for i in "${!runs[@]}"; do
  echo "${runs[$i]}: sim.launch on the emulated head (stairs, 40 Hz scans of 1081 beams, grouper on${TLP_ROBOT_HZ:+, robot joint states at $TLP_ROBOT_HZ Hz}), ${window} s after ${warmup} s:"
  tc=0; tr=0
  for p in ${procs[$i]}; do
    [ -r "/proc/$p/stat" ] || continue
    l=$(label "$p")
    pct=$(awk -v a="${c0[$p]}" -v b="$(cpu "$p")" -v t0="$t0" -v t1="$t1" -v hz="$tick" 'BEGIN {printf "%.2f", 100 * (b - a) / hz / (t1 - t0)}')
    r=$(awk '/VmRSS/ {printf "%.1f", $2 / 1024}' "/proc/$p/status")
    wk=$(awk -v a="${w0[$p]}" -v b="$(wakes "$p")" -v t0="$t0" -v t1="$t1" 'BEGIN {printf "%.0f", (b - a) / (t1 - t0)}')
    case "$l" in
      emulator|ros:*) note=" (not counted)";;
      *) note=""; tc=$(awk -v a="$tc" -v b="$pct" 'BEGIN {print a + b}'); tr=$(awk -v a="$tr" -v b="$r" 'BEGIN {print a + b}');;
    esac
    printf "  %-58s cpu %6s %% of one core, resident %6s MB, woken %5s/s%s\n" "$l" "$pct" "$r" "$wk" "$note"
  done
  total_cpu[$i]=$tc; total_rss[$i]=$tr
  printf "  package total: cpu_percent=%.2f rss_mb=%.1f (goals: < 5 %%, < 100 MB)\n" "$tc" "$tr"
done
if [ -n "$baseline" ]; then
  printf "side by side: this %.2f %% / %.1f MB, baseline %.2f %% / %.1f MB: cpu ratio %.2f, memory ratio %.2f\n" \
    "${total_cpu[0]}" "${total_rss[0]}" "${total_cpu[1]}" "${total_rss[1]}" \
    "$(awk -v a="${total_cpu[0]}" -v b="${total_cpu[1]}" 'BEGIN {print (b > 0 ? a / b : 0)}')" \
    "$(awk -v a="${total_rss[0]}" -v b="${total_rss[1]}" 'BEGIN {print (b > 0 ? a / b : 0)}')"
fi
