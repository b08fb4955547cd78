// The sweep assembler: joint interpolation, reversals, waiting lines, dropped
// lines and sweeps, a walking base; sequence gaps; rigid transforms of a sweep.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include <Eigen/Eigenvalues>

#include "tilt_laser_perception/core/height_map.hpp"
#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/core/sequence.hpp"
#include "tilt_laser_perception/core/sweep.hpp"

using namespace tilt_laser_perception::core;

TEST(JointBuffer, InterpolatesAndRefusesGaps) {
  JointBuffer b(0.05);
  EXPECT_TRUE(b.add(0.00, 0.0));
  EXPECT_TRUE(b.add(0.01, 0.1));
  EXPECT_FALSE(b.add(0.005, 9.0));  // out of order
  EXPECT_TRUE(b.add(0.10, 0.2));    // a 90 ms gap
  double q = 0;
  ASSERT_TRUE(b.at(0.005, q));
  EXPECT_NEAR(q, 0.05, 1e-12);
  EXPECT_FALSE(b.at(0.05, q));  // inside the gap
  EXPECT_FALSE(b.at(0.2, q));   // after the last
  // Many beams at once, one interval at a time: the same as one by one.
  std::vector<double> qs;
  ASSERT_TRUE(b.sample(0.001, 0.0005, 17, qs));
  for (int i = 0; i < 17; ++i) {
    ASSERT_TRUE(b.at(0.001 + i * 0.0005, q));
    EXPECT_NEAR(qs[i], q, 1e-12) << i;
  }
  EXPECT_FALSE(b.sample(0.001, 0.0005, 200, qs));  // reaches into the gap
  // A time increment so small that beam counts overflow an integer (found by
  // fuzz_grouping under UBSan): every beam at the first one's time.
  ASSERT_TRUE(b.sample(0.002, 1e-300, 3, qs));
  for (double v : qs) EXPECT_NEAR(v, 0.02, 1e-12);
}

namespace {
// The simulated clock of drive(), for base pose callbacks that depend on it.
double g_now = 0.0;

// Drives an assembler for `seconds` of recording time: a joint state every
// 5 ms (q_at(t), none where skip_joint(t)), an 11-beam line of a wall 2 m
// away every 25 ms, polling as it goes. Arrival and poll times are
// `wall0 + t` (a bag played again keeps its stamps but not the wall clock).
// Finished sweeps go to `sweeps` (when given); after_poll runs after each poll.
/// drive()'s scan line: 11 beams of a wall 2 m away, one segment over all of them.
LineInput wallLine(double stamp, double time_increment = 0.001) {
  LineInput in;
  in.ranges.assign(11, 2.0f);
  in.angle_min = -0.1;
  in.angle_increment = 0.02;
  in.range_min = 0.1;
  in.range_max = 30;
  in.stamp = stamp;
  in.time_increment = time_increment;
  in.segments = {{0, 10}};
  return in;
}

void drive(SweepAssembler& a, const std::function<double(double)>& q_at, double seconds, double wall0,
           std::vector<SweepResult>* sweeps, const std::function<bool(double)>& skip_joint = nullptr,
           const std::function<void()>& after_poll = nullptr,
           const std::function<bool(double)>& skip_line = nullptr) {
  double next_scan = 0.0;
  for (double t = 0.0; t < seconds; t += 0.005) {
    const double wall = wall0 + t;
    g_now = wall;
    if (!skip_joint || !skip_joint(t)) a.addJoint(t, q_at(t));
    if (t >= next_scan + 0.025) {
      if (!skip_line || !skip_line(next_scan)) a.addLine(wallLine(next_scan), wall);
      next_scan += 0.025;
    }
    SweepResult r;
    while (a.poll(wall, r))
      if (sweeps) sweeps->push_back(std::move(r));
    if (after_poll) after_poll();
  }
}

/// Sweep parameters for the short test sweeps (3 lines make a sweep).
SweepParams shortSweeps() {
  SweepParams p;
  p.min_lines = 3;
  return p;
}

// Triangle tilt: 0.2 -> 0.8 rad in 0.6 s, then back.
double triangle(double t) {
  const double ph = std::fmod(t, 1.2);
  return ph < 0.6 ? 0.2 + ph : 1.4 - ph;
}

/// Every line's middle (drive's lines span 10 ms) lies in its sweep: sweeps never mix.
void expectLinesInTheirSweeps(const std::vector<SweepResult>& sweeps) {
  for (const auto& sw : sweeps)
    for (const auto& l : sw.lines) {
      EXPECT_GE(l.stamp + 0.005, sw.start) << "sweep " << sw.start << ".." << sw.end;
      EXPECT_LE(l.stamp + 0.005, sw.end) << "sweep " << sw.start << ".." << sw.end;
    }
}

std::vector<SweepResult> runTriangle(double max_dropped_fraction, SweepCounters* counters,
                                     SweepAssembler::BasePose base_pose = nullptr) {
  SweepParams p = shortSweeps();
  p.max_dropped_fraction = max_dropped_fraction;
  TiltChain chain;
  chain.base_to_joint.translation() = Eigen::Vector3d(0, 0, 1.4);
  SweepAssembler a(p, chain, std::move(base_pose));
  std::vector<SweepResult> sweeps;
  drive(a, triangle, 3.0, 0.0, &sweeps, [](double t) { return t > 1.5 && t < 1.56; });  // 60 ms without joint states
  *counters = a.counters();
  return sweeps;
}
}  // namespace

TEST(SweepAssembler, CutsSweepsAtReversalsAndDropsLinesWithoutJointStates) {
  SweepCounters c;
  const std::vector<SweepResult> sweeps = runTriangle(0.2, &c);
  // Reversals at 0.6, 1.2, 1.8, 2.4: sweeps 0.6-1.2, 1.2-1.8, 1.8-2.4 (the first, from 0, is no sweep).
  ASSERT_EQ(sweeps.size(), 3u);
  EXPECT_NEAR(sweeps[0].start, 0.6, 0.006);
  EXPECT_NEAR(sweeps[0].end, 1.2, 0.006);
  EXPECT_NEAR(sweeps[2].end, 2.4, 0.006);
  EXPECT_NEAR(static_cast<double>(sweeps[0].lines.size()), 24.0, 1.0);
  // The joint gap (1.5 .. 1.56 s) dropped the lines that needed it: 2 or 3 of them.
  EXPECT_GE(sweeps[1].dropped_lines, 2);
  EXPECT_LE(sweeps[1].dropped_lines, 3);
  EXPECT_GE(c.lines_no_joint, 2u);
  expectLinesInTheirSweeps(sweeps);
}

TEST(SweepAssembler, ALineJustAfterAReversalWaitsToKnowItsSweep) {
  // A tilt that slows into its turns (0.2 .. 0.8 rad, a cosine of period
  // 1.2 s): the joint comes back by the hysteresis (0.005 rad) 35 ms after
  // each extreme, while the line that starts at the extreme is covered by
  // joint states and arrives 25 ms after it. Put in 3D at once it would join
  // the sweep that ends before its middle; it waits for the reversal.
  SweepAssembler a(shortSweeps(), TiltChain());
  std::vector<SweepResult> sweeps;
  drive(a, [](double t) { return 0.5 - 0.3 * std::cos(M_PI * t / 0.6); }, 3.0, 0.0, &sweeps);
  ASSERT_EQ(sweeps.size(), 3u);  // 0.6-1.2, 1.2-1.8, 1.8-2.4
  for (const auto& sw : sweeps) {
    EXPECT_NEAR(sw.end - sw.start, 0.6, 0.006);
    EXPECT_EQ(sw.dropped_lines, 0);
  }
  expectLinesInTheirSweeps(sweeps);
}

TEST(SweepAssembler, WaitsForLateTransformsAndDropsLinesInATfGap) {
  using Status = SweepAssembler::PoseStatus;
  // The head's base is 0.5 m up and its transforms arrive 0.1 s late (within
  // max_wait, 0.3 s): lines wait for them and none is lost.
  const auto late = [](double t, Eigen::Isometry3d& pose) {
    if (t > g_now - 0.1) return Status::Wait;
    pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0, 0, 0.5);
    return Status::Ok;
  };
  SweepCounters c;
  std::vector<SweepResult> sweeps = runTriangle(0.2, &c, late);
  ASSERT_EQ(sweeps.size(), 3u);
  EXPECT_EQ(c.lines_no_pose, 0u);
  EXPECT_EQ(sweeps[0].dropped_lines, 0);
  // ranges of 2 m from a laser 1.9 m up, tilted 0.2..0.8 rad down: the points
  // lie at 1.9 - 2 sin(q) (the chain's own offset is 1.4 m)
  const SweepLine& l = sweeps[0].lines[5];
  EXPECT_NEAR(l.points[5].z(), 1.9 - 2.0 * std::sin(l.tilt[5]), 1e-4);

  // Transforms that never come for 2.0 .. 2.1 s: the lines of that span are dropped, the others wait.
  const auto gap = [&](double t, Eigen::Isometry3d& pose) {
    if (t > 2.0 && t < 2.1) return Status::Missing;
    return late(t, pose);
  };
  sweeps = runTriangle(0.3, &c, gap);
  ASSERT_EQ(sweeps.size(), 3u);
  EXPECT_GE(c.lines_no_pose, 3u);
  EXPECT_LE(c.lines_no_pose, 5u);
  EXPECT_EQ(static_cast<unsigned>(sweeps[2].dropped_lines), c.lines_no_pose);

  // Transforms that never arrive at all: every line waits max_wait, then is dropped, and no sweep is made.
  const auto never = [](double, Eigen::Isometry3d&) { return Status::Wait; };
  sweeps = runTriangle(0.2, &c, never);
  EXPECT_TRUE(sweeps.empty());
  EXPECT_GE(c.lines_no_pose, 100u);
}

TEST(SweepAssembler, SaysWhatItsFirstLineWaitsFor) {
  // The grouper nodelet wakes for a joint state or a transform only when the
  // first waiting line waits for that kind of input (issue 18).
  using Status = SweepAssembler::PoseStatus;
  using Waiting = SweepAssembler::Waiting;
  bool pose_known = true;
  SweepAssembler a(shortSweeps(), TiltChain(), [&](double, Eigen::Isometry3d& pose) {
    if (!pose_known) return Status::Wait;
    pose.setIdentity();
    return Status::Ok;
  });
  drive(a, triangle, 0.9, 0.0, nullptr);  // a sweep began at the reversal at 0.6 s; the joint falls
  EXPECT_EQ(a.waiting(), Waiting::Nothing);
  SweepResult r;
  a.addLine(wallLine(0.9), 0.9);  // its beams reach past the last joint state (0.895 s)
  EXPECT_FALSE(a.poll(0.9, r));
  EXPECT_EQ(a.waiting(), Waiting::Joints);
  pose_known = false;
  for (const double t : {0.9, 0.905, 0.91, 0.915, 0.92}) a.addJoint(t, triangle(t));
  EXPECT_FALSE(a.poll(0.92, r));
  EXPECT_EQ(a.waiting(), Waiting::Pose);
  pose_known = true;
  EXPECT_FALSE(a.poll(0.92, r));
  EXPECT_EQ(a.pending(), 0u);
  EXPECT_EQ(a.waiting(), Waiting::Nothing);
  // The joint turns back by less than the hysteresis: the next joint states may end the sweep.
  a.addJoint(0.925, triangle(0.92) + 0.002);
  EXPECT_FALSE(a.poll(0.925, r));
  EXPECT_EQ(a.waiting(), Waiting::Joints);
}

/// A UTM-30LX scan of 1081 beams over 27 ms, every range 2 m.
static LineInput fullScan() {
  LineInput in;
  in.ranges.assign(1081, 2.0f);
  in.angle_min = -2.356;
  in.angle_increment = 0.004363;
  in.range_max = 30;
  in.time_increment = 0.000025;
  return in;
}

/// The sweep from the reversal at 1.0 s to the one at 2.0 s of a joint
/// turning at 1 rad/s (0.2 -> 1.2 -> 0.2 rad), its lines copies of `in`
/// 30 ms apart, each one segment.
static bool oneSweep(SweepAssembler& a, const LineInput& in, SweepResult& r) {
  const auto q_at = [](double t) { return t < 1.0 ? 0.2 + t : (t < 2.0 ? 2.2 - t : t - 1.8); };
  for (double t = 0.0; t <= 2.3; t += 0.005) a.addJoint(t, q_at(t));
  for (int k = 0; k < 34; ++k) {  // the lines of the sweep, and one past it
    LineInput l = in;
    l.stamp = 1.0 + 0.03 * k + 0.001;
    l.segments = {{0, static_cast<int>(in.ranges.size()) - 1}};
    a.addLine(l, 2.3);
  }
  a.addJoint(2.305, q_at(2.305));
  return a.poll(2.31, r);
}

TEST(SweepAssembler, EveryBeamAtItsOwnTiltExactly) {
  // 1081 beams over 27 ms while the joint turns at 1 rad/s: each point is
  // where the exact rotation at its own time puts it (the assembly turns the
  // rotation on from beam to beam rather than calling cos and sin each time).
  SweepParams p;
  p.min_lines = 1;
  TiltChain chain;
  chain.base_to_joint.translation() = Eigen::Vector3d(0, 0, 1.4);
  chain.joint_to_laser.translation() = Eigen::Vector3d(0.05, 0, 0.06);
  SweepAssembler a(p, chain);
  LineInput in = fullScan();
  for (int i = 0; i < 1081; ++i) in.ranges[i] = 1.0f + 0.002f * i;
  SweepResult r;
  ASSERT_TRUE(oneSweep(a, in, r));
  double worst = 0.0;
  for (const SweepLine& l : r.lines)
    for (int i = 0; i < 1081; ++i) {
      const double q = l.tilt[i];
      const double ang = in.angle_min + i * in.angle_increment, rr = in.ranges[i];
      const Eigen::Vector3d exact =
          chain.laserPose(q) * Eigen::Vector3d(rr * std::cos(ang), rr * std::sin(ang), 0.0);
      worst = std::max(worst, (exact - l.points[i].cast<double>()).norm());
    }
  EXPECT_GT(r.lines.size(), 20u);
  EXPECT_LT(worst, 2e-6);  // float storage of the points: ~1e-7 m
}

TEST(SweepAssembler, ASweepsLastBeamIsTheLatestTimeItsLinesHadPosesFor) {
  // The grouper looks up the robot's pose for the fused map there, not at the
  // reversal after it, which a live run may not have in tf yet.
  SweepAssembler a(shortSweeps(), TiltChain());
  SweepResult r;
  ASSERT_TRUE(oneSweep(a, fullScan(), r));
  EXPECT_NEAR(r.lines.back().stamp, 1.961, 1e-9);  // the last line whose middle is before the reversal at 2 s
  EXPECT_NEAR(lastBeamTime(r), 1.961 + 1080 * 0.000025, 1e-9);
  EXPECT_LT(lastBeamTime(r), r.end);
  r.lines.clear();
  EXPECT_EQ(lastBeamTime(r), r.end);
}

TEST(SweepAssembler, KnowsTheSpanOfEachLinesReturns) {
  // The rear beams of a 270-degree scan often see nothing: the height map
  // does not load those points at all.
  SweepAssembler a(shortSweeps(), TiltChain());
  LineInput in = fullScan();
  in.range_min = 0.1;
  for (int i = 0; i < 120; ++i) in.ranges[i] = std::numeric_limits<float>::quiet_NaN();
  for (int i = 1000; i < 1081; ++i) in.ranges[i] = (i % 2) ? 0.0f : 40.0f;  // under range_min, over range_max
  in.ranges[500] = std::numeric_limits<float>::quiet_NaN();                   // a hole inside stays inside
  SweepResult r;
  ASSERT_TRUE(oneSweep(a, in, r));
  for (const SweepLine& l : r.lines) {
    EXPECT_EQ(l.returns_begin, 120);
    EXPECT_EQ(l.returns_end, 1000);
    EXPECT_TRUE(l.points[119].hasNaN() && l.points[120].allFinite() && l.points[999].allFinite() &&
                l.points[1000].hasNaN());
    EXPECT_EQ(l.returns(), std::make_pair(120, 1000));
  }
  SweepLine elsewhere;  // a line made elsewhere: the whole line
  elsewhere.points.resize(5);
  EXPECT_EQ(elsewhere.returns(), std::make_pair(0, 5));
}

TEST(SweepAssembler, AWalkingBaseMovesEveryBeamToItsOwnTime) {
  // The base walks at 0.3 m/s, turns at 0.25 rad/s and bobs 1 cm at a step
  // of 0.8 s while the joint turns at 1 rad/s: each point is where the
  // base's pose at its own beam's time puts it (within 0.1 mm: the
  // first-order motion in a scan), not where the pose at the line's middle
  // would (3 mm and more at the scan's ends).
  SweepParams p;
  p.min_lines = 1;
  TiltChain chain;
  chain.base_to_joint.translation() = Eigen::Vector3d(0, 0, 1.4);
  chain.joint_to_laser.translation() = Eigen::Vector3d(0.05, 0, 0.06);
  const auto base_at = [](double t) {
    Eigen::Isometry3d b = Eigen::Isometry3d::Identity();
    b.translation() = Eigen::Vector3d(0.3 * t, 0.0, 0.01 * std::sin(2 * M_PI * t / 0.8));
    b.linear() = Eigen::AngleAxisd(0.25 * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return b;
  };
  SweepAssembler a(p, chain, [&](double t, Eigen::Isometry3d& pose) {
    pose = base_at(t);
    return SweepAssembler::PoseStatus::Ok;
  });
  const LineInput in = fullScan();
  SweepResult r;
  ASSERT_TRUE(oneSweep(a, in, r));
  double worst = 0.0, worst_mid = 0.0;
  for (const SweepLine& l : r.lines)
    for (int i = 0; i < 1081; ++i) {
      const double ang = in.angle_min + i * in.angle_increment, t = l.stamp + i * in.time_increment;
      const Eigen::Vector3d beam(2.0 * std::cos(ang), 2.0 * std::sin(ang), 0.0);
      const Eigen::Vector3d exact = base_at(t) * chain.laserPose(l.tilt[i]) * beam;
      const Eigen::Vector3d at_mid = base_at(l.stamp + 540 * in.time_increment) * chain.laserPose(l.tilt[i]) * beam;
      worst = std::max(worst, (exact - l.points[i].cast<double>()).norm());
      worst_mid = std::max(worst_mid, (exact - at_mid).norm());
    }
  EXPECT_GT(r.lines.size(), 20u);
  EXPECT_LT(worst, 1e-4);
  EXPECT_GT(worst_mid, 3e-3);
  // The laser's origin at the middle beam, from the pose there.
  const SweepLine& l = r.lines[10];
  const Eigen::Vector3d o = base_at(l.stamp + 540 * in.time_increment) * chain.laserPose(l.tilt[540]).translation();
  EXPECT_LT((o - l.origin.cast<double>()).norm(), 1e-4);  // the pose there interpolated: the bob's curvature
}

TEST(TransformSweep, MovesPointsSegmentsAndPlanesRigidly) {
  SweepResult s;
  SweepLine line;
  line.points = {{1, 0, 0}, {2, 0, 0}, {3, 0, 0.1f}};
  line.origin = Eigen::Vector3f(0, 0, 1);
  s.lines.push_back(line);
  Segment3 seg;
  ASSERT_TRUE(makeSegment3(line.points, std::vector<float>{1, 2, 3}, 0, 0, 2, seg));
  seg.origin = Eigen::Vector3d(0, 0, 1);
  s.segments.push_back(seg);
  Plane pl;
  pl.fit.normal = Eigen::Vector3d::UnitZ();
  pl.fit.centroid = Eigen::Vector3d(2, 0, 0);
  pl.fit.offset = 0.0;
  pl.boundary = {{1, -1, 0}, {3, -1, 0}, {3, 1, 0}};
  s.planes.push_back(pl);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.5, -1.0, 0.2);
  T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 0.1, 1.0).normalized()).toRotationMatrix();
  SweepResult moved = s;
  transformSweep(moved, T);
  for (int i = 0; i < 3; ++i)
    EXPECT_LT((moved.lines[0].points[i].cast<double>() - T * line.points[i].cast<double>()).norm(), 1e-6);
  EXPECT_LT((moved.segments[0].start - T * seg.start).norm(), 1e-12);
  EXPECT_LT((moved.segments[0].moments.mean() - T * seg.moments.mean()).norm(), 1e-12);
  EXPECT_LT((moved.segments[0].origin - T * seg.origin).norm(), 1e-12);
  // The moved moments fit the moved points as the old ones fit the old.
  Moments3 direct;
  for (const auto& p : line.points) direct.add(T * p.cast<double>());
  EXPECT_LT((moved.segments[0].moments.ss - direct.ss).norm(), 1e-5);
  EXPECT_LT((moved.planes[0].fit.normal - T.linear() * Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_NEAR(moved.planes[0].fit.offset, moved.planes[0].fit.normal.dot(T * Eigen::Vector3d(1, -1, 0)), 1e-12);
  EXPECT_LT((moved.planes[0].boundary[2] - T * Eigen::Vector3d(3, 1, 0)).norm(), 1e-12);
}

TEST(SequenceGaps, CountsMissedMessagesAndRestarts) {
  SequenceGaps g;
  EXPECT_EQ(g.add(10), 0u);  // the first: nothing known before it
  EXPECT_EQ(g.add(11), 0u);
  EXPECT_EQ(g.add(14), 2u);  // 12 and 13 lost
  EXPECT_EQ(g.add(14), 0u);  // a repeat: a restart, no loss
  EXPECT_EQ(g.add(0), 0u);   // a looping bag starts again
  EXPECT_EQ(g.add(3), 2u);
  g.forgetLast();            // unsubscribed for a while
  EXPECT_EQ(g.add(40), 0u);
  EXPECT_EQ(g.add(42), 1u);
  EXPECT_EQ(g.missed(), 5u);
  EXPECT_EQ(g.restarts(), 2u);
}

TEST(SweepAssembler, StartsAgainWhenTheClockGoesBack) {
  // A 3 s recording played twice in a row (rosbag play --loop): the second
  // pass is assembled like the first, not dropped as out of order.
  SweepAssembler a(shortSweeps(), TiltChain());
  std::vector<SweepResult> sweeps;
  drive(a, triangle, 3.0, 0.0, &sweeps);
  drive(a, triangle, 3.0, 3.0, &sweeps);
  EXPECT_EQ(a.counters().time_jumps, 1u);
  EXPECT_EQ(a.counters().lines_out_of_order, 0u);
  ASSERT_EQ(sweeps.size(), 6u);  // 0.6-1.2, 1.2-1.8, 1.8-2.4, twice
  EXPECT_NEAR(sweeps[3].start, 0.6, 0.006);
  EXPECT_EQ(sweeps[3].lines.size(), sweeps[0].lines.size());
}

TEST(SweepAssembler, DropsASweepThatNeverEndsInsteadOfGrowing) {
  // The head stops mid-sweep (the servo's torque went off): no reversal comes.
  // Found by the soak (scripts/bench/soak.py): memory grew by 0.7 MB/s.
  SweepParams p = shortSweeps();
  p.max_lines = 100;
  SweepAssembler a(p, TiltChain());
  std::size_t most = 0;
  // up to 0.8 rad at 0.6 s (a reversal), back down to 0.6 rad at 0.8 s, then still
  drive(a, [](double t) { return t < 0.6 ? 0.2 + t : (t < 0.8 ? 0.8 - (t - 0.6) : 0.6); }, 10.0, 0.0, nullptr, nullptr,
        [&] { most = std::max(most, a.linesInSweep()); });
  EXPECT_LE(most, 100u);
  EXPECT_GE(a.counters().sweeps_dropped, 1u);
}

TEST(SweepAssembler, DropsASweepThatLostTooManyLines) {
  SweepCounters c;
  const std::vector<SweepResult> sweeps = runTriangle(0.05, &c);  // 2 or 3 of 24 lines lost: more than 5 %
  ASSERT_EQ(sweeps.size(), 2u);
  EXPECT_EQ(c.sweeps_dropped, 1u);
  EXPECT_NEAR(sweeps[1].start, 1.8, 0.006);  // the one after it is whole
}

namespace {
/// The clean triangle run's sweeps next to one with `inject` called once at
/// recording time `at` (bad messages among the good ones).
struct InjectedRun {
  std::vector<SweepResult> clean, injected;
  SweepCounters counters;
};
InjectedRun runInjected(double at, const std::function<void(SweepAssembler&)>& inject) {
  InjectedRun r;
  {
    SweepAssembler a(shortSweeps(), TiltChain());
    drive(a, triangle, 3.0, 0.0, &r.clean);
  }
  SweepAssembler a(shortSweeps(), TiltChain());
  bool done = false;
  drive(a, triangle, 3.0, 0.0, &r.injected, nullptr, [&] {
    if (!done && g_now >= at) {
      inject(a);
      done = true;
    }
  });
  r.counters = a.counters();
  return r;
}

void expectSameSweeps(const InjectedRun& r) {
  ASSERT_EQ(r.injected.size(), r.clean.size());
  for (std::size_t i = 0; i < r.clean.size(); ++i) {
    EXPECT_NEAR(r.injected[i].start, r.clean[i].start, 1e-9) << "sweep " << i;
    EXPECT_NEAR(r.injected[i].end, r.clean[i].end, 1e-9) << "sweep " << i;
    EXPECT_EQ(r.injected[i].lines.size(), r.clean[i].lines.size()) << "sweep " << i;
  }
}
}  // namespace

TEST(SweepAssembler, ANanJointStateAfterAStampOfZeroDoesNotStallTheReversals) {
  // Issue 20's stall: {stamp 0, position NaN} reset the tilt tracker and the
  // NaN became its reference: no reversal was found again. Both halves
  // alone, and together, now leave the sweeps as they were.
  const InjectedRun r = runInjected(1.5, [](SweepAssembler& a) {
    a.addJoint(0.0, std::numeric_limits<double>::quiet_NaN());
    a.addJoint(1.5025, std::numeric_limits<double>::quiet_NaN());
    a.addJoint(0.0, 0.3);  // one stamp far back: a bad message, no restart
  });
  expectSameSweeps(r);
  EXPECT_EQ(r.clean.size(), 3u);
  EXPECT_EQ(r.counters.joints_bad, 2u);
  EXPECT_EQ(r.counters.time_jumps, 0u);
  EXPECT_EQ(r.counters.joints_out_of_order, 1u);
}

TEST(SweepAssembler, ALineWithAnAbsurdTimeIncrementIsDroppedAndHoldsNothingUp) {
  // time_increment 1 s (or negative, or NaN): the line would wait for joint
  // states 1000 s ahead and the lines behind it with it (11 real lines were
  // lost); it is malformed at once.
  for (const double ti : {1.0, -0.001, std::numeric_limits<double>::quiet_NaN()}) {
    const InjectedRun r = runInjected(1.3, [ti](SweepAssembler& a) { a.addLine(wallLine(1.2876, ti), g_now); });
    expectSameSweeps(r);
    EXPECT_EQ(r.counters.lines_bad, 1u) << ti;
    EXPECT_EQ(r.counters.lines_no_joint, 0u) << ti;
  }
}

TEST(SweepAssembler, ALineStampedFarBackIsDroppedNotARestart) {
  const InjectedRun r = runInjected(2.0, [](SweepAssembler& a) { a.addLine(wallLine(0.1), g_now); });
  expectSameSweeps(r);
  EXPECT_EQ(r.counters.time_jumps, 0u);
  EXPECT_EQ(r.counters.lines_out_of_order, 1u);
}

TEST(SweepAssembler, ASweepThatAnOutageInterruptedIsDroppedNotPublishedLate) {
  // The laser falls silent for 0.2 s in the middle of the second sweep
  // (1.2-1.8 s) while the joint states go on: its 8 lines that never came
  // are counted as lost (a third of 24, more than 10 %) and the sweep is
  // dropped. Lines of other sweeps are whole; one lost line is no loss.
  SweepAssembler a(shortSweeps(), TiltChain());
  std::vector<SweepResult> sweeps;
  drive(a, triangle, 3.0, 0.0, &sweeps, nullptr, nullptr,
        [](double stamp) { return (stamp > 1.39 && stamp < 1.59) || std::abs(stamp - 2.0) < 0.001; });
  ASSERT_EQ(sweeps.size(), 2u);
  EXPECT_NEAR(sweeps[0].start, 0.6, 0.006);
  EXPECT_NEAR(sweeps[1].start, 1.8, 0.006);  // 1.8-2.4, one line of 24 lost
  EXPECT_EQ(sweeps[0].dropped_lines, 0);
  EXPECT_EQ(sweeps[1].dropped_lines, 1);
  EXPECT_EQ(a.counters().sweeps_dropped, 1u);
}

TEST(SweepAssembler, ParametersAreValidatedWithTheirNames) {
  EXPECT_EQ(SweepParams().validate(), "");
  SweepParams p;
  p.reversal_hysteresis = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(p.validate().find("reversal_hysteresis"), std::string::npos);
  p = SweepParams();
  p.max_wait = -1;
  EXPECT_NE(p.validate().find("max_wait"), std::string::npos);
  p = SweepParams();
  p.max_lines = 5;
  EXPECT_NE(p.validate().find("max_sweep_lines"), std::string::npos);
  p = SweepParams();
  p.scan_limits.max_ranges = 0;
  EXPECT_NE(p.validate().find("max_ranges"), std::string::npos);
}

// A recording of one sweep: the tilt turns once (0.8 -> 0.2 rad in 0.3 s,
// then up to 0.8 rad, where the recording ends). Without a reversal after it
// the sweep stays open; flush() closes it with every line after the turn.
TEST(SweepAssembler, TheInputsEndClosesTheLastSweep) {
  const auto down_then_up = [](double t) { return t < 0.3 ? 0.8 - 2.0 * t : std::min(0.8, 0.2 + (t - 0.3)); };
  SweepAssembler a(shortSweeps(), TiltChain());
  std::vector<SweepResult> sweeps;
  drive(a, down_then_up, 0.9, 0.0, &sweeps);
  EXPECT_EQ(sweeps.size(), 0u) << "no reversal after the turn yet";
  SweepResult last;
  ASSERT_TRUE(a.flush(0.9, last));
  EXPECT_NEAR(last.start, 0.3, 0.006);
  // drive()'s lines start every 25 ms and are added 25 ms late; those whose middle (stamp + 5 ms) is after the turn
  int after_turn = 0;
  for (double s = 0.0; s + 0.025 < 0.9 - 1e-9; s += 0.025) after_turn += s + 0.005 > 0.3;
  EXPECT_EQ(static_cast<int>(last.lines.size()), after_turn);
  EXPECT_GE(last.end, last.lines.back().stamp);
  EXPECT_FALSE(a.flush(0.9, last)) << "a second flush has nothing left to close";
  EXPECT_EQ(a.counters().sweeps, 1u);
  EXPECT_EQ(a.counters().sweeps_dropped, 0u);
}

// Without any reversal no sweep began: flush() closes nothing and the lines
// are counted as outside a sweep (group_bag says so).
TEST(SweepAssembler, LinesBeforeAnyReversalAreCountedOutsideASweep) {
  SweepAssembler a(shortSweeps(), TiltChain());
  drive(a, [](double t) { return 0.2 + 0.5 * t; }, 0.5, 0.0, nullptr);
  SweepResult last;
  EXPECT_FALSE(a.flush(0.5, last));
  EXPECT_EQ(a.counters().reversals, 0u);
  EXPECT_GE(a.counters().lines_outside_sweeps, 15u);
  EXPECT_EQ(a.counters().sweeps, 0u);
}

namespace {
/// A spinning joint: q = w t + 0.3, read as a servo reads it (within one turn,
/// -pi..pi) or unwrapped.
std::vector<SweepResult> runSpin(double w, bool wrapped, SweepCounters* counters = nullptr) {
  SweepParams p = shortSweeps();
  p.spin_span = M_PI;
  TiltChain chain;
  chain.axis = Eigen::Vector3d::UnitX();
  chain.base_to_joint.translation() = Eigen::Vector3d(0, 0, 1.4);
  SweepAssembler a(p, chain);
  std::vector<SweepResult> sweeps;
  drive(a, [&](double t) { return wrapped ? std::remainder(w * t + 0.3, 2.0 * M_PI) : w * t + 0.3; }, 8.0, 0.0,
        &sweeps);
  if (counters) *counters = a.counters();
  return sweeps;
}
}  // namespace

TEST(SweepAssembler, ASpinningJointIsUnwrappedAndCutEveryHalfTurn) {
  // 2 rad/s from 0.3 rad: it passes pi at 1.42 s, 2 pi at 2.99 s, 3 pi at
  // 4.56 s, 4 pi at 6.13 s, 5 pi at 7.70 s: four sweeps (the first stretch
  // is none).
  // Its readings wrap from pi to -pi each turn: that is no boundary.
  for (const bool wrapped : {true, false}) {
    SweepCounters c;
    const std::vector<SweepResult> sweeps = runSpin(2.0, wrapped, &c);
    ASSERT_EQ(sweeps.size(), 4u) << "wrapped " << wrapped;
    EXPECT_EQ(c.reversals, 5u);
    // The lines before the first sweep (middles before 1.42 s: 57 lines, the
    // last of them arriving after the joint had passed pi) are in none, and
    // none of them is taken for a line out of order.
    EXPECT_EQ(c.lines_out_of_order, 0u);
    EXPECT_EQ(c.lines_outside_sweeps, 57u);
    for (int k = 0; k < 4; ++k) {
      EXPECT_NEAR(sweeps[k].start, ((k + 1) * M_PI - 0.3) / 2.0, 0.006);
      EXPECT_NEAR(sweeps[k].end, ((k + 2) * M_PI - 0.3) / 2.0, 0.006);
      // A half turn at 2 rad/s is 1.57 s: 62 or 63 lines 25 ms apart.
      EXPECT_NEAR(static_cast<double>(sweeps[k].lines.size()), 62.8, 1.0);
      // Every beam's joint angle unwrapped, within its sweep's half turn.
      for (const SweepLine& l : sweeps[k].lines)
        for (const float q : l.tilt) {
          EXPECT_GE(q, (k + 1) * M_PI - 0.01);
          EXPECT_LE(q, (k + 2) * M_PI + 0.01);
        }
    }
    expectLinesInTheirSweeps(sweeps);
  }
}

TEST(SweepAssembler, ASpinTheOtherWayIsCutTheSame) {
  // -2 rad/s from 0.3: it passes 0 at 0.15 s, -pi at 1.72 s, -2 pi at 3.29 s, ...
  const std::vector<SweepResult> sweeps = runSpin(-2.0, true);
  ASSERT_EQ(sweeps.size(), 4u);
  EXPECT_NEAR(sweeps[0].start, 0.15, 0.006);
  EXPECT_NEAR(sweeps[0].end, (M_PI + 0.3) / 2.0, 0.006);
  for (const SweepResult& s : sweeps) EXPECT_NEAR(s.end - s.start, M_PI / 2.0, 0.006);
  expectLinesInTheirSweeps(sweeps);
}

TEST(SweepAssembler, ASpinSpanIsValidated) {
  SweepParams p;
  p.spin_span = -1.0;
  EXPECT_NE(p.validate().find("spin_span"), std::string::npos);
  p.spin_span = 7.0;
  EXPECT_NE(p.validate().find("spin_span"), std::string::npos);
  p.spin_span = M_PI;
  EXPECT_EQ(p.validate(), "");
}

TEST(SweepAssembler, ASweepCarriesTheGroupingParametersItsPlanesCameFrom) {
  // The height map holds a plane's points and corners to the tolerances the
  // plane was grouped with: the sweep says which. New ones (a reconfigure)
  // apply from the next sweep on.
  SweepParams p = shortSweeps();
  p.grouping.dist_min = 0.04;
  TiltChain chain;
  chain.base_to_joint.translation() = Eigen::Vector3d(0, 0, 1.4);
  SweepAssembler a(p, chain);
  std::vector<SweepResult> sweeps;
  GroupingParams g = p.grouping;
  g.dist_min = 0.05;
  bool set = false;
  drive(a, triangle, 3.0, 0.0, &sweeps, nullptr, [&] {
    if (!set && !sweeps.empty()) a.setGroupingParams(g), set = true;
  });
  ASSERT_GE(sweeps.size(), 3u);
  EXPECT_DOUBLE_EQ(sweeps.front().grouping.dist_min, 0.04);
  EXPECT_DOUBLE_EQ(sweeps.back().grouping.dist_min, 0.05);
}

TEST(SweepAssembler, TheGroupingKnowsTheLasersArmFromTheChain) {
  // HRP-4's head (urdf/hrp4_head.urdf's laser_joint): the laser 5 cm ahead of
  // the tilt axis (y) and 6 cm above it; an offset along the axis is no arm.
  TiltChain chain;
  chain.joint_to_laser.translation() = Eigen::Vector3d(0.05, 0.3, 0.06);
  SweepAssembler a(shortSweeps(), chain);
  EXPECT_NEAR(a.groupingParams().arm, std::hypot(0.05, 0.06), 1e-12);
  SweepAssembler on_axis(shortSweeps(), TiltChain());
  EXPECT_EQ(on_axis.groupingParams().arm, 0.0);
}
