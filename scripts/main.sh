#!/usr/bin/env bash
# The main job: sets up (Debian packages), builds, repeats the paper's Figure 3
# experiment on simulated UTM-30LX scans, splits the recording the package ships,
# evaluates sweeps of the stairs scene (planes, height map) against the truth,
# then starts the emulated head on the stairs scene with the whole pipeline
# (sim.launch), listens to a few sweeps and takes an rviz screenshot under Xvfb.
# Leaves results/: summary.txt, heightmap.png (live height map and plane
# outlines), heightmap_spin.png (a spinning head's), rviz.png, split.png and the CSVs.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bash "$here/scripts/setup.sh"
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
extra=()
for p in python3-matplotlib rviz xvfb; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || extra+=("$p")
done
[ ${#extra[@]} -eq 0 ] || $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${extra[@]}"
bash "$here/scripts/build.sh"
export PATH="/usr/bin:$PATH"
ws="${TLP_WS:-$here/build_ws}"
set +u; source "$ws/install/setup.bash"; set -u
bin="$ws/install/tilt_laser_perception/lib/tilt_laser_perception"
out="$here/results"
mkdir -p "$out"

echo "== Figure 3: fixed d_T = 0.03 m against adaptive zeta = 0.01 (20 noise seeds)"
"$bin/figure3" --seeds 20 --check | tee "$out/figure3.csv"
echo
echo "== Split of the shipped recording (stairs scene, head sweeping 10..60 deg at 1 rad/s)"
"$bin/split_bag" "$here/test/data/stairs.bag" --dump-scan 40 "$out/scan40.csv" | tee "$out/split_bag.txt"
python3 "$here/scripts/dev/plot_results.py" "$out/figure3.csv" "$out/scan40.csv" "$out/split.png"
echo
echo "== Sweeps of the stairs scene (head tilting 10..60 deg at 1 rad/s), judged against the truth"
"$bin/evaluate" --scene stairs --sweeps 5 --dump "$out/stairs" | tee "$out/evaluate.csv"
echo "== The same with one joint angle per scan line (at its stamp) instead of one per beam"
"$bin/evaluate" --scene stairs --sweeps 5 --no-skew | tail -1 | tee "$out/evaluate_no_skew.txt"
echo "== The same with a real rig's errors (--realistic: encoder, backlash, timing, mount, footprint; doc/simulator.md)"
"$bin/evaluate" --scene stairs --sweeps 5 --realistic | tail -1 | tee "$out/evaluate_realistic.txt"
python3 "$here/scripts/dev/plot_heightmap.py" "$out/stairs" "$out/heightmap_evaluate.png"
echo "== Calibration: a recording of a head 1.2 deg, 6 ms and 0.5/-0.4 deg off (with --realistic's other errors but"
echo "   no gear play), calibrate on it, then evaluate with the estimate applied"
"$bin/make_scene_bag" --scene stairs --out "$out/calibration.bag" --duration 8 --realistic --backlash-deg 0 \
  --joint-offset-deg 1.2 --time-offset-ms 6 --mount-error-deg 0.5,-0.4 > /dev/null
"$bin/calibrate" "$out/calibration.bag" --out "$out/calibration.yaml" 2>/dev/null | tee "$out/calibration.txt"
for how in "" "--calibration $out/calibration.yaml" "--errors-known"; do
  echo "evaluate ${how:-(uncorrected)}: $("$bin/evaluate" --scene stairs --sweeps 5 --realistic --backlash-deg 0 \
    --joint-offset-deg 1.2 --time-offset-ms 6 --mount-error-deg 0.5,-0.4 $how | tail -1 |
    grep -o 'correct=[^ ]* .*normal_err_deg=[^ ]* .*heightmap_rmse_m=[^ ]*' | sed 's/ over=.*noise=[^ ]*//; s/ offset_err.*heightmap_rmse/ heightmap_rmse/')"
done | tee -a "$out/calibration.txt"
echo
echo "== A walk: 0.3 m/s towards the stairs from 1.5 m behind them (the gait's bob, sway, yaw and roll), 8 sweeps in the"
echo "   odom frame, every beam at the base's pose at its time; the height map fused over sweeps around the robot"
"$bin/evaluate" --scene stairs --sweeps 8 --walk 0.3 --start -1.5,0 --dump "$out/walk" | tee "$out/evaluate_walk.csv"
echo "== The same walk with every line of a sweep put at the pose of the sweep's end (--no-pose)"
"$bin/evaluate" --scene stairs --sweeps 8 --walk 0.3 --start -1.5,0 --no-pose | tail -1 | tee "$out/evaluate_walk_no_pose.txt"
python3 "$here/scripts/dev/plot_heightmap.py" "$out/walk_fused" "$out/heightmap_walk_fused.png"
python3 "$here/scripts/dev/plot_heightmap.py" "$out/walk" "$out/heightmap_walk_sweep.png"
echo
echo "== A spinning head (config/head_spin.yaml: the spindle 30 deg down, 1 rad/s, a sweep each half turn) on the stairs"
"$bin/evaluate" --scene stairs --sweeps 4 --spin 1.0 --dump "$out/spin" | tee "$out/evaluate_spin.csv"
python3 "$here/scripts/dev/plot_heightmap.py" "$out/spin" "$out/heightmap_spin.png"
echo
# Another rig's real recording (../shared/data, when it is there): imported, then grouped offline.
rig_bag="$here/../shared/data/real/tilting_lidar_scanner/room_240.bag"
if [ -f "$rig_bag" ]; then
  echo "== Another rig's recording: tilting_lidar_scanner room_240 (URG-04LX on a hobby servo), imported and grouped"
  python3 "$here/scripts/import_tilt_bag.py" "$rig_bag" "$out/room_240_tlp.bag" | tee "$out/room_240.txt"
  "$bin/group_bag" "$out/room_240_tlp.bag" --urdf "$out/room_240_tlp.urdf" --floor-z 0.10 --dump "$out/room_240" |
    tee -a "$out/room_240.txt"
  "$bin/calibrate" "$out/room_240_tlp.bag" --urdf "$out/room_240_tlp.urdf" 2>/dev/null | tee -a "$out/room_240.txt"
  python3 "$here/scripts/dev/plot_cloud.py" "$out/room_240_sweep0.pcd" "$out/room_240.png" \
    "room_240 (tilting_lidar_scanner), its first sweep; colours: planes" | tee -a "$out/room_240.txt"
else
  echo "(../shared/data absent: the other rig's recording is skipped)" > "$out/room_240.txt"
fi
echo
echo "== The emulated head on the stairs scene with the whole pipeline (sim.launch): 5 sweeps, rviz"
export ROS_HOME="${ROS_HOME:-$ws/ros_home}"
mkdir -p "$ROS_HOME"
port=$(( 11000 + RANDOM % 1000 ))
export ROS_MASTER_URI="http://localhost:$port"
roslaunch -p "$port" tilt_laser_perception sim.launch port:=$(( port + 1000 )) \
  servo_link:=/tmp/tlp_main_servo_$port >"$out/sim_launch.log" 2>&1 &
launch=$!
trap 'kill -INT $launch 2>/dev/null; wait $launch 2>/dev/null || true' EXIT
# the scene's horizontal faces: floor, four treads, the box's top
live_ok=0
python3 "$here/scripts/live_summary.py" --sweeps 5 --prefix "$out/live" --levels 0,0.15,0.30,0.45,0.60 \
  --timeout 90 || live_ok=$?
bash "$here/scripts/dev/rviz_screenshot.sh" "$out/rviz.png" 15
shot_ok=0
python3 "$here/scripts/dev/check_screenshot.py" "$out/rviz.png" | tee "$out/rviz_check.txt" || shot_ok=$?
kill -INT $launch 2>/dev/null; wait $launch 2>/dev/null || true
trap - EXIT
python3 "$here/scripts/dev/plot_heightmap.py" "$out/live" "$out/heightmap.png"
{
  echo "tilt_laser_perception main job, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo
  echo "== Live: the emulated head on the stairs scene, whole pipeline in one nodelet manager (sim.launch)"
  cat "$out/live_summary.txt"
  echo "rviz screenshot check:"
  sed 's/^/  /' "$out/rviz_check.txt"
  echo
  echo "== Figure 3 (means per scan over 20 seeds):"
  column -s, -t < "$out/figure3.csv"
  echo
  cat "$out/split_bag.txt"
  echo
  echo "== Stairs scene, 5 simulated sweeps judged against the truth (evaluate; per sweep, then means):"
  column -s, -t < <(head -n -1 "$out/evaluate.csv")
  tail -1 "$out/evaluate.csv"
  echo
  echo "With one joint angle per scan line instead of one per beam:"
  cat "$out/evaluate_no_skew.txt"
  echo "With a real rig's errors (--realistic):"
  cat "$out/evaluate_realistic.txt"
  echo
  echo "== Calibration (make_scene_bag with errors, calibrate, evaluate):"
  cat "$out/calibration.txt"
  echo
  echo "== A walk (evaluate --walk 0.3 --start -1.5,0; per sweep, then means; fused_*: the map fused over sweeps):"
  column -s, -t < <(head -n -1 "$out/evaluate_walk.csv")
  tail -1 "$out/evaluate_walk.csv"
  echo "With every line at the pose of the sweep's end (--no-pose):"
  cat "$out/evaluate_walk_no_pose.txt"
  echo
  echo "== A spinning head on the stairs (evaluate --spin 1.0; the means of 4 sweeps):"
  tail -1 "$out/evaluate_spin.csv"
  echo
  echo "== Another rig's recording (import_tilt_bag.py, group_bag):"
  cat "$out/room_240.txt"
  echo
  echo "Pictures:"
  for p in heightmap.png:"the live height map and plane outlines" rviz.png:"rviz on the emulated head" \
           split.png:"Figure 3 and a split scan" heightmap_evaluate.png:"the height map of evaluated sweeps" \
           room_240.png:"another rig's recording (room_240)" heightmap_walk_fused.png:"a walk: the fused map" \
           heightmap_walk_sweep.png:"a walk: the last sweep's own map" heightmap_spin.png:"a spinning head's map"; do
    if [ -s "$out/${p%%:*}" ]; then echo "  $out/${p%%:*}: ${p#*:}"; fi
  done
} > "$out/summary.txt"
echo
cat "$out/summary.txt"
echo
echo "results in $out: summary.txt and the pictures it lists"
[ "$live_ok" -eq 0 ] || { echo "the live planes do not match the scene (see above)"; exit 1; }
[ "$shot_ok" -eq 0 ] || { echo "the rviz screenshot misses a display (see above)"; exit 1; }
