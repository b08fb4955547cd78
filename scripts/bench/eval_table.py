#!/usr/bin/env python3
"""One row of evaluate figures: `evaluate ARGS --seed S` for the seeds given,
summed over every sweep of every seed (report.py uses summarize()).

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


def summarize(evaluate, seeds, args):
    """The figures of `evaluate ARGS --seed S` over the seeds, as a dict."""
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
        raise RuntimeError("evaluate printed no sweeps")
    n = len(rows)
    tot = lambda k: sum(float(r[k]) for r in rows)
    mean = lambda k: tot(k) / n
    front = lambda k: 100 * sum(float(r[k]) for r in front_rows) / max(len(front_rows), 1)
    latencies = sorted(float(r["latency_ms"]) for r in rows) if "latency_ms" in rows[0] else [float("nan")]
    return {
        "sweeps": n, "correct": tot("correct"), "true_faces": tot("true_faces"), "lines": mean("lines"),
        "missed": mean("missed"), "noise": mean("noise"), "under": mean("under"),
        "normal_err_deg": mean("normal_err_deg"),  # as evaluate's summary line: the sweeps' means
        "rmse_cm": 100 * mean("heightmap_rmse_m"), "fused_rmse_cm": 100 * mean("fused_rmse_m"),
        "walkable_cm": 100 * mean("walkable_rmse_m"), "fused_walkable_cm": 100 * mean("fused_walkable_rmse_m"),
        "invented_pct": 100 * mean("invented"),
        "overconfident_pct": 100 * mean("fused_overconfident") if "fused_overconfident" in rows[0] else float("nan"),
        # step edges: the sweeps' medians and 95th percentiles, over the sweeps that saw an edge
        "edge_median_cm": 100 * nanmean([float(r.get("step_edge_median_m", "nan")) for r in rows]),
        "edge_p95_cm": 100 * nanmean([float(r.get("step_edge_p95_m", "nan")) for r in rows]),
        # of the step edges in view, the share the map leaves unknown around (not judged above)
        "edge_unknown_pct": 100 * nanmean([float(r.get("step_edge_unknown", "nan")) for r in rows]),
        "step_precision_pct": 100 * mean("steppable_precision"), "step_recall_pct": 100 * mean("steppable_recall"),
        "front": front("front_coverage"), "fused_front": front("fused_front_coverage"),
        "front_observable": front("front_observable"),
        "veil": mean("veil_segments"), "overhanging": mean("overhanging_segments"),
        "latency_ms": latencies[len(latencies) // 2],
    }


def nanmean(values):
    seen = [v for v in values if v == v]
    return sum(seen) / len(seen) if seen else float("nan")


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
    try:
        f = summarize(evaluate, seeds, args)
    except RuntimeError as e:
        sys.exit(str(e))
    print(f"{' '.join(args)} (seeds {','.join(map(str, seeds))}, {f['sweeps']} sweeps): "
          f"correct {f['correct']:.0f}/{f['true_faces']:.0f} = {100 * f['correct'] / max(f['true_faces'], 1):.0f} %, "
          f"missed {f['missed']:.2f}, noise {f['noise']:.2f}, under {f['under']:.2f} a sweep, "
          f"normal error {f['normal_err_deg']:.2f} deg, RMSE {f['rmse_cm']:.2f} / {f['fused_rmse_cm']:.2f} cm, "
          f"front known {f['front']:.0f} / {f['fused_front']:.0f} % "
          f"(points reach {f['front_observable']:.0f} %), "
          f"veil / overhanging segments {f['veil']:.2f} / {f['overhanging']:.2f} a sweep")


if __name__ == "__main__":
    main()
