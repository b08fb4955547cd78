#!/usr/bin/env python3
"""Pictures the height map and the plane outlines of one sweep (evaluate --dump).

usage: plot_heightmap.py PREFIX OUT_PNG [SUMMARY_TXT]
"""
import csv
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main():
    prefix, out = sys.argv[1], sys.argv[2]
    ox, oy, res, w, h = open(prefix + "_heightmap.txt").read().split()
    ox, oy, res, w, h = float(ox), float(oy), float(res), int(w), int(h)
    grid = np.fromfile(prefix + "_heightmap.bin", dtype=np.float32).reshape(h, w)
    planes, verts = {}, {}
    for r in csv.DictReader(open(prefix + "_planes.csv")):
        pid = int(r["id"])
        if r["kind"] == "plane":
            planes[pid] = dict(area=float(r["a"]), n=(float(r["b"]), float(r["c"]), float(r["d"])),
                               c=(float(r["e"]), float(r["f"]), float(r["g"])))
        else:
            verts.setdefault(pid, []).append((float(r["a"]), float(r["b"]), float(r["c"])))

    fig, ax = plt.subplots(figsize=(9, 8))
    extent = [ox, ox + w * res, oy, oy + h * res]
    im = ax.imshow(np.ma.masked_invalid(grid), origin="lower", extent=extent, cmap="viridis", vmin=-0.05, vmax=0.7)
    fig.colorbar(im, ax=ax, label="height [m]")
    lines = []
    for pid, p in sorted(planes.items()):
        vs = verts.get(pid, [])
        if not vs:
            continue
        xs = [v[0] for v in vs] + [vs[0][0]]
        ys = [v[1] for v in vs] + [vs[0][1]]
        horizontal = abs(p["n"][2]) > 0.97
        ax.plot(xs, ys, color="white" if horizontal else "red", lw=1.2)
        cx, cy, cz = p["c"]
        if extent[0] <= cx <= extent[1] and extent[2] <= cy <= extent[3]:
            label = f"{pid}: {cz:.3f} m" if horizontal else f"{pid}"
            ax.text(cx, cy, label, color="white", fontsize=7, ha="center")
        kind = "horizontal" if horizontal else ("vertical" if abs(p["n"][2]) < 0.1 else "sloped")
        lines.append(f"plane {pid:2d}: {kind:10s} area {p['area']:6.2f} m^2, centroid "
                     f"({cx:6.2f}, {cy:6.2f}, {cz:6.3f}) m")
    ax.plot([0], [0], marker="^", color="orange", ms=10)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_xlabel("x [m] (base_footprint, forward)")
    ax.set_ylabel("y [m] (left)")
    ax.set_title("height map of one sweep (white: walkable plane outlines, red: steep planes)")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    if len(sys.argv) > 3:
        with open(sys.argv[3], "w") as f:
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
