#!/usr/bin/env python3
"""Checks an rviz screenshot of rviz/tilt_laser.rviz: every display that must
be seen is seen. Counts, in rviz's 3D view, the pixels of each display's
colours and fails when one falls short:

- planes:     plane polygons (warm and green hues, conversions.cpp planePalette)
- height map: height map cloud (blue hues, conversions.cpp heightColor)
- points:     sweep cloud and scan (teal points, rviz/tilt_laser.rviz)

usage: check_screenshot.py IMAGE.png [--min-planes F] [--min-map F] [--min-points F]
Fractions are of the 3D view's pixels. Prints one line per class; exits 1 when
one is under its minimum.
"""
import argparse
import sys

import numpy as np
from PIL import Image

# the 3D view of rviz/tilt_laser.rviz in its 1280 x 800 window, as fractions
VIEW = (0.29, 0.08, 0.995, 0.96)  # left, top, right, bottom


def classify(rgb):
    """Fractions of planes, height map and point pixels in an H x W x 3 array."""
    c = rgb.astype(np.float32) / 255.0
    mx, mn = c.max(axis=2), c.min(axis=2)
    sat = np.where(mx > 0, (mx - mn) / np.maximum(mx, 1e-6), 0.0)
    r, g, b = c[..., 0], c[..., 1], c[..., 2]
    d = np.maximum(mx - mn, 1e-6)
    hue = np.where(mx == r, (g - b) / d % 6, np.where(mx == g, (b - r) / d + 2, (r - g) / d + 4)) * 60.0
    coloured = (sat > 0.4) & (mx > 0.25)
    blue = (hue >= 180) & (hue <= 250)
    n = float(rgb.shape[0] * rgb.shape[1])
    return {
        "planes": float(np.count_nonzero(coloured & ~blue & ~((hue > 160) & (hue < 180)))) / n,
        "height map": float(np.count_nonzero(coloured & blue)) / n,
        "points": float(np.count_nonzero(coloured & (hue > 160) & (hue < 180))) / n,
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("image")
    ap.add_argument("--min-planes", type=float, default=0.02)
    ap.add_argument("--min-map", type=float, default=0.05)
    ap.add_argument("--min-points", type=float, default=0.002)
    args = ap.parse_args()
    im = np.asarray(Image.open(args.image).convert("RGB"))
    h, w = im.shape[:2]
    l, t, r, b = VIEW
    view = im[int(t * h):int(b * h), int(l * w):int(r * w)]
    frac = classify(view)
    mins = {"planes": args.min_planes, "height map": args.min_map, "points": args.min_points}
    ok = True
    for k in ("planes", "height map", "points"):
        good = frac[k] >= mins[k]
        ok &= good
        print(f"{k:10s}: {100 * frac[k]:6.2f} % of the 3D view (minimum {100 * mins[k]:.2f} %)  "
              f"{'ok' if good else 'MISSING'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
