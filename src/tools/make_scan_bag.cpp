// Writes a rosbag of simulated UTM-30LX scans of a scene (topic /scan, frame
// "laser"): the sensor at a height above the scene origin, pitched down, and
// optionally nodding between two pitch angles (the pose changes beam by beam).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include <rosbag/bag.h>
#include <sensor_msgs/LaserScan.h>

#include "tilt_laser_perception/sim/lidar_sim.hpp"

using namespace tilt_laser_perception;

static void usage() {
  std::fprintf(stderr,
               "usage: make_scan_bag --scene NAME --out BAG [--scans N] [--seed S] [--height H]\n"
               "                     [--pitch-min DEG] [--pitch-max DEG] [--tilt-speed DEG_PER_S]\n"
               "  defaults: 80 scans, seed 1, height 1.4 m, pitch 30..60 deg down at 60 deg/s\n"
               "  (--tilt-speed 0 holds --pitch-min)\n");
}

int main(int argc, char** argv) {
  std::string scene_name, out;
  int scans = 80;
  unsigned long seed = 1;
  double height = 1.4, pitch_min = 30.0, pitch_max = 60.0, speed = 60.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    if (a == "--scene" && v) scene_name = argv[++i];
    else if (a == "--out" && v) out = argv[++i];
    else if (a == "--scans" && v) scans = std::atoi(argv[++i]);
    else if (a == "--seed" && v) seed = std::strtoul(argv[++i], nullptr, 10);
    else if (a == "--height" && v) height = std::atof(argv[++i]);
    else if (a == "--pitch-min" && v) pitch_min = std::atof(argv[++i]);
    else if (a == "--pitch-max" && v) pitch_max = std::atof(argv[++i]);
    else if (a == "--tilt-speed" && v) speed = std::atof(argv[++i]);
    else { usage(); return 2; }
  }
  if (scene_name.empty() || out.empty() || scans < 1 || !(pitch_max >= pitch_min)) { usage(); return 2; }
  try {
    const sim::Scene scene = sim::loadScene(scene_name);
    sim::LidarSimulator simulator(scene, sim::LidarModel(), sim::NoiseParams(), seed);
    const double deg = M_PI / 180.0, span = pitch_max - pitch_min;
    const auto pitch_at = [&](double t) {
      if (speed <= 0.0 || span <= 0.0) return pitch_min;
      const double period = 2.0 * span / speed;
      const double phase = std::fmod(t, period) * speed;
      return phase <= span ? pitch_min + phase : pitch_max - (phase - span);
    };
    const sim::PoseFunction pose = [&](double t) {
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation() = Eigen::Vector3d(0, 0, height);
      T.linear() = Eigen::AngleAxisd(pitch_at(t) * deg, Eigen::Vector3d::UnitY()).toRotationMatrix();
      return T;
    };
    rosbag::Bag bag(out, rosbag::bagmode::Write);
    const ros::Time start(1700000000, 0);
    sim::SimScan s;
    for (int k = 0; k < scans; ++k) {
      const double t = k * simulator.model().scan_period;
      simulator.scan(t, pose, s);
      sensor_msgs::LaserScan msg;
      msg.header.seq = k;
      msg.header.stamp = start + ros::Duration(t);
      msg.header.frame_id = "laser";
      msg.angle_min = s.model.angleMin();
      msg.angle_max = s.model.angleMax();
      msg.angle_increment = s.model.angle_increment;
      msg.time_increment = s.model.timeIncrement();
      msg.scan_time = s.model.scan_period;
      msg.range_min = s.model.range_min;
      msg.range_max = s.model.range_max;
      msg.ranges = s.ranges;
      msg.intensities = s.intensities;
      bag.write("/scan", msg.header.stamp, msg);
    }
    bag.close();
    std::printf("wrote %d scans of scene '%s' to %s\n", scans, scene.name.c_str(), out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_scan_bag: %s\n", e.what());
    return 1;
  }
  return 0;
}
