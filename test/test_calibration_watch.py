#!/usr/bin/env python3
"""The SweepGrouper's live calibration check on a head whose joint zero is
1.5 degrees off: within a few windows of 8 sweeps its diagnostic status is a
warning, "calibration drifted", and its "calibration check" value suggests a
joint offset within 0.1 degree of 1.5."""
import re
import threading
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus


class CalibrationWatch(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.seen = []  # (level, message, values) of the grouper's statuses
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diag, queue_size=100)

    def on_diag(self, msg):
        for s in msg.status:
            if "sweep grouper" in s.name:
                with self.lock:
                    self.seen.append((s.level, s.message, {kv.key: kv.value for kv in s.values}))

    def test_warns_and_suggests_the_offset(self):
        deadline = time.monotonic() + 90.0
        found = None
        while time.monotonic() < deadline and found is None:
            time.sleep(0.5)
            with self.lock:
                for level, message, values in self.seen:
                    if "calibration drifted" in message:
                        found = (level, message, values)
                        break
        self.assertIsNotNone(found, "no 'calibration drifted' status; last: %s" % (self.seen[-1:] if self.seen else None))
        level, message, values = found
        self.assertGreaterEqual(level, DiagnosticStatus.WARN)
        check = values.get("calibration check", "")
        m = re.search(r"joint_offset ([+-][0-9.]+) deg", check)
        self.assertIsNotNone(m, check)
        self.assertAlmostEqual(float(m.group(1)), 1.5, delta=0.1)


if __name__ == "__main__":
    rospy.init_node("test_calibration_watch")
    rostest.rosrun("tilt_laser_perception", "calibration_watch", CalibrationWatch)
