#include "tilt_laser_perception/ros/input_health.hpp"

#include <malloc.h>

#include "tilt_laser_perception/core/load_count.hpp"

namespace tilt_laser_perception {

void InputHealth::init(const std::string& name, double window) {
  // A message far larger than the sensor gives (a scan of 1,000,000 ranges,
  // 4 MB) is refused, but roscpp has already read it into memory. glibc
  // raises its mmap threshold to the largest block freed, so after such a
  // message the next ones come from the heap and their memory stays with the
  // process for good (+107 MB after a few). A fixed threshold keeps blocks
  // of 1 MB and more mapped on their own and returned when freed; the
  // pipeline's own per-scan and per-sweep blocks are smaller.
  static const bool fixed = mallopt(M_MMAP_THRESHOLD, 1 << 20) == 1;
  (void)fixed;
  name_ = name;
  window_ = window;
  refused_ = core::ReasonCounts(window);
  loads_ = countLoad(name);
  loaded_at_ = ros::WallTime::now();
}

int countLoad(const std::string& name) {
  const int loads = core::countLoad(name);
  if (loads > 1) ROS_WARN("%s: loaded for the %d. time in this process", name.c_str(), loads);
  return loads;
}

void addLoadStatus(diagnostic_updater::DiagnosticStatusWrapper& stat, int loads) {
  stat.add("loads in this process (1: never reloaded)", loads);
  stat.addf("process up [s]", "%.1f", core::processUptime());
}

void InputHealth::refuse(const std::string& reason, const std::string& detail, unsigned long k) {
  const unsigned long total = refused_.add(reason, now(), k);
  static constexpr std::size_t kMaxReasons = 64;  // reasons are fixed strings; bound the map anyway
  const ros::WallTime t = ros::WallTime::now();
  auto it = last_warned_.find(reason);
  if (it != last_warned_.end() && (t - it->second).toSec() < 5.0) return;
  if (it == last_warned_.end() && last_warned_.size() >= kMaxReasons) last_warned_.clear();
  last_warned_[reason] = t;
  ROS_WARN("%s: input dropped: %s%s%s (%lu so far)", name_.c_str(), reason.c_str(), detail.empty() ? "" : ": ",
           detail.c_str(), total);
}

bool InputHealth::acceptJointState(const sensor_msgs::JointState& js, const core::StampLimits& limits) {
  if (js.name.size() != js.position.size()) {
    refuse("joint_states: name and position differ in length",
           std::to_string(js.name.size()) + " names, " + std::to_string(js.position.size()) + " positions");
    return false;
  }
  const double t = js.header.stamp.toSec();
  if (const char* bad = core::checkStamp(t, now(), limits)) {
    refuse(std::string("joint_states: ") + bad, std::to_string(t));
    return false;
  }
  return true;
}

bool InputHealth::acceptJointPosition(const sensor_msgs::JointState& js, std::size_t i, bool continuous) {
  if (const char* bad = core::checkJointPosition(js.position[i], continuous)) {
    refuse(std::string("joint_states: ") + bad, js.name[i] + " " + std::to_string(js.position[i]));
    return false;
  }
  return true;
}

unsigned long InputHealth::sequence(const std::string& publisher, std::uint32_t seq) {
  if (gaps_.size() >= 16 && gaps_.find(publisher) == gaps_.end()) gaps_.clear();  // publishers come and go
  return gaps_[publisher].add(seq);
}

unsigned long InputHealth::missedUpstream() const {
  unsigned long n = 0;
  for (const auto& g : gaps_) n += g.second.missed();
  return n;
}

core::Health InputHealth::judge(const core::WindowCounter& in, const core::WindowCounter& out, double first_input,
                               double stale_after, std::string& why) const {
  core::FlowState flow;
  flow.now = now();
  flow.first_input = first_input;
  flow.last_input = in.last();
  flow.last_output = out.last();
  flow.recent_problems = refused_.recent(flow.now);
  return core::judgeFlow(flow, stale_after, why);
}

void InputHealth::report(diagnostic_updater::DiagnosticStatusWrapper& stat, core::Health level,
                         const std::string& why) const {
  using diagnostic_msgs::DiagnosticStatus;
  static const unsigned char kLevel[] = {DiagnosticStatus::OK, DiagnosticStatus::WARN, DiagnosticStatus::ERROR,
                                         DiagnosticStatus::STALE};
  std::string summary = why;
  if (loads_ > 1 && (ros::WallTime::now() - loaded_at_).toSec() < 60.0) {
    summary = "reloaded (load " + std::to_string(loads_) + " in this process); " + why;
    if (level == core::Health::Ok) level = core::Health::Warn;
  }
  stat.summary(kLevel[static_cast<int>(level)], summary);
  addLoadStatus(stat, loads_);
  const double t = now();
  stat.add("inputs dropped (last " + std::to_string(int(window_)) + " s)", refused_.recent(t));
  stat.add("inputs dropped (total)", refused_.total());
  for (const auto& e : refused_.entries(t))
    stat.add("dropped: " + e.reason, std::to_string(e.recent) + " recent, " + std::to_string(e.total) + " total");
  stat.add("scans missed upstream (sequence gaps)", missedUpstream());
}

}  // namespace tilt_laser_perception
