#!/usr/bin/env python3
"""Pictures a height map (one sweep's or the fused one) and the plane outlines of its sweep (evaluate --dump).

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
    meta = open(prefix + "_heightmap.txt").read().split("\n")
    ox, oy, res, w, h = meta[0].split()
    ox, oy, res, w, h = float(ox), float(oy), float(res), int(w), int(h)
    # "robot X Y YAW FRAME WHAT" (older dumps: a standing robot at the origin of base_footprint)
    robot = meta[1].split() if len(meta) > 1 and meta[1].startswith("robot") else ["robot", "0", "0", "0",
                                                                                      "base_footprint", "sweep"]
    rx, ry, ryaw, frame, what = float(robot[1]), float(robot[2]), float(robot[3]), robot[4], robot[5]
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
    ax.plot([rx], [ry], marker="^", color="orange", ms=10)
    ax.annotate("", xy=(rx + 0.4 * np.cos(ryaw), ry + 0.4 * np.sin(ryaw)), xytext=(rx, ry),
                arrowprops=dict(arrowstyle="->", color="orange"))
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_xlabel(f"x [m] ({frame})")
    ax.set_ylabel(f"y [m] ({frame})")
    title = "height map fused over sweeps" if what == "fused" else "height map of one sweep"
    ax.set_title(f"{title} (orange: the robot; white: this sweep's walkable plane outlines, red: steep planes)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    if len(sys.argv) > 3:
        with open(sys.argv[3], "w") as f:
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
