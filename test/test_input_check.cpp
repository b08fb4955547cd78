// The checks where messages enter (core/input_check.hpp, core::checkScan's
// bounds): each kind of bad field that issue 20 found, and the window counts
// and health verdict the diagnostics are made of.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "tilt_laser_perception/core/input_check.hpp"
#include "tilt_laser_perception/core/joint_hold.hpp"
#include "tilt_laser_perception/core/load_count.hpp"
#include "tilt_laser_perception/core/scan_split.hpp"

using namespace tilt_laser_perception::core;

namespace {
const double kNan = std::numeric_limits<double>::quiet_NaN();

struct Scan {
  std::vector<float> ranges = std::vector<float>(1081, 2.0f);
  ScanView view() const {
    ScanView v;
    v.ranges = ranges.data();
    v.size = ranges.size();
    v.angle_min = -2.356194;
    v.angle_increment = 0.004363323;
    v.angle_max = v.angle_min + (v.size - 1) * v.angle_increment;
    v.range_min = 0.023;
    v.range_max = 60.0;
    v.time_increment = 1.736e-5;  // the UTM-30LX: 25 ms per 1440 steps
    v.scan_time = 0.025;
    return v;
  }
};
}  // namespace

TEST(InputCheck, StampsMustBeSetFiniteAndNearTheClock) {
  const StampLimits l;  // 5 s back, 1 s ahead
  EXPECT_EQ(checkStamp(1000.0, 1000.2, l), nullptr);
  EXPECT_STREQ(checkStamp(0.0, 1000.0, l), "stamp zero (not set)");
  EXPECT_STREQ(checkStamp(kNan, 1000.0, l), "stamp not finite");
  EXPECT_STREQ(checkStamp(-1.0, 1000.0, l), "stamp negative");
  EXPECT_NE(checkStamp(994.0, 1000.0, l), nullptr);   // 6 s old
  EXPECT_EQ(checkStamp(995.5, 1000.0, l), nullptr);
  EXPECT_NE(checkStamp(1001.5, 1000.0, l), nullptr);  // 1.5 s ahead
  EXPECT_EQ(checkStamp(3.0, 0.0, l), nullptr);        // the sim clock has not started: no clock test
  StampLimits off;
  off.max_age = off.max_ahead = 0.0;
  EXPECT_EQ(checkStamp(10.0, 1000.0, off), nullptr);
}

TEST(InputCheck, JointPositionsMustBeFiniteAngles) {
  EXPECT_EQ(checkJointPosition(0.7), nullptr);
  EXPECT_EQ(checkJointPosition(-3.1), nullptr);
  EXPECT_NE(checkJointPosition(kNan), nullptr);
  EXPECT_NE(checkJointPosition(std::numeric_limits<double>::infinity()), nullptr);
  EXPECT_NE(checkJointPosition(7.0), nullptr);
  // A continuous (spinning) joint turns on: 60 rad is ten turns, not absurd.
  EXPECT_EQ(checkJointPosition(61.7, true), nullptr);
  EXPECT_EQ(checkJointPosition(-61.7, true), nullptr);
  EXPECT_NE(checkJointPosition(kNan, true), nullptr);
  EXPECT_NE(checkJointPosition(2e7, true), nullptr);
}

TEST(InputCheck, ScansBeyondTheBoundsOrWithBadTimesAreRefused) {
  Scan s;
  EXPECT_EQ(checkScan(s.view()), ScanError::None);
  ScanView v = s.view();
  v.time_increment = kNan;  // issue 20's crash
  EXPECT_EQ(checkScan(v), ScanError::BadTimeIncrement);
  v.time_increment = -1e-5;
  EXPECT_EQ(checkScan(v), ScanError::BadTimeIncrement);
  v.time_increment = 1.0;  // 1080 s per scan
  EXPECT_EQ(checkScan(v), ScanError::BadTimeIncrement);
  v = s.view();
  v.scan_time = std::numeric_limits<double>::infinity();
  EXPECT_EQ(checkScan(v), ScanError::BadTimeIncrement);
  v = s.view();
  v.time_increment = 0.0;  // not given: fine (one time for the whole line)
  EXPECT_EQ(checkScan(v), ScanError::None);
  // 100,000 ranges: refused before any buffer grows for them.
  Scan big;
  big.ranges.assign(100000, 2.0f);
  v = big.view();
  v.time_increment = 0.0;
  v.angle_increment = 4.7e-3 / 100;
  v.angle_max = v.angle_min + (v.size - 1) * v.angle_increment;
  EXPECT_EQ(checkScan(v), ScanError::TooManyRanges);
  ScanLimits wide;
  wide.max_ranges = 200000;
  EXPECT_EQ(checkScan(v, wide), ScanError::None);
}

TEST(InputCheck, TheSplitterRefusesAHugeScanWithoutGrowing) {
  ScanSplitter sp;
  SplitResult r;
  Scan s;
  ASSERT_EQ(sp.split(s.view(), r), ScanError::None);
  EXPECT_GT(r.segments.size(), 0u);
  Scan big;
  big.ranges.assign(1000000, 2.0f);
  ScanView v = big.view();
  v.time_increment = 0.0;
  v.angle_increment = 1e-6;
  v.angle_max = v.angle_min + (v.size - 1) * v.angle_increment;
  EXPECT_EQ(sp.split(v, r), ScanError::TooManyRanges);
  EXPECT_TRUE(r.segments.empty());
  ASSERT_EQ(sp.split(s.view(), r), ScanError::None);  // and goes on with good ones
  EXPECT_GT(r.segments.size(), 0u);
}

TEST(InputCheck, WindowCountsForgetWhatIsOlderThanTheWindow) {
  WindowCounter c(10.0);
  for (int i = 0; i < 40; ++i) c.add(100.0 + 0.025 * i);  // 40 in one second
  EXPECT_EQ(c.recent(101.0), 40u);
  EXPECT_EQ(c.recent(109.5), 40u);
  EXPECT_EQ(c.recent(111.0), 0u);
  EXPECT_EQ(c.total(), 40u);
  c.add(200.0);
  EXPECT_EQ(c.recent(200.5), 1u);
  EXPECT_EQ(c.recent(50.0), 0u);  // the clock went back (a looping bag): nothing recent
  c.add(50.2);
  EXPECT_EQ(c.recent(50.5), 1u);
  EXPECT_EQ(c.total(), 42u);

  ReasonCounts r(10.0);
  EXPECT_EQ(r.add("scan: empty scan", 10.0), 1u);
  EXPECT_EQ(r.add("scan: empty scan", 11.0), 2u);
  EXPECT_EQ(r.add("joint_states: stamp zero (not set)", 12.0), 1u);
  EXPECT_EQ(r.recent(12.5), 3u);
  EXPECT_EQ(r.recent(21.5), 1u);
  EXPECT_EQ(r.total(), 3u);
  ASSERT_EQ(r.entries(21.5).size(), 2u);
  EXPECT_EQ(r.entries(21.5)[0].recent, 0u);
  EXPECT_EQ(r.entries(21.5)[0].total, 2u);
  EXPECT_EQ(r.add("joint_states: inbox full (the worker fell behind)", 22.0, 400), 400u);  // many at once
  EXPECT_EQ(r.recent(22.5), 400u);  // the one at 12 s is out of the window
  EXPECT_EQ(r.total(), 403u);
}

TEST(InputCheck, HealthTellsThePresent) {
  std::string why;
  FlowState s;
  s.now = 100.0;
  EXPECT_EQ(judgeFlow(s, 5.0, why), Health::Stale);  // nothing yet
  s.first_input = 98.0;
  s.last_input = 99.9;
  EXPECT_EQ(judgeFlow(s, 5.0, why), Health::Ok) << why;  // starting: within the grace
  s.now = 110.0;
  s.last_input = 109.9;
  EXPECT_EQ(judgeFlow(s, 5.0, why), Health::Error) << why;  // scans flow, no planes for 12 s
  s.last_output = 109.0;
  EXPECT_EQ(judgeFlow(s, 5.0, why), Health::Ok) << why;
  s.recent_problems = 2;
  EXPECT_EQ(judgeFlow(s, 5.0, why), Health::Warn) << why;
  s.recent_problems = 0;
  s.now = 120.0;
  EXPECT_EQ(judgeFlow(s, 5.0, why), Health::Stale) << why;  // the laser went silent
}

TEST(InputCheck, ParametersAreValidatedWithTheirNames) {
  EXPECT_EQ(ScanLimits().validate(), "");
  ScanLimits l;
  l.max_ranges = 1;
  EXPECT_NE(ScanLimits(l).validate().find("max_ranges"), std::string::npos);
  l = ScanLimits();
  l.max_duration = kNan;
  EXPECT_NE(l.validate().find("max_scan_duration"), std::string::npos);
}

TEST(JointHold, HoldsWhileNobodyElsePublishesTheJoints) {
  JointHold hold(0.5);
  EXPECT_TRUE(hold.holding(0.0));   // nothing seen yet
  hold.seen(10.0);                  // the robot's joint states
  EXPECT_FALSE(hold.holding(10.2));
  EXPECT_FALSE(hold.holding(10.49));
  EXPECT_TRUE(hold.holding(10.51));  // silent for longer than the timeout: hold again
  hold.seen(11.0);
  EXPECT_FALSE(hold.holding(11.1));
}

// Loads are counted per name in the process; the process's uptime grows.
TEST(LoadCount, CountsEachNameInTheProcess) {
  EXPECT_EQ(countLoad("test/a"), 1);
  EXPECT_EQ(countLoad("test/a"), 2);
  EXPECT_EQ(countLoad("test/b"), 1);
  EXPECT_EQ(countLoad("test/a"), 3);
  const double t0 = processUptime();
  EXPECT_GE(t0, 0.0);
  EXPECT_LT(t0, 3600.0);
  volatile double x = 0.0;
  for (int i = 0; i < 100000; ++i) x = x + std::sqrt(static_cast<double>(i));
  EXPECT_GE(processUptime(), t0);
}
