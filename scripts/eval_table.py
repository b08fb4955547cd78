#!/usr/bin/env python3
"""One row of README's evaluate tables: `evaluate ARGS --seed S` for the seeds
given, summed over every sweep of every seed.

  eval_table.py EVALUATE [--seeds 1,2,3] -- ARGS...

Prints correct / true faces (and the percentage), missed, noise and under a
sweep, the normal error of the correct faces, the height map RMSE of the sweep's own map and of the
fused one, and how much of the 1 m in front of the feet each knows (means
over the sweeps; the front's, as evaluate's summary, over those after 1 m
walked; and how much of it the points reach), and the veil and overhanging
segments a sweep.
"""
import csv
import io
import subprocess
import sys


def main():
    argv = sys.argv[1:]
    if "--" not in argv or not argv[0] or argv[0].startswith("-"):
        sys.exit(__doc__)
    split = argv.index("--")
    evaluate, opts, args = argv[0], argv[1:split], argv[split + 1:]
    seeds = [1, 2, 3]
    if opts[:1] == ["--seeds"] and len(opts) == 2:
        seeds = [int(s) for s in opts[1].split(",")]
    elif opts:
        sys.exit(__doc__)
    rows, front_rows = [], []
    for s in seeds:
        out = subprocess.run([evaluate] + args + ["--seed", str(s)], capture_output=True, text=True, check=True).stdout
        lines = [l for l in out.splitlines() if l and "=" not in l]
        these = list(csv.DictReader(io.StringIO("\n".join(lines))))
        rows += these
        # As evaluate's summary: the front of the feet over the sweeps after 1 m walked (all when it stands).
        walked = any(float(r["travelled_m"]) > 0.0 for r in these)
        front_rows += [r for r in these if not walked or float(r["travelled_m"]) >= 1.0]
    if not rows:
        sys.exit("evaluate printed no sweeps")
    n = len(rows)
    tot = lambda k: sum(float(r[k]) for r in rows)
    mean = lambda k: tot(k) / n
    front = lambda k: 100 * sum(float(r[k]) for r in front_rows) / max(len(front_rows), 1)
    correct, true_faces = tot("correct"), tot("true_faces")
    normal = mean("normal_err_deg")  # as evaluate's summary line: the sweeps' means
    print(f"{' '.join(args)} (seeds {','.join(map(str, seeds))}, {n} sweeps): "
          f"correct {correct:.0f}/{true_faces:.0f} = {100 * correct / max(true_faces, 1):.0f} %, "
          f"missed {mean('missed'):.2f}, noise {mean('noise'):.2f}, under {mean('under'):.2f} a sweep, "
          f"normal error {normal:.2f} deg, RMSE {100 * mean('heightmap_rmse_m'):.2f} / {100 * mean('fused_rmse_m'):.2f} cm, "
          f"front known {front('front_coverage'):.0f} / {front('fused_front_coverage'):.0f} % "
          f"(points reach {front('front_observable'):.0f} %), "
          f"veil / overhanging segments {mean('veil_segments'):.2f} / {mean('overhanging_segments'):.2f} a sweep")


if __name__ == "__main__":
    main()
