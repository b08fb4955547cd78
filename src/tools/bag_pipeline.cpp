#include "bag_pipeline.hpp"

#include <algorithm>

#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/buffer_core.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>
#include <urdf/model.h>

#include "calibration_yaml.hpp"
#include "tilt_laser_perception/ros/conversions.hpp"

namespace tilt_laser_perception {
namespace tools {

bool parseBagOption(int argc, char** argv, int& i, BagPipelineOptions& o) {
  const std::string a = argv[i];
  if (a == "--reverse") {  // each sweep's lines grouped in the other order
    o.sweep.reverse_lines = true;
    return true;
  }
  if (i + 1 >= argc) return false;
  if (a == "--urdf") o.urdf = argv[++i];
  else if (a == "--frame") o.frame = argv[++i];
  else if (a == "--joint") o.joint = argv[++i];
  else if (a == "--laser") o.laser = argv[++i];
  else if (a == "--calibration") o.calibration = readCalibrationYaml(argv[++i]);
  else if (a == "--spin-span") o.sweep.spin_span = std::atof(argv[++i]);  // a spinning head: a sweep each span [rad]
  else return false;
  return true;
}

bool runBagPipeline(const BagPipelineOptions& o, const std::function<void(double, double)>& on_joint,
                    const std::function<void(const core::SweepResult&)>& on_sweep, BagPipelineResult& result,
                    std::string& error) {
  if (const std::string bad = o.sweep.validate(); !bad.empty()) {
    error = "invalid sweep parameters: " + bad;
    return false;
  }
  urdf::Model model;
  if (!model.initFile(o.urdf)) {
    error = "cannot read URDF " + o.urdf;
    return false;
  }
  core::TiltChain chain;
  std::string parent;
  if (!tiltChainFromUrdf(model, o.joint, o.laser, chain, parent, error)) return false;
  chain = o.calibration.correct(chain);
  result.chain = chain;
  rosbag::Bag bag;
  try {
    bag.open(o.bag, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    error = "cannot open " + o.bag + ": " + e.what();
    return false;
  }
  tf2::BufferCore tf(ros::Duration(1e6));
  const auto base_pose = [&](double t, Eigen::Isometry3d& pose) {
    try {
      pose = tf2::transformToEigen(tf.lookupTransform(o.frame, parent, ros::Time(t)));
      result.base = pose;
      return core::SweepAssembler::PoseStatus::Ok;
    } catch (const tf2::TransformException&) {
      return core::SweepAssembler::PoseStatus::Missing;
    }
  };
  core::SweepAssembler assembler(o.sweep, chain, base_pose);
  core::ScanSplitter splitter;
  core::SplitResult split;
  core::SweepResult done;
  double last = 0.0;
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    last = m.getTime().toSec();
    if (const auto t = m.instantiate<tf2_msgs::TFMessage>()) {
      const bool is_static = m.getTopic() == "/tf_static";
      for (const auto& tr : t->transforms) tf.setTransform(tr, "bag", is_static);
    } else if (const auto js = m.instantiate<sensor_msgs::JointState>()) {
      if (result.joint_names.size() < 8)
        for (const auto& n : js->name)
          if (std::find(result.joint_names.begin(), result.joint_names.end(), n) == result.joint_names.end())
            result.joint_names.push_back(n);
      for (std::size_t i = 0; i < js->name.size() && i < js->position.size(); ++i)
        if (js->name[i] == o.joint) {
          ++result.joint_states;
          const double q = js->position[i] + o.calibration.joint_offset;
          if (on_joint) on_joint(js->header.stamp.toSec(), q);
          assembler.addJoint(js->header.stamp.toSec(), q);
        }
    } else if (const auto scan = m.instantiate<sensor_msgs::LaserScan>()) {
      ++result.scans;
      if (splitter.split(toScanView(*scan), split) != core::ScanError::None) continue;
      core::LineInput in = toLineInput(*scan);
      in.stamp -= o.calibration.time_offset;
      for (const auto& s : split.segments) in.segments.emplace_back(s.first, s.last);
      for (const auto& e : split.edges) in.edges.emplace_back(e.index, e.kind);
      assembler.addLine(std::move(in), last);
    }
    while (assembler.poll(last, done)) {
      ++result.sweeps;
      if (on_sweep) on_sweep(done);
    }
  }
  // What is left waits in vain; then the recording's end closes the sweep in
  // progress, which has no reversal after it.
  while (assembler.poll(last + o.sweep.max_wait + 1.0, done)) {
    ++result.sweeps;
    if (on_sweep) on_sweep(done);
  }
  if (assembler.flush(last, done)) {
    ++result.sweeps;
    result.closed_by_end = true;
    if (on_sweep) on_sweep(done);
  }
  result.counters = assembler.counters();
  result.last_warning = assembler.lastWarning();
  return true;
}

std::string noSweepReason(const BagPipelineOptions& o, const BagPipelineResult& r) {
  if (r.sweeps > 0) return "";
  const core::SweepCounters& c = r.counters;
  if (r.scans == 0) return "the recording holds no sensor_msgs/LaserScan";
  if (r.joint_states == 0) {
    std::string names;
    for (const auto& n : r.joint_names) names += (names.empty() ? "" : ", ") + n;
    return "no joint state names the tilt joint '" + o.joint + "' (--joint; the recording names: " +
           (names.empty() ? "no joints" : names) + ")";
  }
  if (c.lines_no_joint >= c.lines / 2 + 1)
    return std::to_string(c.lines_no_joint) + " of " + std::to_string(c.lines) +
           " scan lines had no joint states around their beams (the tilt was not recorded while scanning?)";
  if (c.lines_no_pose >= c.lines / 2 + 1)
    return std::to_string(c.lines_no_pose) + " of " + std::to_string(c.lines) + " scan lines had no pose of '" +
           o.frame + "' on /tf (--frame)";
  if (c.reversals == 0)
    return "the tilt never reversed, so no sweep began (" + std::to_string(c.lines_outside_sweeps) +
           " lines outside a sweep); a recording that starts its only sweep from rest needs a lead-in "
           "(import_tilt_bag.py writes one)" +
           (o.sweep.spin_span > 0.0 ? std::string()
                                    : "; a spinning head's recording needs --spin-span RAD (pi: a sweep each half turn)");
  if (c.sweeps_dropped > 0)
    return std::to_string(c.sweeps_dropped) + " sweep(s) dropped: " + r.last_warning;
  return "no sweep finished (" + std::to_string(c.lines_outside_sweeps) + " lines outside a sweep; " +
         r.last_warning + ")";
}

}  // namespace tools
}  // namespace tilt_laser_perception
