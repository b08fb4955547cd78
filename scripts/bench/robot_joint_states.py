#!/usr/bin/env python3
"""A stand-in for HRP-4's controller: the robot's joint states (its 34 joints,
the neck among them, at a fixed pose) on /joint_states from a process of its
own, at --rate Hz (default 1000). For bench_pipeline.sh (TLP_ROBOT_HZ) and
for trying the head with the robot's neck given.

usage: robot_joint_states.py [--rate HZ] [--seconds S]
"""
import argparse
import time

import rospy
from sensor_msgs.msg import JointState

# HRP-4's joints (legs, chest, neck, arms), as its controller names them.
JOINTS = (["R_HIP_Y", "R_HIP_R", "R_HIP_P", "R_KNEE_P", "R_ANKLE_P", "R_ANKLE_R",
           "L_HIP_Y", "L_HIP_R", "L_HIP_P", "L_KNEE_P", "L_ANKLE_P", "L_ANKLE_R",
           "CHEST_P", "CHEST_Y", "NECK_Y", "NECK_P"]
          + [side + j for side in ("R_", "L_") for j in ("SHOULDER_P", "SHOULDER_R", "SHOULDER_Y", "ELBOW_P",
                                                         "WRIST_Y", "WRIST_P", "WRIST_R", "HAND_J0", "HAND_J1")])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--seconds", type=float, default=0.0, help="0: until stopped")
    a = ap.parse_args()
    rospy.init_node("robot_joint_states", disable_signals=True)
    pub = rospy.Publisher("joint_states", JointState, queue_size=10)
    m = JointState()
    m.name = JOINTS
    m.position = [0.0] * len(JOINTS)
    m.position[JOINTS.index("NECK_P")] = 0.1
    period = 1.0 / a.rate
    t_end = time.monotonic() + a.seconds if a.seconds > 0 else float("inf")
    nxt = time.monotonic()
    try:
        while not rospy.is_shutdown() and time.monotonic() < t_end:
            m.header.stamp = rospy.Time.now()
            pub.publish(m)
            nxt += period
            time.sleep(max(0.0, nxt - time.monotonic()))
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
