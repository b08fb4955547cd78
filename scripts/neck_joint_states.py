#!/usr/bin/env python3
"""Holds HRP-4's neck joints (config/neck.yaml) at fixed angles on joint_states
while the robot itself does not publish them, so that robot_state_publisher
always has the whole chain from base_footprint to the laser. As soon as
another node publishes fresh values for these joints (the robot's own joint
states), this node falls silent and the robot's values drive tf; when they
stop for longer than ~timeout, it takes over again. Each change is logged.

Parameters (private): joints, fixed_positions, source (topic), timeout [s], rate [Hz].
"""
import threading

import rospy
from sensor_msgs.msg import JointState


def main():
    rospy.init_node("neck_joint_states")
    joints = rospy.get_param("~joints", ["NECK_Y", "NECK_P"])
    fixed = [float(v) for v in rospy.get_param("~fixed_positions", [0.0] * len(joints))]
    if len(fixed) != len(joints):
        rospy.logerr("~fixed_positions has %d values for %d joints: using zeros", len(fixed), len(joints))
        fixed = [0.0] * len(joints)
    source = rospy.get_param("~source", "/joint_states")
    timeout = float(rospy.get_param("~timeout", 0.5))
    rate = float(rospy.get_param("~rate", 50.0))
    me = rospy.get_name()
    lock = threading.Lock()
    last_robot = [None]  # wall time of the last robot message with all our joints

    def on_state(msg):
        if msg._connection_header.get("callerid") == me:
            return
        if all(j in msg.name for j in joints):
            with lock:
                last_robot[0] = rospy.get_time()

    pub = rospy.Publisher("joint_states", JointState, queue_size=10)
    rospy.Subscriber(source, JointState, on_state, queue_size=50)
    holding = None
    r = rospy.Rate(rate)
    while not rospy.is_shutdown():
        now = rospy.get_time()
        with lock:
            robot_fresh = last_robot[0] is not None and now - last_robot[0] < timeout
        if holding is not (not robot_fresh):
            holding = not robot_fresh
            if holding:
                rospy.loginfo("%s: no joint states for %s on %s: holding them at %s rad", me, ", ".join(joints),
                              source, fixed)
            else:
                rospy.loginfo("%s: the robot publishes %s: following it", me, ", ".join(joints))
        if holding:
            msg = JointState()
            msg.header.stamp = rospy.Time.now()
            msg.name = list(joints)
            msg.position = list(fixed)
            pub.publish(msg)
        try:
            r.sleep()
        except rospy.ROSInterruptException:
            break


if __name__ == "__main__":
    main()
