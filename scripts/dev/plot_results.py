#!/usr/bin/env python3
"""Plots the main job's results: the Figure 3 table and one split scan.

usage: plot_results.py FIGURE3_CSV SCAN_CSV OUT_PNG
"""
import csv
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    fig3, scan_csv, out = sys.argv[1:4]
    rows = list(csv.DictReader(open(fig3)))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(14, 6))

    dists = sorted({float(r["distance_m"]) for r in rows})
    labels = [f"{d:g} m" for d in dists]
    for k, (mode, color) in enumerate((("fixed", "tab:red"), ("adaptive", "tab:blue"))):
        vals = [float(r["spurious_edges"]) for d in dists for r in rows
                if float(r["distance_m"]) == d and r["mode"] == mode]
        xs = [i + (k - 0.5) * 0.38 for i in range(len(dists))]
        ax1.bar(xs, vals, width=0.38, color=color,
                label=f"{mode} (d_T = 0.03 m)" if mode == "fixed" else "adaptive (d_T = max(0.03 m, 0.01 R))")
        for x, v in zip(xs, vals):
            ax1.text(x, v + 0.2, f"{v:.1f}", ha="center", fontsize=8)
    ax1.set_xticks(range(len(dists)))
    ax1.set_xticklabels(labels)
    ax1.set_xlabel("distance to the board (1, 2 m) or wall (10-30 m)")
    ax1.set_ylabel("spurious edge points per scan (mean over seeds)")
    ax1.set_title("Figure 3: fixed vs range-adaptive split threshold")
    ax1.legend()

    pts, segs, edges = [], [], []
    for r in csv.DictReader(open(scan_csv)):
        if r["type"] == "point":
            pts.append((float(r["x0"]), float(r["y0"])))
        elif r["type"] == "segment":
            segs.append((float(r["x0"]), float(r["y0"]), float(r["x1"]), float(r["y1"])))
        else:
            edges.append((r["kind"], float(r["x0"]), float(r["y0"])))
    if pts:
        ax2.scatter([p[0] for p in pts], [p[1] for p in pts], s=2, color="0.6", label="returns")
    for i, (x0, y0, x1, y1) in enumerate(segs):
        ax2.plot([x0, x1], [y0, y1], lw=2.5, color=plt.cm.tab10(i % 10))
    colors = {"jump": "red", "occluded": "orange", "crease": "blue", "boundary": "green"}
    for kind, c in colors.items():
        sel = [(x, y) for k, x, y in edges if k == kind]
        if sel:
            ax2.scatter([p[0] for p in sel], [p[1] for p in sel], s=40, color=c, edgecolor="k", zorder=5,
                        label=f"{kind} edge")
    ax2.scatter([0], [0], marker="^", s=80, color="k", label="sensor")
    ax2.set_aspect("equal")
    ax2.set_xlabel("x [m] (scan frame)")
    ax2.set_ylabel("y [m]")
    ax2.set_title(f"one scan of the shipped recording: {len(segs)} segments, {len(edges)} edge points")
    ax2.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main()
