#!/usr/bin/env python3
"""The NeckRelay nodelet (the neck_relay node) holds the neck joints while the robot is silent about
them, falls silent while the robot publishes them, and takes over again when
the robot stops or gives them as NaN or without positions."""
import threading
import time
import unittest

import rospy
import rostest
from sensor_msgs.msg import JointState


class NeckRelay(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.relay = []  # (wall time, positions) of the relay's messages
        rospy.Subscriber("joint_states", JointState, self.on_state, queue_size=100)
        self.pub = rospy.Publisher("joint_states", JointState, queue_size=10)

    def on_state(self, msg):
        if msg._connection_header.get("callerid") == "/neck_joint_states":
            with self.lock:
                self.relay.append((time.monotonic(), dict(zip(msg.name, msg.position))))

    def relay_since(self, t):
        with self.lock:
            return [m for m in self.relay if m[0] >= t]

    def test_holds_then_follows_then_holds(self):
        t0 = time.monotonic()
        while not self.relay_since(t0) and time.monotonic() - t0 < 10:
            time.sleep(0.05)
        time.sleep(1.0)
        held = self.relay_since(t0)
        self.assertGreater(len(held), 20)  # 50 Hz
        self.assertEqual(held[-1][1], {"NECK_Y": 0.0, "NECK_P": 0.25})  # config of the test
        # the robot publishes its neck (and other joints): the relay falls silent
        t1 = time.monotonic()
        while time.monotonic() - t1 < 2.0:
            js = JointState()
            js.header.stamp = rospy.Time.now()
            js.name = ["NECK_Y", "NECK_P", "R_KNEE_P"]
            js.position = [0.3, 0.1, 0.5]
            self.pub.publish(js)
            time.sleep(0.02)
        self.assertEqual(len(self.relay_since(t1 + 0.5)), 0)
        # the robot stops: the relay holds the neck again after ~timeout (0.5 s)
        t2 = time.monotonic()
        time.sleep(1.5)
        back = self.relay_since(t2)
        self.assertGreater(len(back), 20)
        self.assertLess(back[0][0] - t2, 1.0)
        # the robot's neck with NaN positions, or with names but no
        # positions: not given, the relay keeps holding it
        for positions in ([float("nan"), float("nan"), 0.5], []):
            t3 = time.monotonic()
            while time.monotonic() - t3 < 1.5:
                js = JointState()
                js.header.stamp = rospy.Time.now()
                js.name = ["NECK_Y", "NECK_P", "R_KNEE_P"]
                js.position = positions
                self.pub.publish(js)
                time.sleep(0.02)
            kept = self.relay_since(t3 + 0.5)
            self.assertGreater(len(kept), 30, "positions %s" % positions)  # 50 Hz for 1 s
            self.assertEqual(kept[-1][1], {"NECK_Y": 0.0, "NECK_P": 0.25})


if __name__ == "__main__":
    rospy.init_node("test_neck_relay")
    rostest.rosrun("tilt_laser_perception", "neck_relay", NeckRelay)
