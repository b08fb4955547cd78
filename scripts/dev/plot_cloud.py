#!/usr/bin/env python3
"""Plots a labelled cloud (an ascii PCD of x y z label, as group_bag --dump
writes it): side, front and top views, each plane in its own colour, points
in no plane grey.  usage: plot_cloud.py CLOUD.pcd OUT.png [TITLE]"""
import sys

import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt


def read_ascii_pcd(path):
    with open(path) as f:
        header = 0
        for line in f:
            header += 1
            if line.startswith("DATA"):
                if line.split()[1] != "ascii":
                    sys.exit("plot_cloud: %s is not an ascii PCD" % path)
                break
    return np.loadtxt(path, skiprows=header, ndmin=2)


def main(argv):
    if len(argv) < 2:
        sys.exit(__doc__)
    d = read_ascii_pcd(argv[0])
    d = d[np.isfinite(d[:, :3]).all(axis=1)]
    step = max(1, len(d) // 60000)
    d = d[::step]
    labels = d[:, 3].astype(int)
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.5))
    for ax, (i, j, name) in zip(axes, [(0, 2, "side (x, z)"), (1, 2, "front (y, z)"), (0, 1, "top (x, y)")]):
        free = labels == 0
        ax.scatter(d[free, i], d[free, j], s=0.3, c="0.75", linewidths=0)
        ax.scatter(d[~free, i], d[~free, j], s=0.3, c=labels[~free] % 20, cmap="tab20", linewidths=0)
        ax.set_title(name)
        ax.set_aspect("equal")
        ax.grid(True, lw=0.3)
    fig.suptitle(argv[2] if len(argv) > 2 else argv[0])
    fig.tight_layout()
    fig.savefig(argv[1], dpi=90)
    print("plot_cloud: %d points (%d in planes, %d planes) -> %s" %
          (len(d) * step, int((labels > 0).sum()) * step, len(set(labels[labels > 0])), argv[1]))


if __name__ == "__main__":
    main(sys.argv[1:])
