#!/usr/bin/env python3
"""Listens to a running pipeline (sim.launch, hrp4.launch or replay.launch) for
a number of sweeps and writes what a person wants to know about them: the
planes of the last sweep with their size and height, the time per stage (from
the nodelets' diagnostics), and the last height map and plane outlines in the
files that plot_heightmap.py pictures.

usage: live_summary.py --sweeps N --prefix PREFIX [--levels 0,0.15,...]
                       [--timeout S]

With --levels (the heights of the scene's horizontal faces), every horizontal
plane of at least 0.05 m^2 is matched to the nearest level and the script
exits 1 when one is off by more than 1 cm or a level within the map has no
plane.
"""
import argparse
import math
import sys
import threading
import time

import numpy as np
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from tilt_laser_perception.msg import HeightMap, PlanePolygonArray


class Listener:
    def __init__(self):
        self.lock = threading.Lock()
        self.sweeps = []          # PlanePolygonArray per sweep
        self.maps = {}            # stamp -> HeightMap
        self.diag = {}            # status name -> {key: value}
        rospy.Subscriber("planes", PlanePolygonArray, self.on_planes, queue_size=10)
        rospy.Subscriber("height_map", HeightMap, self.on_map, queue_size=10)
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diag, queue_size=10)

    def on_planes(self, msg):
        with self.lock:
            self.sweeps.append(msg)

    def on_map(self, msg):
        with self.lock:
            self.maps[msg.header.stamp.to_nsec()] = msg

    def on_diag(self, msg):
        with self.lock:
            for s in msg.status:
                self.diag[s.name] = {kv.key: kv.value for kv in s.values}


def kind(p):
    nz = abs(p.normal.z)
    return "horizontal" if nz > 0.97 else ("vertical" if nz < 0.1 else "sloped")


def write_dump(prefix, planes, hmap):
    with open(prefix + "_heightmap.txt", "w") as f:
        f.write(f"{hmap.info.origin.position.x:f} {hmap.info.origin.position.y:f} {hmap.info.resolution:f} "
                f"{hmap.info.width} {hmap.info.height}\n")
    np.asarray(hmap.heights, dtype=np.float32).tofile(prefix + "_heightmap.bin")
    with open(prefix + "_planes.csv", "w") as f:
        f.write("kind,id,a,b,c,d,e,f,g\n")
        for p in planes.planes:
            f.write(f"plane,{p.id},{p.area:.4f},{p.normal.x:.4f},{p.normal.y:.4f},{p.normal.z:.4f},"
                    f"{p.centroid.x:.4f},{p.centroid.y:.4f},{p.centroid.z:.4f}\n")
            for v in p.boundary.points:
                f.write(f"vertex,{p.id},{v.x:.4f},{v.y:.4f},{v.z:.4f},,,,\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sweeps", type=int, default=5)
    ap.add_argument("--prefix", required=True)
    ap.add_argument("--levels", default="")
    ap.add_argument("--timeout", type=float, default=60.0)
    args = ap.parse_args(rospy.myargv()[1:])
    rospy.init_node("live_summary", anonymous=True)
    lis = Listener()
    # the first sweep may have begun before anybody listened: take one more
    want = args.sweeps + 1
    t_end = time.monotonic() + args.timeout
    while not rospy.is_shutdown() and time.monotonic() < t_end:
        with lis.lock:
            if len(lis.sweeps) >= want:
                break
        time.sleep(0.1)
    time.sleep(1.5)  # one more diagnostics period
    with lis.lock:
        sweeps = lis.sweeps[1:want]
        diag = dict(lis.diag)
        maps = dict(lis.maps)
    if not sweeps:
        print("no sweep arrived within %.0f s" % args.timeout)
        return 1
    last = sweeps[-1]
    hmap = maps.get(last.header.stamp.to_nsec())
    out = []
    out.append(f"{len(sweeps)} sweeps, {sum(len(s.planes) for s in sweeps) / len(sweeps):.1f} planes per sweep")
    out.append(f"planes of the last sweep (stamp {last.header.stamp.to_sec():.3f}, frame {last.header.frame_id}):")
    for p in sorted(last.planes, key=lambda p: (kind(p), p.centroid.z)):
        tilt = math.degrees(math.acos(min(1.0, abs(p.normal.z))))
        out.append(f"  plane {p.id:2d}: {kind(p):10s} area {p.area:6.2f} m^2, height {p.centroid.z:6.3f} m, "
                   f"centroid ({p.centroid.x:5.2f}, {p.centroid.y:5.2f}), tilt {tilt:4.1f} deg, "
                   f"rms {1000 * p.rms_error:4.1f} mm, {p.segment_count} segments")
    status = 0
    if args.levels:
        levels = [float(v) for v in args.levels.split(",")]
        out.append("horizontal faces against the scene's levels (planes of at least 0.05 m^2):")
        found = {lv: [] for lv in levels}
        for s in sweeps:
            for p in s.planes:
                if kind(p) != "horizontal" or p.area < 0.05:
                    continue
                lv = min(levels, key=lambda v: abs(v - p.centroid.z))
                found[lv].append((p.centroid.z - lv, s.header.stamp.to_sec(), p))
        for lv in levels:
            errs = found[lv]
            if not errs:
                out.append(f"  level {lv:5.3f} m: no plane  FAIL")
                status = 1
                continue
            worst, stamp, p = max(errs, key=lambda e: abs(e[0]))
            ok = abs(worst) <= 0.01
            status |= 0 if ok else 1
            out.append(f"  level {lv:5.3f} m: {len(errs)} planes over {len(sweeps)} sweeps, "
                       f"worst error {1000 * worst:+5.1f} mm  {'ok' if ok else 'FAIL'}")
            if not ok:  # which plane, so that the sweep can be looked at
                tilt = math.degrees(math.acos(min(1.0, abs(p.normal.z))))
                out.append(f"    sweep {stamp:.3f}, plane {p.id}: area {p.area:.2f} m^2, centroid ({p.centroid.x:.2f}, "
                           f"{p.centroid.y:.2f}, {p.centroid.z:.3f}), tilt {tilt:.1f} deg, {p.segment_count} segments")
    out.append("time per stage (the nodelets' diagnostics):")
    for name, keys in (("scan splitter", ("split time mean [us]", "split time max [us]", "scans dropped")),
                       ("sweep grouper", ("grouping as lines came [ms] (last sweep)",
                                          "latency after the last line [ms] (last sweep)", "sweeps published",
                                          "sweeps dropped"))):
        entry = next((v for k, v in diag.items() if k.endswith(name)), None)
        if entry is None:
            out.append(f"  {name}: no diagnostics")
            continue
        out.append(f"  {name}: " + ", ".join(f"{k} {entry.get(k, '?')}" for k in keys))
    if hmap is not None:
        write_dump(args.prefix, last, hmap)
        known = sum(1 for h in hmap.heights if not math.isnan(h))
        out.append(f"height map: {hmap.info.width} x {hmap.info.height} cells of {100 * hmap.info.resolution:.0f} cm, "
                   f"{known} known ({100.0 * known / max(1, len(hmap.heights)):.0f} %)")
    else:
        out.append("height map: none with the last sweep's stamp")
        status = 1
    print("\n".join(out))
    with open(args.prefix + "_summary.txt", "w") as f:
        f.write("\n".join(out) + "\n")
    return status


if __name__ == "__main__":
    sys.exit(main())
