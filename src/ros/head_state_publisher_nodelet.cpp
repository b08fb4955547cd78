// tilt_laser_perception/HeadStatePublisher: the head's transforms from
// robot_description and joint_states, as robot_state_publisher gives them
// (the fixed joints once on /tf_static; each moving joint on /tf at the stamp
// of its joint state, at most ~publish_frequency times a second), but inside
// the head's process: the driver's 200 Hz joint states reach it without
// serialization, and the grouper's tf listener gets its transforms without
// the round trip through another process (robot_state_publisher took 3.5 %
// of a core for this). Joints the URDF does not have are ignored; a joint of
// the URDF that nobody publishes has no transform, as with
// robot_state_publisher, except the joints of ~hold: while nobody publishes
// them (the robot's own joint states: HRP-4's neck) their transforms are
// given at fixed angles, so that tf always has the chain from base_footprint
// to the laser; when fresh values come, those drive tf, and after ~hold/timeout
// without, the fixed angles again (the NeckRelay's job, without its joint
// state messages). Parameters (private): publish_frequency [Hz] (50);
// hold/joints, hold/fixed_positions [rad], hold/timeout [s], hold/rate [Hz]
// (config/neck.yaml). The joint states of this process (the driver's 200 Hz)
// are taken inline, in the thread that publishes them: no wake-up of another
// thread 200 times a second. Those of another process (the robot's own,
// a bag) go through the nodelet's queue: see onState. onState and the hold
// timer share a short-held mutex.
#include <algorithm>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <boost/make_shared.hpp>
#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/TransformStamped.h>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_msgs/TFMessage.h>
#include <urdf/model.h>

#include "tilt_laser_perception/core/joint_hold.hpp"
#include "tilt_laser_perception/ros/conversions.hpp"
#include "tilt_laser_perception/ros/inline_queue.hpp"
#include "tilt_laser_perception/ros/input_health.hpp"

namespace tilt_laser_perception {

class HeadStatePublisherNodelet : public nodelet::Nodelet {
 private:
  struct Moving {
    std::string parent, child;
    Eigen::Isometry3d origin;
    Eigen::Vector3d axis;
    bool prismatic = false;
    bool continuous = false;  // turns without end (a spinning head): any finite angle
    ros::Time last;  // stamp last published
  };

  uint64_t ownerId() const { return reinterpret_cast<uint64_t>(this); }

 public:
  ~HeadStatePublisherNodelet() override {
    hold_timer_.stop();
    diag_timer_.stop();
    sub_.shutdown();  // no inline call after this (it waits for one in progress)
    if (queue_) queue_->removeByID(ownerId());
  }

 private:
  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    health_.init(getName());
    pnh.param("max_stamp_age", stamp_limits_.max_age, stamp_limits_.max_age);
    pnh.param("max_stamp_ahead", stamp_limits_.max_ahead, stamp_limits_.max_ahead);
    diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
    diagnostics_->setHardwareID("none");
    diagnostics_->add("head state publisher", this, &HeadStatePublisherNodelet::diagnose);
    diag_timer_ = nh.createTimer(ros::Duration(0.5), [this](const ros::TimerEvent&) { diagnostics_->update(); });
    double frequency = 50.0;
    pnh.param("publish_frequency", frequency, 50.0);
    interval_ = ros::Duration(frequency > 0.0 ? 1.0 / frequency : 0.0);
    std::string xml;
    urdf::Model model;
    if (!nh.getParam("robot_description", xml) || !model.initString(xml)) {
      NODELET_ERROR("%s: no valid robot_description: no transforms", getName().c_str());
      return;
    }
    std::vector<geometry_msgs::TransformStamped> statics;
    for (const auto& [name, joint] : model.joints_) {
      const Eigen::Isometry3d origin = toIsometry(joint->parent_to_joint_origin_transform);
      if (joint->type == urdf::Joint::FIXED) {
        geometry_msgs::TransformStamped t = tf2::eigenToTransform(origin);
        t.header.stamp = ros::Time::now();
        t.header.frame_id = joint->parent_link_name;
        t.child_frame_id = joint->child_link_name;
        statics.push_back(t);
      } else if (joint->type != urdf::Joint::FLOATING && joint->type != urdf::Joint::PLANAR) {
        Moving m;
        m.parent = joint->parent_link_name;
        m.child = joint->child_link_name;
        m.origin = origin;
        m.axis = Eigen::Vector3d(joint->axis.x, joint->axis.y, joint->axis.z).normalized();
        m.prismatic = joint->type == urdf::Joint::PRISMATIC;
        m.continuous = joint->type == urdf::Joint::CONTINUOUS;
        moving_[name] = m;
      }
    }
    // Created here, not with the object: a nodelet's ROS set-up belongs in onInit.
    // /tf as tf2_ros::TransformBroadcaster sends it, but as a shared message:
    // a listener in this process takes it as it is (the broadcaster publishes
    // by reference, so every message was serialized, handed to roscpp's poll
    // thread and deserialized again); it is serialized only for another process.
    tf_pub_ = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
    static_broadcaster_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    static_broadcaster_->sendTransform(statics);
    // The held joints (the neck): each with its fixed angle, while nobody gives it.
    std::vector<std::string> hold;
    std::vector<double> fixed;
    double timeout = 0.5, rate = 50.0;
    pnh.param("hold/joints", hold, std::vector<std::string>());
    pnh.param("hold/fixed_positions", fixed, std::vector<double>(hold.size(), 0.0));
    pnh.param("hold/timeout", timeout, 0.5);
    pnh.param("hold/rate", rate, 50.0);
    if (fixed.size() != hold.size()) {
      NODELET_ERROR("~hold/fixed_positions has %zu values for %zu joints: using zeros", fixed.size(), hold.size());
      fixed.assign(hold.size(), 0.0);
    }
    for (std::size_t i = 0; i < hold.size(); ++i) {
      if (!moving_.count(hold[i])) {
        NODELET_WARN("~hold: the URDF has no moving joint %s", hold[i].c_str());
        continue;
      }
      held_.push_back(Held{hold[i], fixed[i], core::JointHold(timeout)});
    }
    queue_ = nh.getCallbackQueue();
    ros::SubscribeOptions states;
    states.initByFullCallbackType<const ros::MessageEvent<sensor_msgs::JointState const>&>(
        "joint_states", 100, boost::bind(&HeadStatePublisherNodelet::onState, this, boost::placeholders::_1));
    states.callback_queue = &inline_queue_;
    states.allow_concurrent_callbacks = true;  // serialized by mutex_
    sub_ = nh.subscribe(states);
    hold_period_ = ros::Duration(1.0 / std::max(1.0, rate));
    if (!held_.empty()) hold_timer_ = nh.createTimer(hold_period_, &HeadStatePublisherNodelet::onHold, this);
    NODELET_INFO("%s: %zu fixed transforms published, %zu moving joints followed, %zu held while nobody gives them",
                 getName().c_str(), statics.size(), moving_.size(), held_.size());
  }

  /// The transform of a moving joint at a position.
  geometry_msgs::TransformStamped transform(const Moving& m, double position, const ros::Time& stamp) const {
    Eigen::Isometry3d T = m.origin;
    if (m.prismatic) T.translate(m.axis * position);
    else T.rotate(Eigen::AngleAxisd(position, m.axis));
    geometry_msgs::TransformStamped t = tf2::eigenToTransform(T);
    t.header.stamp = stamp;
    t.header.frame_id = m.parent;
    t.child_frame_id = m.child;
    return t;
  }

  // Both callbacks build their message under mutex_ and publish it after
  // letting go: roscpp holds one lock of its own over every publish in the
  // process, and onState runs inside the driver's publish (inline), so
  // publishing with mutex_ held would deadlock against the other callback.
  void send(const boost::shared_ptr<tf2_msgs::TFMessage>& m) {
    if (m && !m->transforms.empty()) tf_pub_.publish(m);
  }

  /// The held joints nobody gives now (wall time `now`) into m at `stamp`;
  /// each change between holding and following is logged (mutex_ held).
  void addHeld(double now, const ros::Time& stamp, tf2_msgs::TFMessage& m) {
    for (Held& h : held_) {
      const bool holding = h.hold.holding(now);
      if (!h.said || holding != h.holding) {
        if (holding) NODELET_INFO("%s: nobody gives %s: holding it at %.3f rad", getName().c_str(), h.joint.c_str(), h.position);
        else NODELET_INFO("%s: %s is given: following it", getName().c_str(), h.joint.c_str());
        h.said = true;
        h.holding = holding;
      }
      if (holding) m.transforms.push_back(transform(moving_.at(h.joint), h.position, stamp));
    }
  }

  /// While joint states come, the held joints go out with the transforms
  /// they give (same message, same stamp: follow); the timer gives them, at
  /// ~hold/rate, only after none came for 0.25 s (the driver down), and
  /// meanwhile looks every 0.5 s instead of waking the process ~hold/rate
  /// times a second for nothing.
  void onHold(const ros::TimerEvent&) {
    const double now = ros::WallTime::now().toSec();
    auto m = boost::make_shared<tf2_msgs::TFMessage>();
    {
      std::lock_guard<std::mutex> l(mutex_);
      const bool states_flow = now - held_sent_ < 0.25;
      if (states_flow != slow_hold_) {
        slow_hold_ = states_flow;
        hold_timer_.setPeriod(states_flow ? ros::Duration(0.5) : hold_period_);
      }
      if (states_flow) return;
      addHeld(now, ros::Time::now(), *m);
    }
    send(m);
  }

  /// A joint state published in this process runs here inside its publish,
  /// in the publisher's thread, which holds roscpp's publish lock: the /tf
  /// this publishes takes that lock again (it is recursive). One from another
  /// process runs in roscpp's receiving thread, which holds the joint_states
  /// subscription's lock; publishing there waits for the publish lock, which
  /// the driver holds while it waits for that subscription's lock to deliver
  /// its own joint state: a deadlock that stopped the whole head (the
  /// robot's neck from its controller, 1 kHz, did it within 15 s). Their
  /// transforms are built here and only the publish is handed to the
  /// nodelet's queue: a worker wakes when a transform is due (50 a second),
  /// not for every joint state.
  void onState(const ros::MessageEvent<sensor_msgs::JointState const>& event) {
    auto m = follow(*event.getConstMessage());
    if (!m) return;
    if (event.getPublisherName() == ros::this_node::getName()) send(m);
    else queue_->addCallback(boost::make_shared<TaskCallback>([this, m] { send(m); }), ownerId());
  }

  /// The transforms of the joints of the URDF in one joint state, null when
  /// none is due. A stamp that is not set, or far from the clock, would go
  /// into tf as it is: one 50 s ahead makes every listener drop the real
  /// ones for 40 s (tf keeps 10 s).
  boost::shared_ptr<tf2_msgs::TFMessage> follow(const sensor_msgs::JointState& js) {
    const double now = InputHealth::now();
    boost::shared_ptr<tf2_msgs::TFMessage> m;  // made only when a transform is due (50 of the 200 a second)
    {
      std::lock_guard<std::mutex> l(mutex_);
      if (std::none_of(js.name.begin(), js.name.end(), [&](const std::string& n) { return moving_.count(n); }))
        return m;  // none of the head's joints (the robot's others)
      if (first_state_ < 0.0) first_state_ = now;
      states_in_.add(now);
      if (!health_.acceptJointState(js, stamp_limits_)) return m;
      const double wall = ros::WallTime::now().toSec();
      for (std::size_t i = 0; i < js.name.size(); ++i) {
        const auto it = moving_.find(js.name[i]);
        if (it == moving_.end() || !health_.acceptJointPosition(js, i, it->second.continuous)) continue;
        // A held joint is given only by a position that can be followed (a
        // NaN one would stop the hold and leave tf without it).
        for (Held& h : held_)
          if (h.joint == js.name[i]) h.hold.seen(wall);
        Moving& mv = it->second;
        const ros::Time& stamp = js.header.stamp;
        if (stamp < mv.last) mv.last = ros::Time();  // the clock went back (a bag looped): start again
        if (!mv.last.isZero() && stamp < mv.last + interval_) continue;
        mv.last = stamp;
        if (!m) m = boost::make_shared<tf2_msgs::TFMessage>();
        m->transforms.push_back(transform(mv, js.position[i], stamp));
      }
      if (m) {
        transforms_out_.add(now);
        if (!held_.empty()) {
          addHeld(wall, js.header.stamp, *m);
          held_sent_ = wall;
        }
      }
    }
    return m;
  }

  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
    std::lock_guard<std::mutex> l(mutex_);
    const double now = InputHealth::now();
    std::string why = "no joint states yet: only the fixed and held joints";
    const core::Health level =
        first_state_ < 0.0 ? core::Health::Ok : health_.judge(states_in_, transforms_out_, first_state_, 5.0, why);
    health_.report(stat, level, why);
    stat.add("joint states (last 10 s)", states_in_.recent(now));
    stat.add("transform messages from joint states (last 10 s)", transforms_out_.recent(now));
    std::string held;
    const double wall = ros::WallTime::now().toSec();
    for (const Held& h : held_)
      if (h.hold.holding(wall)) held += (held.empty() ? "" : ", ") + h.joint;
    stat.add("held at fixed angles (nobody gives them)", held.empty() ? "none" : held);
  }

  struct Held {
    std::string joint;
    double position;
    core::JointHold hold;
    bool said = false, holding = true;
  };
  InlineCallbackQueue inline_queue_;  // outlives sub_
  ros::CallbackQueueInterface* queue_ = nullptr;  // the nodelet's: joint states of other processes
  std::mutex mutex_;  // moving_, held_, the counts: joint states against the timers
  std::map<std::string, Moving> moving_;
  std::vector<Held> held_;
  ros::Timer hold_timer_, diag_timer_;
  ros::Duration hold_period_;
  double held_sent_ = -1e300;  // wall time follow() last gave the held joints
  bool slow_hold_ = false;     // the hold timer at 0.5 s: joint states flow
  InputHealth health_;
  core::StampLimits stamp_limits_;
  core::WindowCounter states_in_, transforms_out_;
  double first_state_ = -1.0;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::Duration interval_;
  ros::Publisher tf_pub_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> static_broadcaster_;
  ros::Subscriber sub_;
};

}  // namespace tilt_laser_perception

PLUGINLIB_EXPORT_CLASS(tilt_laser_perception::HeadStatePublisherNodelet, nodelet::Nodelet)
