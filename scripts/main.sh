#!/usr/bin/env bash
# The main job: sets up (Debian packages), builds, repeats the paper's Figure 3
# experiment on simulated UTM-30LX scans, splits the recording the package ships,
# evaluates sweeps of the stairs scene (planes, height map) against the truth,
# and leaves results/: summary.txt, split.png, heightmap.png and the CSVs.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bash "$here/scripts/setup.sh"
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
dpkg-query -W -f='${Status}' python3-matplotlib 2>/dev/null | grep -q "install ok installed" ||
  $SUDO apt-get install -y -qq --no-install-recommends python3-matplotlib
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
python3 "$here/scripts/plot_results.py" "$out/figure3.csv" "$out/scan40.csv" "$out/split.png"
echo
echo "== Sweeps of the stairs scene (head tilting 10..60 deg at 1 rad/s), judged against the truth"
"$bin/evaluate" --scene stairs --sweeps 5 --dump "$out/stairs" | tee "$out/evaluate.csv"
echo "== The same with one joint angle per scan line (at its stamp) instead of one per beam"
"$bin/evaluate" --scene stairs --sweeps 5 --no-skew | tail -1 | tee "$out/evaluate_no_skew.txt"
python3 "$here/scripts/plot_heightmap.py" "$out/stairs" "$out/heightmap.png" "$out/planes.txt"
{
  echo "tilt_laser_perception main job, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo
  echo "Figure 3 (means per scan over 20 seeds):"
  column -s, -t < "$out/figure3.csv"
  echo
  cat "$out/split_bag.txt"
  echo
  echo "Stairs scene, 5 sweeps (evaluate; per sweep, then means):"
  column -s, -t < <(head -n -1 "$out/evaluate.csv")
  tail -1 "$out/evaluate.csv"
  echo
  echo "With one joint angle per scan line instead of one per beam:"
  cat "$out/evaluate_no_skew.txt"
  echo
  echo "Planes of the last sweep:"
  cat "$out/planes.txt"
  echo
  echo "Pictures: $out/split.png, $out/heightmap.png"
} > "$out/summary.txt"
echo
echo "results in $out: summary.txt, split.png, heightmap.png, figure3.csv, split_bag.txt, evaluate.csv"
