#!/usr/bin/env bash
# The main job: sets up (Debian packages), builds, repeats the paper's Figure 3
# experiment on simulated UTM-30LX scans, splits the recording the package ships,
# and leaves results/: figure3.csv, split_bag.txt, split.png and summary.txt.
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
{
  echo "tilt_laser_perception main job, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo
  echo "Figure 3 (means per scan over 20 seeds):"
  column -s, -t < "$out/figure3.csv"
  echo
  cat "$out/split_bag.txt"
  echo
  echo "Picture: $out/split.png"
} > "$out/summary.txt"
echo
echo "results in $out: summary.txt, figure3.csv, split_bag.txt, split.png"
