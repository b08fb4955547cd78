#!/usr/bin/env python3
"""The HeadStatePublisher gives the fixed joints on /tf_static, each joint
state's moving joints on /tf, and the neck at its fixed angles while nobody
gives it: the neck pitch 0.25 rad (the test's config), then the robot's -0.2
while it publishes, then 0.25 again once it stops; with the tilt's joint
states alone (the driver), the held neck at their stamps; and still held
while the robot's neck comes with NaN positions."""
import math
import time
import unittest

import rospy
import rostest
import tf2_ros
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage


def pitch(q):
    # rotation about y of a quaternion that is one
    return 2.0 * math.atan2(q.y, q.w)


class HeadStatePublisher(unittest.TestCase):
    def setUp(self):
        # the publisher up first
        rospy.wait_for_message("/tf", TFMessage, timeout=20.0)
        self.buffer = tf2_ros.Buffer()
        self.listener = tf2_ros.TransformListener(self.buffer)
        self.pub = rospy.Publisher("joint_states", JointState, queue_size=10)
        self.neck_stamps = []  # stamps of the neck pitch's transforms on /tf, as they come
        rospy.Subscriber("/tf", TFMessage, self.on_tf, queue_size=100)

    def on_tf(self, m):
        self.neck_stamps.extend(t.header.stamp.to_nsec() for t in m.transforms if t.child_frame_id == "neck_p_link")

    def neck_pitch(self, timeout=5.0):
        self.buffer.can_transform("neck_y_link", "neck_p_link", rospy.Time(0), rospy.Duration(timeout))
        return pitch(self.buffer.lookup_transform("neck_y_link", "neck_p_link", rospy.Time(0)).transform.rotation)

    def test_holds_follows_holds(self):
        # fixed joints: the laser on the tilt link, 0.05 m forward and 0.06 m up
        ok = self.buffer.can_transform("head_tilt_link", "laser", rospy.Time(0), rospy.Duration(10.0))
        self.assertTrue(ok, self.buffer.all_frames_as_string())
        t = self.buffer.lookup_transform("head_tilt_link", "laser", rospy.Time(0)).transform.translation
        self.assertAlmostEqual(t.x, 0.05, places=6)
        self.assertAlmostEqual(t.z, 0.06, places=6)
        self.assertAlmostEqual(self.neck_pitch(), 0.25, places=4)  # held
        # the robot publishes its neck and the tilt: followed
        end = time.monotonic() + 2.0
        while time.monotonic() < end:
            m = JointState()
            m.header.stamp = rospy.Time.now()
            m.name = ["NECK_Y", "NECK_P", "head_tilt_joint"]
            m.position = [0.0, -0.2, 0.5]
            self.pub.publish(m)
            time.sleep(0.02)
        self.assertAlmostEqual(self.neck_pitch(), -0.2, places=4)
        tilt = self.buffer.lookup_transform("head_tilt_base", "head_tilt_link", rospy.Time(0)).transform.rotation
        self.assertAlmostEqual(pitch(tilt), 0.5, places=4)
        # silent again: back to the fixed angle after the timeout (0.5 s)
        time.sleep(1.5)
        self.assertAlmostEqual(self.neck_pitch(), 0.25, places=4)
        # the tilt alone, as the driver gives it: the held neck goes out with
        # the tilt's transforms, at their stamps (no timer of its own then)
        stamps = []
        end = time.monotonic() + 1.5
        del self.neck_stamps[:]
        while time.monotonic() < end:
            m = JointState()
            m.header.stamp = rospy.Time.now()
            m.name = ["head_tilt_joint"]
            m.position = [0.3]
            self.pub.publish(m)
            stamps.append(m.header.stamp)
            time.sleep(0.005)
        time.sleep(0.1)
        given = set(t.to_nsec() for t in stamps)
        neck = list(self.neck_stamps)
        self.assertTrue(self.buffer.can_transform("base_footprint", "laser", stamps[-40], rospy.Duration(2.0)))
        self.assertAlmostEqual(self.neck_pitch(), 0.25, places=4)
        riders = sum(t in given for t in neck)
        # ~50 a second with the tilt's; the timer's (at the clock's stamps) at most at the phase's edges
        self.assertGreater(len(neck), 30)
        self.assertGreater(riders, 0.8 * len(neck), "%d of %d held neck transforms at a joint state's stamp" % (riders, len(neck)))
        # then silent: the timer holds the neck again, at the clock's stamps
        time.sleep(1.5)
        neck = self.buffer.lookup_transform("neck_y_link", "neck_p_link", rospy.Time(0))
        self.assertGreater(neck.header.stamp, stamps[-1] + rospy.Duration(0.5))
        # the robot's neck with NaN positions (refused) beside a good tilt:
        # not a given neck, so it is still held and the chain stays whole
        stamps = []
        del self.neck_stamps[:]
        end = time.monotonic() + 1.5
        while time.monotonic() < end:
            m = JointState()
            m.header.stamp = rospy.Time.now()
            m.name = ["NECK_Y", "NECK_P", "head_tilt_joint"]
            m.position = [float("nan"), float("nan"), 0.4]
            self.pub.publish(m)
            stamps.append(m.header.stamp)
            time.sleep(0.005)
        # counted as they came during the phase (once it ends, the timer
        # holds the neck again and tf would interpolate across the gap)
        given = set(t.to_nsec() for t in stamps)
        riders = sum(t in given for t in self.neck_stamps)
        self.assertGreater(riders, 30, "%d held neck transforms at the tilt's stamps while the neck's positions are NaN" % riders)
        neck = self.buffer.lookup_transform("neck_y_link", "neck_p_link", rospy.Time(0))
        self.assertAlmostEqual(pitch(neck.transform.rotation), 0.25, places=4)


if __name__ == "__main__":
    rospy.init_node("test_head_state_publisher")
    rostest.rosrun("tilt_laser_perception", "head_state_publisher_test", HeadStatePublisher)
