// The odometry of the simulated walking robot, for sim.launch walk:=...: the
// same walk as tilt_laser_sim's (scene, walk options, and the start time that
// tilt_laser_sim writes to --walk-clock), published as odom -> base_footprint
// on /tf at ~rate (100 Hz), as a humanoid's state estimator would.
//   ~scene (stairs), ~walk ("--walk 0.3 --start -1.5,0 ..."), ~clock_file, ~rate (100),
//   ~frame_id (odom), ~child_frame_id (base_footprint)
#include <ros/ros.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/transform_broadcaster.h>

#include <fstream>
#include <sstream>
#include <vector>

#include "tilt_laser_perception/sim/walk.hpp"

using namespace tilt_laser_perception;

int main(int argc, char** argv) {
  ros::init(argc, argv, "sim_odometry");
  ros::NodeHandle pnh("~");
  std::string scene_name, walk_text, clock_file, frame, child;
  double rate = 100.0;
  pnh.param<std::string>("scene", scene_name, "stairs");
  pnh.param<std::string>("walk", walk_text, "");
  pnh.param<std::string>("clock_file", clock_file, "");
  pnh.param<std::string>("frame_id", frame, "odom");
  pnh.param<std::string>("child_frame_id", child, "base_footprint");
  pnh.param("rate", rate, rate);
  sim::WalkParams params;
  try {
    std::vector<std::string> words{"sim_odometry"};
    std::istringstream in(walk_text);
    for (std::string w; in >> w;) words.push_back(w);
    std::vector<char*> args;
    for (std::string& w : words) args.push_back(w.data());
    for (int i = 1; i < static_cast<int>(args.size()); ++i)
      if (!sim::parseWalkOption(static_cast<int>(args.size()), args.data(), i, params))
        throw std::invalid_argument(std::string("not a walk option: ") + args[i]);
  } catch (const std::exception& e) {
    ROS_FATAL("~walk '%s': %s", walk_text.c_str(), e.what());
    return 2;
  }
  if (!(rate > 0.0 && rate <= 1000.0)) {
    ROS_ERROR("~rate must be in (0, 1000] Hz: using 100");
    rate = 100.0;
  }
  const sim::Scene scene = sim::loadScene(scene_name);
  // The walk's start: tilt_laser_sim's clock, written when it started (a file
  // left by an earlier run is older than this node by more than its start-up).
  const double began = ros::WallTime::now().toSec();
  bool have_start = clock_file.empty();
  while (!have_start && ros::ok()) {
    std::ifstream f(clock_file);
    double t = 0.0;
    if (f >> t && t > began - 10.0) {
      params.start_time = t;
      have_start = true;
    } else {
      ROS_INFO_THROTTLE(5.0, "waiting for tilt_laser_sim's walk clock in %s", clock_file.c_str());
      ros::WallDuration(0.05).sleep();
    }
  }
  if (clock_file.empty()) params.start_time = began;
  const sim::WalkModel walk(scene, params);
  tf2_ros::TransformBroadcaster tf;
  ros::WallRate loop(rate);
  while (ros::ok()) {
    const ros::Time now = ros::Time::now();
    geometry_msgs::TransformStamped m = tf2::eigenToTransform(walk.odomPose(now.toSec()));
    m.header.stamp = now;
    m.header.frame_id = frame;
    m.child_frame_id = child;
    tf.sendTransform(m);
    loop.sleep();
  }
  return 0;
}
