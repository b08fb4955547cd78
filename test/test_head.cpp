// The simulated head: servo motion, mounting, per-beam skew of scans taken
// while tilting, sweep control and the true height map.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "tilt_laser_perception/sim/head.hpp"

using namespace tilt_laser_perception::sim;

TEST(ServoModel, TrapezoidalMotionToTheGoal) {
  ServoModel s(0.0, 0.0);
  s.setVelocityLimit(0.0, 2.0);
  s.setAccelerationLimit(0.0, 20.0);
  s.setGoal(0.0, 1.0);
  // 0.1 s to reach 2 rad/s (0.1 rad), cruise, 0.1 s braking (0.1 rad): 0.6 s in all.
  EXPECT_NEAR(s.state(0.1).velocity, 2.0, 0.02);
  EXPECT_NEAR(s.state(0.35).position, 0.1 + 2.0 * 0.25, 0.01);
  double vmax = 0.0;
  for (double t = 0.35; t < 1.0; t += 0.01) vmax = std::max(vmax, std::abs(s.state(t).velocity));
  EXPECT_LE(vmax, 2.0 + 1e-9);
  const auto end = s.state(1.0);
  EXPECT_NEAR(end.position, 1.0, 1e-6);
  EXPECT_FALSE(end.moving);
  // The history answers for past times.
  EXPECT_NEAR(s.positionAt(0.35), 0.6, 0.01);
  EXPECT_NEAR(s.positionAt(0.05), 0.5 * 20.0 * 0.05 * 0.05, 0.002);
}

TEST(ServoModel, TorqueOffStopsFollowingTheGoal) {
  ServoModel s(0.0, 0.0);
  s.setTorque(0.0, false);
  s.setGoal(0.0, 1.0);
  EXPECT_NEAR(s.state(1.0).position, 0.0, 1e-9);
}

TEST(HeadGeometry, LaserPoseFollowsTheTilt) {
  HeadGeometry g;
  const Eigen::Isometry3d level = g.laserPose(0.0);
  EXPECT_TRUE(level.translation().isApprox(Eigen::Vector3d(0.05, 0.0, 1.46)));
  const Eigen::Isometry3d down = g.laserPose(M_PI / 2);
  // Pitched 90 degrees down: the laser's x axis points at the floor, its origin 5 cm below the axis.
  EXPECT_TRUE((down.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d(0, 0, -1), 1e-12));
  EXPECT_TRUE(down.translation().isApprox(Eigen::Vector3d(0.06, 0.0, 1.35), 1e-12));
}

TEST(HeadSimulator, ScanTakenWhileTiltingIsSkewedBeamByBeam) {
  const Scene floor = Scene::parse("objects:\n  - {type: floor, center: [0, 0], size: [40, 40]}\n");
  HeadGeometry g;
  ServoModel servo(0.5, 0.0);  // 28.6 degrees down
  servo.setVelocityLimit(0.0, 1.0);
  servo.setAccelerationLimit(0.0, 200.0);
  servo.setGoal(0.0, 1.2);
  NoiseParams exact;
  exact.mode = NoiseMode::None;
  exact.mixed_pixel_probability = 0.0;
  HeadSimulator sim(floor, g, servo, exact, 1);
  const double t0 = 0.1;  // moving at 1 rad/s by then
  servo.state(t0 + 0.03);
  HeadScan hs;
  sim.scan(t0, hs);
  const LidarModel m;
  // Beam i's tilt is the joint angle at its own time: 1 rad/s * 18.75 ms = 1.07 deg across the scan.
  EXPECT_NEAR(hs.tilt[1080] - hs.tilt[0], 1.0 * m.beamTime(1080), 1e-4);
  double max_skew = 0.0;
  for (int i : {400, 540, 700}) {
    const auto expected = [&](double tilt) {
      const Eigen::Isometry3d T = g.laserPose(tilt);
      const Eigen::Vector3d d = T.linear() * Eigen::Vector3d(std::cos(m.angle(i)), std::sin(m.angle(i)), 0.0);
      return -T.translation().z() / d.z();
    };
    EXPECT_NEAR(hs.scan.true_ranges[i], expected(servo.positionAt(t0 + m.beamTime(i))), 1e-4) << i;
    max_skew = std::max(max_skew, std::abs(hs.scan.true_ranges[i] - expected(hs.tilt[0])));
  }
  // One angle for the whole scan would be off by more than 2 cm.
  EXPECT_GT(max_skew, 0.02);
}

namespace {
// A head tilting at 1 rad/s over a floor, scanned with the given rig errors.
struct RigRun {
  Scene floor = Scene::parse("objects:\n  - {type: floor, center: [0, 0], size: [40, 40]}\n");
  HeadGeometry g;
  ServoModel servo{0.5, 0.0};
  NoiseParams exact;
  explicit RigRun(double goal = 1.2) {
    servo.setVelocityLimit(0.0, 1.0);
    servo.setAccelerationLimit(0.0, 200.0);
    servo.setGoal(0.0, goal);
    exact.mode = NoiseMode::None;
    exact.mixed_pixel_probability = 0.0;
  }
  HeadScan scan(HeadSimulator& sim, double t0) {
    servo.state(t0 + 0.03);
    HeadScan hs;
    sim.scan(t0, hs);
    return hs;
  }
};
constexpr double kDeg = M_PI / 180.0;
}  // namespace

TEST(RigErrors, JointOffsetAndTimeOffsetMoveTheLasersTrueTilt) {
  RigRun run;
  RigErrors rig;
  rig.joint_offset = 0.5 * kDeg;
  rig.time_offset = 0.005;  // stamped 5 ms late: the beams were taken 5 ms before the stamp says
  HeadSimulator sim(run.floor, run.g, run.servo, run.exact, 1, LidarModel(), rig);
  const HeadScan hs = run.scan(sim, 0.1);
  const LidarModel m;
  for (int i : {0, 540, 1080})
    EXPECT_NEAR(hs.tilt[i], run.servo.positionAt(0.1 - 0.005 + m.beamTime(i)) + 0.5 * kDeg, 1e-6) << i;
  // The floor's range follows the true tilt, not the reported one.
  const Eigen::Isometry3d T = run.g.laserPose(hs.tilt[540]);
  const Eigen::Vector3d d = T.linear() * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(hs.scan.true_ranges[540], -T.translation().z() / d.z(), 1e-4);
}

TEST(RigErrors, BacklashLagsByHalfThePlayAndFlipsWithTheDirection) {
  RigRun run(1.0);
  RigErrors rig;
  rig.backlash = 0.4 * kDeg;
  HeadSimulator sim(run.floor, run.g, run.servo, run.exact, 1, LidarModel(), rig);
  // Going down (tilt increasing): the laser trails the horn by 0.2 degrees.
  HeadScan hs;
  for (double t = 0.05; t < 0.3; t += 0.025) hs = run.scan(sim, t);
  EXPECT_NEAR(hs.tilt[540] - run.servo.positionAt(0.275 + LidarModel().beamTime(540)), -0.2 * kDeg, 1e-6);
  // At the goal (0.5 s) and back up: it trails the other way.
  run.servo.setGoal(0.7, 0.5);
  for (double t = 0.3; t < 1.0; t += 0.025) hs = run.scan(sim, t);
  EXPECT_NEAR(hs.tilt[540] - run.servo.positionAt(0.975 + LidarModel().beamTime(540)), +0.2 * kDeg, 1e-6);
}

TEST(RigErrors, MountRollTiltsTheFloorAcrossTheScan) {
  RigRun run(0.5);  // holds still at 0.5 rad
  RigErrors rig;
  rig.mount_roll = 1.0 * kDeg;
  HeadSimulator ideal(run.floor, run.g, run.servo, run.exact, 1);
  HeadSimulator rolled(run.floor, run.g, run.servo, run.exact, 1, LidarModel(), rig);
  const HeadScan a = run.scan(ideal, 0.1), b = run.scan(rolled, 0.1);
  // The front beam barely changes; beams to the sides change in opposite directions.
  EXPECT_NEAR(a.scan.true_ranges[540], b.scan.true_ranges[540], 0.002);
  const double left = b.scan.true_ranges[720] - a.scan.true_ranges[720];   // +45 deg
  const double right = b.scan.true_ranges[360] - a.scan.true_ranges[360];  // -45 deg
  EXPECT_GT(std::abs(left), 0.02);
  EXPECT_LT(left * right, 0.0);
}

TEST(RigErrors, ReadingNoiseAndLineJitterHaveTheirSigma) {
  RigRun run(3.0);
  RigErrors rig;
  rig.tilt_noise = 0.05 * kDeg;
  rig.line_jitter = 0.002;
  HeadSimulator sim(run.floor, run.g, run.servo, run.exact, 7, LidarModel(), rig);
  double s2 = 0.0, j2 = 0.0;
  const int n = 60;
  for (int k = 0; k < n; ++k) {
    const double t = 0.05 + 0.025 * k;  // moving at 1 rad/s throughout
    const HeadScan hs = run.scan(sim, t);
    const double e = run.servo.reading(t) - run.servo.positionAt(t);
    s2 += e * e;
    const double lag = hs.tilt[0] - run.servo.positionAt(t);  // 1 rad/s: radians = seconds
    j2 += lag * lag;
  }
  EXPECT_NEAR(std::sqrt(s2 / n), 0.05 * kDeg, 0.015 * kDeg);
  EXPECT_NEAR(std::sqrt(j2 / n), 0.002, 0.0006);
}

TEST(RigErrors, OptionsParseAndRefuseBadValues) {
  RigErrors rig;
  NoiseParams noise;
  const char* args[] = {"x", "--realistic", "--mount-error-deg", "0.2,-0.4", "--time-offset-ms", "-3", "--scene"};
  char** argv = const_cast<char**>(args);
  int i = 1;
  EXPECT_TRUE(parseRigOption(7, argv, i, rig, noise));
  EXPECT_NEAR(rig.backlash, 0.3 * kDeg, 1e-12);
  EXPECT_NEAR(noise.footprint, 1.0 * kDeg, 1e-12);
  EXPECT_TRUE(rig.quantize);
  ++i;
  EXPECT_TRUE(parseRigOption(7, argv, i, rig, noise));
  EXPECT_EQ(i, 3);
  EXPECT_NEAR(rig.mount_roll, 0.2 * kDeg, 1e-12);
  EXPECT_NEAR(rig.mount_yaw, -0.4 * kDeg, 1e-12);
  ++i;
  EXPECT_TRUE(parseRigOption(7, argv, i, rig, noise));
  EXPECT_NEAR(rig.time_offset, -0.003, 1e-12);
  ++i;
  EXPECT_FALSE(parseRigOption(7, argv, i, rig, noise));
  const char* bad[] = {"x", "--backlash-deg", "0.3deg", "--backlash-deg", "-1", "--joint-offset-deg"};
  char** b = const_cast<char**>(bad);
  for (int k : {1, 3, 5}) {
    int j = k;
    EXPECT_THROW(parseRigOption(6, b, j, rig, noise), std::invalid_argument) << bad[k];
  }
}

TEST(SweepController, SweepsBetweenTheLimits) {
  ServoModel servo(0.2, 0.0);
  tilt_laser_perception::core::TiltProfileParams p;
  p.min_angle = 0.2;
  p.max_angle = 0.8;
  p.speed = 1.0;
  SweepController sweep(servo, p);
  int sweeps = 0;
  double lo = 1e9, hi = -1e9;
  tilt_laser_perception::core::Sweep s;
  for (double t = 0.0; t < 3.0; t += 0.001) {
    if (sweep.update(t, &s)) {
      ++sweeps;
      // One way: 0.6 rad at 1 rad/s plus acceleration and braking at 20 rad/s^2 (0.65 s);
      // the profile turns once within 3 mrad of the end, a little earlier.
      EXPECT_NEAR(s.end_time - s.start_time, 0.64, 0.02);
      EXPECT_NEAR(std::abs(s.end_angle - s.start_angle), 0.6, 0.01);
      EXPECT_EQ(s.upward, s.end_angle > s.start_angle);
    }
    const double x = servo.state(t).position;
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  EXPECT_GE(sweeps, 3);
  EXPECT_LE(sweeps, 4);
  EXPECT_NEAR(lo, 0.2, 0.002);  // turning early, the horn brakes a little past the end
  EXPECT_NEAR(hi, 0.8, 0.002);
}

TEST(TrueHeightMap, StairsTreadsAndFloor) {
  const Scene s = loadScene("stairs");
  // 1 cm cells from (0, -0.5): x = 1.0 m is floor, x = 1.35 m is tread 1 (0.15 m), x = 1.95 m tread 3 (0.45 m).
  const auto h = trueHeightMap(s, 0.0, -0.5, 0.01, 300, 100);
  const auto at = [&](double x, double y) { return h[static_cast<int>((y + 0.5) / 0.01) * 300 + static_cast<int>(x / 0.01)]; };
  EXPECT_NEAR(at(0.5, 0.0), 0.0, 1e-6);
  EXPECT_NEAR(at(1.35, 0.0), 0.15, 1e-6);
  EXPECT_NEAR(at(1.95, 0.0), 0.45, 1e-6);
  EXPECT_NEAR(at(1.0, 0.45), 0.0, 1e-6);   // beside the box (box spans y 0.75..1.15)
}
