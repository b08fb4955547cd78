#!/usr/bin/env python3
"""Turns a recording of another tilting rig into this package's own topics, so
that replay.launch runs the whole pipeline on it:

  /scan          sensor_msgs/LaserScan (frame "laser"), as recorded
  /joint_states  the tilt as head_tilt_joint [rad], sampled at --rate: each
                 scan's angle held from its stamp to the next (a stepping
                 stand has one angle per scan)
  /tf, /tf_static  base_footprint -> head_tilt_base (the axle) ->
                 head_tilt_link (the tilt) -> laser (the arm)
  OUT.urdf       the same chain as a URDF (the grouper takes its tilt chain
                 from robot_description): replay.launch urdf:=OUT.urdf

First for the tilting_lidar_scanner stand (pcg_node/LaserScanAngle on /slice:
a LaserScan and the stand's tilt in degrees; ../shared/data/README.md gives
its geometry: the laser on an arm 0.08 m from the axle, a positive tilt
pitching the beams down about the laser's y axis). Any message with a
LaserScan field and a tilt field works: --scan-field, --tilt-field,
--tilt-unit deg|rad, --tilt-sign.

usage: import_tilt_bag.py IN.bag OUT.bag [--topic /slice] [--axle-height H]
       [--arm D] [--rate HZ] [--scan-field laserScan] [--tilt-field stepAngle]
       [--tilt-unit deg] [--tilt-sign 1] [--urdf OUT.urdf]
Prints what it wrote and the tilt range.
"""
import argparse
import math
import sys

import rosbag
import rospy
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import JointState, LaserScan
from tf2_msgs.msg import TFMessage

URDF = """<?xml version="1.0"?>
<!-- A tilting 2D lidar rig imported by import_tilt_bag.py: the axle at
     {h} m above base_footprint, the laser {arm} m from it on the tilting arm
     (positive tilt pitches the beams down, about y). -->
<robot name="{name}">
  <link name="base_footprint"/>
  <link name="head_tilt_base"/>
  <link name="head_tilt_link"/>
  <link name="laser">
    <visual>
      <geometry><box size="0.05 0.05 0.07"/></geometry>
      <material name="laser_orange"><color rgba="0.95 0.45 0.1 1"/></material>
    </visual>
  </link>
  <joint name="rig_axle_joint" type="fixed">
    <parent link="base_footprint"/>
    <child link="head_tilt_base"/>
    <origin xyz="0 0 {h}" rpy="0 0 0"/>
  </joint>
  <joint name="head_tilt_joint" type="revolute">
    <parent link="head_tilt_base"/>
    <child link="head_tilt_link"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1.6" upper="1.6" effort="1.0" velocity="2.0"/>
  </joint>
  <joint name="laser_arm_joint" type="fixed">
    <parent link="head_tilt_link"/>
    <child link="laser"/>
    <origin xyz="0 0 {arm}" rpy="0 0 0"/>
  </joint>
</robot>
"""


def transform(parent, child, stamp, xyz=(0.0, 0.0, 0.0), pitch=0.0):
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
    t.transform.rotation.y = math.sin(0.5 * pitch)
    t.transform.rotation.w = math.cos(0.5 * pitch)
    return t


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--topic", default="/slice")
    ap.add_argument("--axle-height", type=float, default=1.1075,
                    help="axle above the floor [m] (the stand's point cloud node: 1.1075)")
    ap.add_argument("--arm", type=float, default=0.08, help="laser's distance from the axle [m]")
    ap.add_argument("--rate", type=float, default=100.0, help="joint states per second")
    ap.add_argument("--scan-field", default="laserScan")
    ap.add_argument("--tilt-field", default="stepAngle")
    ap.add_argument("--tilt-unit", choices=["deg", "rad"], default="deg")
    ap.add_argument("--tilt-sign", type=float, default=1.0, help="-1 when a positive tilt pitches up")
    ap.add_argument("--urdf", help="URDF to write (default: OUT with .urdf for .bag)")
    ap.add_argument("--no-lead-in", action="store_true",
                    help="no joint states before the first scan (the first sweep is then lost: it has no reversal before it)")
    a = ap.parse_args(argv)
    if not (a.rate > 0 and a.arm >= 0 and math.isfinite(a.axle_height)):
        ap.error("--rate must be > 0, --arm >= 0, --axle-height finite")
    urdf = a.urdf or (a.out[:-4] if a.out.endswith(".bag") else a.out) + ".urdf"

    scans = []  # (stamp, LaserScan, tilt [rad])
    skipped = 0
    with rosbag.Bag(a.inp) as bag:
        for _, m, _ in bag.read_messages(topics=[a.topic]):
            scan = getattr(m, a.scan_field, None)
            tilt = getattr(m, a.tilt_field, None)
            if scan is None or tilt is None or not math.isfinite(float(tilt)):
                skipped += 1
                continue
            q = float(tilt) * (math.pi / 180.0 if a.tilt_unit == "deg" else 1.0) * a.tilt_sign
            s = LaserScan()  # the recorded type is the bag's own class: copy into sensor_msgs'
            for f in s.__slots__:
                setattr(s, f, getattr(scan, f))
            s.header.frame_id = "laser"
            scans.append((s.header.stamp, s, q))
    if not scans:
        sys.exit("import_tilt_bag: no message with fields '%s' and '%s' on %s in %s" %
                 (a.scan_field, a.tilt_field, a.topic, a.inp))
    scans.sort(key=lambda x: x[0])

    period = rospy.Duration(1.0 / a.rate)
    joints = 0

    def joint(out, t, q):
        nonlocal joints
        js = JointState()
        js.header.seq = joints
        js.header.stamp = t
        js.name = ["head_tilt_joint"]
        js.position = [q]
        out.write("/joint_states", js, t)
        out.write("/tf", TFMessage([transform("head_tilt_base", "head_tilt_link", t, pitch=q)]), t)
        joints += 1

    with rosbag.Bag(a.out, "w") as out:
        t0 = scans[0][0]
        lead = rospy.Duration(0.0 if a.no_lead_in else 0.1)
        statics = TFMessage([transform("base_footprint", "head_tilt_base", t0 - lead, (0.0, 0.0, a.axle_height)),
                             transform("head_tilt_link", "laser", t0 - lead, (0.0, 0.0, a.arm))])
        out.write("/tf_static", statics, t0 - lead)
        if not a.no_lead_in:
            # The assembler begins a sweep at a tilt reversal; a stand that
            # starts its only sweep from rest has none. Joint states only
            # (no scans) in the 0.1 s before the first scan: 0.5 degree back
            # against the direction of travel and forward again, a reversal
            # 0.05 s before the first scan, so that its first sweep is one.
            ahead = next((q for _, _, q in scans if abs(q - scans[0][2]) > 0.01), scans[0][2])
            back = -math.copysign(math.radians(0.5), ahead - scans[0][2])
            n = max(4, int(round(0.1 * a.rate)))
            for k in range(n):
                u = k / float(n)
                joint(out, t0 - lead + rospy.Duration(0.1 * u), scans[0][2] + back * (1.0 - abs(2.0 * u - 1.0)))
        for k, (stamp, scan, q) in enumerate(scans):
            end = scans[k + 1][0] if k + 1 < len(scans) else stamp + rospy.Duration(scan.scan_time or 0.1)
            t = stamp
            while t < end:
                joint(out, t, q)
                t = t + period
            scan.header.seq = k
            # after the joint state of its end is due: as a driver publishes it
            out.write("/scan", scan, stamp + rospy.Duration(len(scan.ranges) * scan.time_increment))
    name = a.inp.rsplit("/", 1)[-1].rsplit(".", 1)[0]
    with open(urdf, "w") as f:
        f.write(URDF.format(h=a.axle_height, arm=a.arm, name="tilt_rig_" + name))
    tilts = [q for _, _, q in scans]
    print("import_tilt_bag: %d scans (%d beams), %d joint states, tilt %.2f..%.2f deg, %.1f s -> %s; URDF %s%s" %
          (len(scans), len(scans[0][1].ranges), joints, math.degrees(min(tilts)), math.degrees(max(tilts)),
           (scans[-1][0] - scans[0][0]).to_sec(), a.out, urdf,
           "; %d messages without the fields skipped" % skipped if skipped else ""))


if __name__ == "__main__":
    main(sys.argv[1:])
