// tilt_laser_perception/NeckRelay: holds HRP-4's neck joints (config/neck.yaml)
// at fixed angles on joint_states while the robot itself does not publish
// them, so that robot_state_publisher always has the whole chain from
// base_footprint to the laser. When another node publishes fresh values for
// all of them (the robot's own joint states), it falls silent and the
// robot's values drive tf; when they stop for longer than ~timeout it takes
// over again. Each change is logged. In the driver's nodelet manager it costs
// next to nothing (the driver's 200 Hz joint states reach it without
// serialization); the Python node it replaces took 8 % of a core.
// Parameters (private): joints, fixed_positions, source (topic), timeout [s], rate [Hz].
#include <algorithm>
#include <string>
#include <vector>

#include <boost/make_shared.hpp>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>

#include "tilt_laser_perception/core/input_check.hpp"
#include "tilt_laser_perception/core/joint_hold.hpp"

namespace tilt_laser_perception {

class NeckRelayNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    pnh.param("joints", joints_, std::vector<std::string>{"NECK_Y", "NECK_P"});
    pnh.param("fixed_positions", fixed_, std::vector<double>(joints_.size(), 0.0));
    if (fixed_.size() != joints_.size()) {
      NODELET_ERROR("~fixed_positions has %zu values for %zu joints: using zeros", fixed_.size(), joints_.size());
      fixed_.assign(joints_.size(), 0.0);
    }
    std::string source;
    double timeout = 0.5, rate = 50.0;
    pnh.param<std::string>("source", source, "/joint_states");
    pnh.param("timeout", timeout, 0.5);
    pnh.param("rate", rate, 50.0);
    hold_ = core::JointHold(timeout);
    source_ = source;
    pub_ = nh.advertise<sensor_msgs::JointState>("joint_states", 10);
    sub_ = nh.subscribe(source, 50, &NeckRelayNodelet::onState, this);
    timer_ = nh.createTimer(ros::Duration(1.0 / std::max(1.0, rate)), &NeckRelayNodelet::onTimer, this);
  }

  void onState(const ros::MessageEvent<sensor_msgs::JointState const>& event) {
    // Our own messages, and those of the nodelets beside us in the manager (the
    // driver's tilt joint), carry this process's name; none of theirs has the neck.
    if (event.getPublisherName() == ros::this_node::getName()) return;
    // Given only with a position for each that can be followed: a NaN one
    // (or names without positions) would silence the relay and leave
    // robot_state_publisher without the neck.
    const sensor_msgs::JointState& js = *event.getConstMessage();
    for (const auto& j : joints_)
      if (std::find(js.name.begin(), js.name.end(), j) == js.name.end()) return;  // not the neck
    const char* bad = js.position.size() != js.name.size() ? "names and positions of different lengths" : nullptr;
    for (std::size_t i = 0; !bad && i < js.name.size(); ++i)
      if (std::find(joints_.begin(), joints_.end(), js.name[i]) != joints_.end()) bad = core::checkJointPosition(js.position[i]);
    if (bad) {
      NODELET_WARN_THROTTLE(5.0, "%s: the neck from %s refused (%s): still holding it", getName().c_str(),
                            event.getPublisherName().c_str(), bad);
      return;
    }
    hold_.seen(ros::WallTime::now().toSec());
  }

  void onTimer(const ros::TimerEvent&) {
    const bool holding = hold_.holding(ros::WallTime::now().toSec());
    if (!said_ || holding != holding_) {
      std::string list;
      for (const auto& j : joints_) list += (list.empty() ? "" : ", ") + j;
      if (holding) {
        std::string values;
        for (double v : fixed_) values += (values.empty() ? "" : ", ") + std::to_string(v);
        NODELET_INFO("%s: no joint states for %s on %s: holding them at [%s] rad", getName().c_str(), list.c_str(),
                     source_.c_str(), values.c_str());
      } else {
        NODELET_INFO("%s: the robot publishes %s: following it", getName().c_str(), list.c_str());
      }
      said_ = true;
      holding_ = holding;
    }
    if (!holding) return;
    auto msg = boost::make_shared<sensor_msgs::JointState>();
    msg->header.stamp = ros::Time::now();
    msg->name = joints_;
    msg->position = fixed_;
    pub_.publish(msg);
  }

  std::vector<std::string> joints_;
  std::vector<double> fixed_;
  std::string source_;
  core::JointHold hold_{0.5};
  bool said_ = false, holding_ = true;
  ros::Publisher pub_;
  ros::Subscriber sub_;
  ros::Timer timer_;
};

}  // namespace tilt_laser_perception

PLUGINLIB_EXPORT_CLASS(tilt_laser_perception::NeckRelayNodelet, nodelet::Nodelet)
