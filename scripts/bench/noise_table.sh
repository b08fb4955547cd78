#!/usr/bin/env bash
# segment_cloud with the default tolerances against --noise auto (tolerances
# of the cloud's own noise) on range images of the simulator's scenes
# (scene_cloud), a row a scene and grid: Hoover's correct faces at 80 % for
# each noise, summed over the seeds, as "defaults/auto of true".
# usage: noise_table.sh BIN_DIR [SIZES="200 100"] [SIGMAS="0 0.0005 0.001 0.002 0.005 0.01"] [SEEDS="1 2"]
# BIN_DIR holds scene_cloud and segment_cloud (devel/lib/tilt_laser_perception).
# SEGMENT_ARGS: more options for every segment_cloud call (e.g.
# "--line-spacing-deg 0" to group every line).
set -euo pipefail
bin=${1:?usage: noise_table.sh BIN_DIR [SIZES] [SIGMAS] [SEEDS]}
sizes=${2:-200 100}
sigmas=${3:-0 0.0005 0.001 0.002 0.005 0.01}
seeds=${4:-1 2}
scenes=${SCENES:-stairs clutter ramp stairs_turned corridor split_room}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
read -r -a more <<< "${SEGMENT_ARGS:-}"
correct() { "$bin/segment_cloud" "$1" --truth-field label --truth-none 0 --noise "$2" "${more[@]}" 2>/dev/null |
  sed -n 's/.*: \([0-9]*\) planes; .* correct=\([0-9]*\) .*/\2 \1/p'; }
printf '%-14s %5s' scene size
for s in $sigmas; do printf ' %14s' "sigma=$s"; done
printf '\n'
for n in $sizes; do
  for scene in $scenes; do
    printf '%-14s %5d' "$scene" "$n"
    for s in $sigmas; do
      d=0 a=0 t=0
      for k in $seeds; do
        "$bin/scene_cloud" "$tmp/c.pcd" --scene "$scene" --size "$n" --sigma "$s" --seed "$k" > /dev/null
        read -r cd td < <(correct "$tmp/c.pcd" off)
        read -r ca _ < <(correct "$tmp/c.pcd" auto)
        d=$((d + cd)) a=$((a + ca)) t=$((t + td))
      done
      printf ' %14s' "$d/$a of $t"
    done
    printf '\n'
  done
done
