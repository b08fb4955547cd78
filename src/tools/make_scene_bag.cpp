// Writes a rosbag straight from a scene, without the emulators: the head
// sweeping its tilt joint (triangle profile), LaserScans (/scan), the joint
// state at 100 Hz stamped when sampled (/joint_states), the transforms
// (/tf_static for the fixed joints, /tf for the tilt joint), and optionally the
// ground truth of every scan (/scan_truth). Fast tests and replays use it.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>

#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include "tilt_laser_perception/ScanTruth.h"
#include "tilt_laser_perception/dynamixel/mx64.hpp"
#include "tilt_laser_perception/sim/head.hpp"

using namespace tilt_laser_perception;

namespace {
void usage() {
  std::fprintf(stderr,
               "usage: make_scene_bag --scene NAME --out BAG [--duration S] [--seed N] [--min-deg D] [--max-deg D]\n"
               "                      [--speed RAD_PER_S] [--spin RAD_PER_S] [--truth] [--head FILE] [--noise datasheet|percent|none]\n"
               "  defaults: 5 s, seed 1, tilt 10..60 deg at 1 rad/s, no truth\n"
               "  --spin: a spinning head (config/head_spin.yaml unless --head) turning at this rate, its joint\n"
               "          head_spin_joint as in urdf/hrp4_head_spin.urdf (replay.launch spin:=true)\n"
               "  walking (--walk ...): the odometry's odom -> base_footprint on /tf at 100 Hz\n"
               "%s%s", sim::rigOptionsUsage(), sim::walkOptionsUsage());
}

geometry_msgs::TransformStamped transform(const std::string& parent, const std::string& child, const ros::Time& t,
                                          const Eigen::Isometry3d& T) {
  geometry_msgs::TransformStamped m;
  m.header.stamp = t;
  m.header.frame_id = parent;
  m.child_frame_id = child;
  m.transform.translation.x = T.translation().x();
  m.transform.translation.y = T.translation().y();
  m.transform.translation.z = T.translation().z();
  const Eigen::Quaterniond q(T.linear());
  m.transform.rotation.x = q.x();
  m.transform.rotation.y = q.y();
  m.transform.rotation.z = q.z();
  m.transform.rotation.w = q.w();
  return m;
}
}  // namespace

int main(int argc, char** argv) {
  std::string scene_name, out, head_path;
  double duration = 5.0, min_deg = 10.0, max_deg = 60.0, speed = 1.0;
  bool spin = false;
  unsigned long seed = 1;
  bool with_truth = false;
  sim::NoiseParams noise;
  sim::RigErrors rig;
  sim::WalkParams walk_params;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    try {
      if (sim::parseRigOption(argc, argv, i, rig, noise) || sim::parseWalkOption(argc, argv, i, walk_params)) continue;
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "make_scene_bag: %s\n", e.what());
      return 2;
    }
    if (a == "--scene" && v) scene_name = argv[++i];
    else if (a == "--out" && v) out = argv[++i];
    else if (a == "--duration" && v) duration = std::atof(argv[++i]);
    else if (a == "--seed" && v) seed = std::strtoul(argv[++i], nullptr, 10);
    else if (a == "--min-deg" && v) min_deg = std::atof(argv[++i]);
    else if (a == "--max-deg" && v) max_deg = std::atof(argv[++i]);
    else if (a == "--speed" && v) speed = std::atof(argv[++i]);
    else if (a == "--spin" && v) {
      spin = true;
      speed = std::atof(argv[++i]);
    }
    else if (a == "--head" && v) head_path = argv[++i];
    else if (a == "--truth") with_truth = true;
    else if (a == "--noise" && v) {
      if (!sim::parseNoiseMode(argv[++i], noise.mode)) { usage(); return 2; }
    } else { usage(); return 2; }
  }
  if (scene_name.empty() || out.empty() || !(duration > 0) || !(max_deg > min_deg) || !(speed > 0)) {
    usage();
    return 2;
  }
  try {
    const sim::Scene scene = sim::loadScene(scene_name);
    const sim::HeadGeometry head =
        sim::HeadGeometry::load(head_path.empty() ? sim::configDirectory() + (spin ? "/head_spin.yaml" : "/head.yaml") : head_path);
    if (head.spinning != spin) throw std::runtime_error("--head " + head_path + (spin ? " is not" : " is") + " a spinning head");
    const double deg = M_PI / 180.0;
    sim::ServoModel servo(min_deg * deg, 0.0);
    core::TiltProfileParams profile;
    profile.min_angle = min_deg * deg;
    profile.max_angle = max_deg * deg;
    profile.speed = speed;
    if (spin) profile.mode = core::TiltProfileParams::Mode::Spin;
    sim::SweepController sweep(servo, profile);
    sim::HeadSimulator head_sim(scene, head, servo, noise, seed, sim::LidarModel(), rig);
    const sim::WalkModel walk(scene, walk_params);
    if (walk_params.walking()) head_sim.setWalk(&walk);
    const sim::LidarModel& m = head_sim.model();

    rosbag::Bag bag(out, rosbag::bagmode::Write);
    const double epoch = 1700000000.0;
    const auto stamp = [&](double t) { return ros::Time(epoch + t); };

    // Fixed transforms: the joint's parent at the axis, the laser on its child
    // (the frames and joint of urdf/hrp4_head.urdf or hrp4_head_spin.urdf,
    // whose joint origin holds the rest of the chain to the joint).
    const core::TiltChain chain = head.chain();
    const std::string joint_name = spin ? "head_spin_joint" : "head_tilt_joint";
    const std::string joint_link = spin ? "head_spin_link" : "head_tilt_link";
    tf2_msgs::TFMessage statics;
    Eigen::Isometry3d axis = Eigen::Isometry3d::Identity();
    axis.translation() = head.axis_origin;
    const Eigen::Isometry3d joint_origin = axis.inverse() * chain.base_to_joint;
    statics.transforms.push_back(transform("base_footprint", "head_tilt_base", stamp(0), axis));
    statics.transforms.push_back(transform(joint_link, "laser", stamp(0), chain.joint_to_laser));
    bag.write("/tf_static", stamp(0), statics);

    sim::HeadScan hs;
    const double js_period = 0.01;
    double next_js = 0.0, next_scan = 0.0;
    unsigned scans = 0, states = 0, seq = 0;
    // Step the sweep every millisecond; sample the joint at 100 Hz; scan every 25 ms
    // (each scan is simulated once the servo has moved through it).
    for (double t = 0.0; t <= duration + 1e-9; t += 0.001) {
      sweep.update(t);
      if (t + 1e-9 >= next_js) {
        const sim::ServoModel::State s = servo.state(t);
        double q = servo.reading(t);  // what the encoder reports (the rig's noise in it)
        if (rig.quantize) q = dynamixel::positionToRad(dynamixel::radToPosition(q));
        sensor_msgs::JointState js;
        js.header.seq = states++;
        js.header.stamp = stamp(t);
        js.name = {joint_name};
        js.position = {q};
        js.velocity = {s.velocity};
        js.effort = {0.0};
        bag.write("/joint_states", js.header.stamp, js);
        tf2_msgs::TFMessage tf;
        tf.transforms.push_back(transform("head_tilt_base", joint_link, stamp(t),
                                          joint_origin * Eigen::AngleAxisd(q, chain.axis)));
        // A walking robot's state estimate: where its odometry puts the base.
        if (walk_params.walking()) tf.transforms.push_back(transform("odom", "base_footprint", stamp(t), walk.odomPose(t)));
        bag.write("/tf", stamp(t), tf);
        next_js += js_period;
      }
      if (t + 1e-9 >= next_scan + m.scan_period) {
        head_sim.scan(next_scan, hs);
        sensor_msgs::LaserScan msg;
        msg.header.seq = seq;
        msg.header.stamp = stamp(next_scan);
        msg.header.frame_id = "laser";
        msg.angle_min = m.angleMin();
        msg.angle_max = m.angleMax();
        msg.angle_increment = m.angle_increment;
        msg.time_increment = m.timeIncrement();
        msg.scan_time = m.scan_period;
        msg.range_min = m.range_min;
        msg.range_max = m.range_max;
        msg.ranges = hs.scan.ranges;
        msg.intensities = hs.scan.intensities;
        bag.write("/scan", stamp(t), msg);
        if (with_truth) {
          ScanTruth truth;
          truth.header = msg.header;
          truth.start_time = epoch + next_scan;
          truth.tilt = hs.tilt;
          truth.face_id = hs.scan.face;
          truth.true_range = hs.scan.true_ranges;
          truth.mixed = hs.scan.mixed;
          bag.write("/scan_truth", stamp(t), truth);
        }
        ++seq;
        ++scans;
        next_scan += m.scan_period;
      }
    }
    bag.close();
    std::printf("wrote %u scans and %u joint states of scene '%s' to %s\n", scans, states, scene.name.c_str(),
                out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_scene_bag: %s\n", e.what());
    return 1;
  }
  return 0;
}
