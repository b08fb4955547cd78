// rostest: drives the ScanSplitter node with good and bad scans and checks its
// output, its diagnostics, its reconfiguration and that it keeps running.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <mutex>
#include <vector>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <dynamic_reconfigure/DoubleParameter.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <dynamic_reconfigure/StrParameter.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>

#include "tilt_laser_perception/ScanSegments.h"

namespace {

constexpr double kDeg = M_PI / 180.0;

class SplitterNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scan_pub_ = nh_.advertise<sensor_msgs::LaserScan>("scan", 20);
    seg_sub_ = nh_.subscribe("scan_segments", 20, &SplitterNodeTest::onSegments, this);
    diag_sub_ = nh_.subscribe("/diagnostics", 20, &SplitterNodeTest::onDiagnostics, this);
    // The splitter subscribes to scan only once scan_segments has a subscriber.
    ASSERT_TRUE(waitFor([&] { return scan_pub_.getNumSubscribers() > 0; }, 20.0)) << "splitter never subscribed";
  }

  template <typename F>
  bool waitFor(F cond, double timeout) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
    while (ros::ok() && ros::WallTime::now() < end) {
      ros::spinOnce();
      {
        std::lock_guard<std::mutex> l(m_);
        if (cond()) return true;
      }
      ros::WallDuration(0.01).sleep();
    }
    std::lock_guard<std::mutex> l(m_);
    return cond();
  }

  void onSegments(const tilt_laser_perception::ScanSegmentsConstPtr& msg) {
    std::lock_guard<std::mutex> l(m_);
    segments_.push_back(*msg);
  }
  void onDiagnostics(const diagnostic_msgs::DiagnosticArrayConstPtr& msg) {
    std::lock_guard<std::mutex> l(m_);
    for (const auto& s : msg->status)
      if (s.name.find("scan splitter") != std::string::npos) last_status_ = s;
  }
  std::string diagValue(const std::string& key) {
    for (const auto& kv : last_status_.values)
      if (kv.key == key) return kv.value;
    return "";
  }

  /// A 1081-beam scan of a room corner at (3, 1): two walls, one crease.
  sensor_msgs::LaserScan cornerScan(uint32_t seq) {
    sensor_msgs::LaserScan s;
    s.header.seq = seq;
    s.header.stamp = ros::Time(1000 + seq, 0);
    s.header.frame_id = "laser";
    s.angle_min = -135.0 * kDeg;
    s.angle_increment = 0.25 * kDeg;
    s.angle_max = s.angle_min + 1080 * s.angle_increment;
    s.range_min = 0.023;
    s.range_max = 60.0;
    s.ranges.assign(1081, std::numeric_limits<float>::infinity());
    for (int i = 0; i < 1081; ++i) {
      const double a = s.angle_min + i * s.angle_increment;
      const double c = std::cos(a), sn = std::sin(a);
      double r = std::numeric_limits<double>::infinity();
      if (c > 1e-9) {
        const double t = 3.0 / c;  // wall x = 3, y in [-1, 1]
        if (std::abs(t * sn) <= 1.0) r = t;
      }
      if (sn > 1e-9) {
        const double t = 1.0 / sn;  // wall y = 1, x in [0.5, 3]
        const double x = t * c;
        if (x >= 0.5 && x <= 3.0 && t < r) r = t;
      }
      if (std::isfinite(r)) s.ranges[i] = static_cast<float>(r);
    }
    return s;
  }

  ros::NodeHandle nh_;
  ros::Publisher scan_pub_;
  ros::Subscriber seg_sub_, diag_sub_;
  std::mutex m_;
  std::vector<tilt_laser_perception::ScanSegments> segments_;
  diagnostic_msgs::DiagnosticStatus last_status_;
};

TEST_F(SplitterNodeTest, SplitsGoodScansDropsBadOnesAndKeepsRunning) {
  scan_pub_.publish(cornerScan(1));
  ASSERT_TRUE(waitFor([&] { return segments_.size() == 1; }, 10.0));
  {
    const auto& m = segments_[0];
    EXPECT_EQ(m.header.stamp, ros::Time(1001, 0));
    EXPECT_EQ(m.header.frame_id, "laser");
    ASSERT_EQ(m.segments.size(), 2u);
    EXPECT_NEAR(m.segments[0].start.x, 3.0, 1e-4);
    EXPECT_NEAR(m.segments[1].end.y, 1.0, 1e-4);
    int creases = 0;
    for (std::size_t i = 0; i < m.edge_kinds.size(); ++i) {
      if (m.edge_kinds[i] != tilt_laser_perception::ScanSegments::EDGE_CREASE) continue;
      ++creases;
      EXPECT_NEAR(m.edge_angles[i] / kDeg, 90.0, 0.5);
    }
    EXPECT_EQ(creases, 1);
    EXPECT_EQ(m.mode, tilt_laser_perception::ScanSegments::MODE_ADAPTIVE);
    EXPECT_NEAR(m.zeta, 0.01, 1e-6);
  }

  // Malformed scans: each is dropped, none is published, the nodelet goes on.
  std::vector<sensor_msgs::LaserScan> bad(8, cornerScan(2));
  bad[0].ranges.clear();                                // empty
  bad[1].angle_increment = std::nanf("");               // NaN increment
  bad[2].angle_increment = 0.0;                         // zero increment
  bad[3].angle_max = bad[3].angle_min + 500 * bad[3].angle_increment;  // inconsistent with 1081 ranges
  bad[4].time_increment = std::nanf("");                // issue 20: this one aborted the nodelet manager
  bad[5].time_increment = 1.0;                          // 1080 s per scan
  bad[6].time_increment = -1e-5;
  bad[7].ranges.assign(100000, 2.0f);                   // more than ~max_ranges (10000)
  bad[7].angle_increment = (bad[7].angle_max - bad[7].angle_min) / 99999;
  bad[7].time_increment = 0.0;
  for (const auto& b : bad) scan_pub_.publish(b);
  // Odd but valid (issue 15): intensities of another length (left out, the
  // ranges split), angle_max one increment off.
  sensor_msgs::LaserScan odd = cornerScan(3);
  odd.intensities.assign(10, 1.0f);
  odd.angle_max += odd.angle_increment;
  scan_pub_.publish(odd);
  scan_pub_.publish(cornerScan(4));  // and a good one after them
  ASSERT_TRUE(waitFor([&] { return segments_.size() == 3; }, 10.0)) << "splitter stopped after bad scans";
  EXPECT_EQ(segments_[1].header.stamp, ros::Time(1003, 0));
  EXPECT_EQ(segments_[1].segments.size(), 2u);
  EXPECT_EQ(segments_[2].header.stamp, ros::Time(1004, 0));
  ros::WallDuration(0.3).sleep();
  ros::spinOnce();
  EXPECT_EQ(segments_.size(), 3u);

  ASSERT_TRUE(waitFor([&] { return diagValue("scans dropped") == "8"; }, 10.0))
      << "diagnostics never counted 8 dropped scans, last: " << diagValue("scans dropped");
  std::lock_guard<std::mutex> l(m_);
  EXPECT_EQ(diagValue("scans published"), "3");
  EXPECT_EQ(diagValue("intensities left out (other length than ranges)"), "1");
  // by reason, each over the recent window and in total
  EXPECT_EQ(diagValue("dropped: scan: empty scan"), "1 recent, 1 total");
  EXPECT_EQ(diagValue("dropped: scan: angle_increment zero or not finite"), "2 recent, 2 total");
  EXPECT_EQ(diagValue("dropped: scan: time_increment/scan_time not finite, negative or too long"), "3 recent, 3 total");
  EXPECT_EQ(diagValue("dropped: scan: more ranges than max_ranges"), "1 recent, 1 total");
  EXPECT_EQ(diagValue("inputs dropped (total)"), "8");
}

TEST_F(SplitterNodeTest, DynamicReconfigureChangesTheSplit) {
  dynamic_reconfigure::Reconfigure srv;
  dynamic_reconfigure::DoubleParameter d;
  d.name = "d_min";
  d.value = 2.0;  // above the corner's 1.56 m from the chord: one segment
  srv.request.config.doubles.push_back(d);
  dynamic_reconfigure::StrParameter mode;
  mode.name = "mode";
  mode.value = "fixed";
  srv.request.config.strs.push_back(mode);
  ASSERT_TRUE(ros::service::waitForService("scan_splitter/set_parameters", ros::Duration(10.0)));
  ASSERT_TRUE(ros::service::call("scan_splitter/set_parameters", srv));
  const std::size_t before = segments_.size();
  scan_pub_.publish(cornerScan(10));
  ASSERT_TRUE(waitFor([&] { return segments_.size() == before + 1; }, 10.0));
  const auto& m = segments_.back();
  EXPECT_EQ(m.mode, tilt_laser_perception::ScanSegments::MODE_FIXED);
  EXPECT_NEAR(m.d_min, 2.0, 1e-6);
  EXPECT_EQ(m.segments.size(), 1u);

  // An invalid setting (zeta = d_min = 0 in adaptive mode) is refused and the old one kept.
  dynamic_reconfigure::Reconfigure bad;
  dynamic_reconfigure::DoubleParameter z;
  z.name = "d_min";
  z.value = 0.0;
  bad.request.config.doubles.push_back(z);
  z.name = "zeta";
  z.value = 0.0;
  bad.request.config.doubles.push_back(z);
  dynamic_reconfigure::StrParameter am;
  am.name = "mode";
  am.value = "adaptive";
  bad.request.config.strs.push_back(am);
  ASSERT_TRUE(ros::service::call("scan_splitter/set_parameters", bad));
  scan_pub_.publish(cornerScan(11));
  ASSERT_TRUE(waitFor([&] { return segments_.size() == before + 2; }, 10.0));
  EXPECT_NEAR(segments_.back().d_min, 2.0, 1e-6);
  EXPECT_EQ(segments_.back().segments.size(), 1u);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_scan_splitter_node");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
