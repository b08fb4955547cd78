#include "bag_pipeline.hpp"

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
  if (i + 1 >= argc) return false;
  if (a == "--urdf") o.urdf = argv[++i];
  else if (a == "--frame") o.frame = argv[++i];
  else if (a == "--joint") o.joint = argv[++i];
  else if (a == "--laser") o.laser = argv[++i];
  else if (a == "--calibration") o.calibration = readCalibrationYaml(argv[++i]);
  else return false;
  return true;
}

bool runBagPipeline(const BagPipelineOptions& o, const std::function<void(double, double)>& on_joint,
                    const std::function<void(const core::SweepResult&)>& on_sweep, BagPipelineResult& result,
                    std::string& error) {
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
      for (std::size_t i = 0; i < js->name.size() && i < js->position.size(); ++i)
        if (js->name[i] == o.joint) {
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
  while (assembler.poll(last + 10.0, done)) {
    ++result.sweeps;
    if (on_sweep) on_sweep(done);
  }
  result.counters = assembler.counters();
  result.last_warning = assembler.lastWarning();
  return true;
}

}  // namespace tools
}  // namespace tilt_laser_perception
