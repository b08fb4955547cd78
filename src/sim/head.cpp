#include "tilt_laser_perception/sim/head.hpp"
#include "tilt_laser_perception/sim/options.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

namespace tilt_laser_perception {
namespace sim {

ServoModel::ServoModel(double initial_position, double t0) : t_(t0), pos_(initial_position), goal_(initial_position) {
  history_.emplace_back(t0, initial_position);
}

void ServoModel::advance(double t) {
  constexpr double dt_max = 0.001;
  while (t_ < t) {
    const double dt = std::min(dt_max, t - t_);
    if (torque_ && velocity_mode_) {
      // Wheel or velocity control: towards the goal velocity at the acceleration limit.
      const double dv = std::clamp(wheel_ - vel_, -amax_ * dt, amax_ * dt);
      pos_ += (vel_ + 0.5 * dv) * dt;
      vel_ += dv;
    } else if (torque_) {
      const double d = goal_ - pos_;
      if (std::abs(d) < 1e-6 && std::abs(vel_) < amax_ * dt) {
        pos_ = goal_;
        vel_ = 0.0;
      } else {
        // Fastest speed from which the goal can still be reached with the acceleration limit.
        const double v_des = std::copysign(std::min(vmax_, std::sqrt(2.0 * amax_ * std::abs(d))), d);
        const double dv = std::clamp(v_des - vel_, -amax_ * dt, amax_ * dt);
        const double v_new = vel_ + dv;
        const double step = 0.5 * (vel_ + v_new) * dt;
        if ((d > 0 && step >= d) || (d < 0 && step <= d)) {  // arrives within this step
          pos_ = goal_;
          vel_ = 0.0;
        } else {
          pos_ += step;
          vel_ = v_new;
        }
      }
    } else {
      const double dv = std::clamp(-vel_, -amax_ * dt, amax_ * dt);
      pos_ += (vel_ + 0.5 * dv) * dt;
      vel_ += dv;
    }
    t_ += dt;
    history_.emplace_back(t_, pos_);
  }
  while (history_.size() > 2 && history_.front().first < t_ - 5.0) history_.pop_front();
}

void ServoModel::setGoal(double t, double goal) {
  std::lock_guard<std::mutex> l(mutex_);
  advance(t);
  goal_ = goal;
  velocity_mode_ = false;
}

void ServoModel::setGoalVelocity(double t, double w) {
  std::lock_guard<std::mutex> l(mutex_);
  advance(t);
  wheel_ = std::clamp(w, -kMaxVelocity, kMaxVelocity);
  velocity_mode_ = true;
}

void ServoModel::wrapToOneTurn(double t) {
  std::lock_guard<std::mutex> l(mutex_);
  advance(t);
  pos_ = std::remainder(pos_, 2.0 * M_PI);
  goal_ = pos_;
  velocity_mode_ = false;
  history_.assign(1, {t_, pos_});
}

void ServoModel::setVelocityLimit(double t, double v) {
  std::lock_guard<std::mutex> l(mutex_);
  advance(t);
  vmax_ = (v <= 0.0 || v > kMaxVelocity) ? kMaxVelocity : v;
}

void ServoModel::setAccelerationLimit(double t, double a) {
  std::lock_guard<std::mutex> l(mutex_);
  advance(t);
  amax_ = (a <= 0.0 || !std::isfinite(a) || a > 200.0) ? 200.0 : a;
}

void ServoModel::setTorque(double t, bool on) {
  std::lock_guard<std::mutex> l(mutex_);
  advance(t);
  torque_ = on;
  if (on) goal_ = pos_;
  if (on) wheel_ = 0.0;
}

double ServoModel::velocityLimit() const {
  std::lock_guard<std::mutex> l(mutex_);
  return vmax_;
}

ServoModel::State ServoModel::state(double t) {
  std::lock_guard<std::mutex> l(mutex_);
  advance(t);
  State s;
  s.position = pos_;
  s.velocity = vel_;
  s.goal = goal_;
  s.moving = std::abs(vel_) > 1e-3 || (torque_ && (velocity_mode_ ? wheel_ != 0.0 : std::abs(goal_ - pos_) > 1e-4));
  s.torque = torque_;
  if (t < t_) s.position = historyAt(t);
  return s;
}

double ServoModel::positionAt(double t) {
  std::lock_guard<std::mutex> l(mutex_);
  if (t >= t_) {
    advance(t);
    return pos_;
  }
  return historyAt(t);
}

double ServoModel::reading(double t) {
  const double p = positionAt(t);
  std::lock_guard<std::mutex> l(mutex_);
  if (reading_sigma_ <= 0.0) return p;
  return p + reading_sigma_ * std::normal_distribution<double>(0.0, 1.0)(reading_rng_);
}

void ServoModel::setReadingNoise(double sigma, std::uint64_t seed) {
  std::lock_guard<std::mutex> l(mutex_);
  reading_sigma_ = sigma;
  reading_rng_.seed(seed);
}

double ServoModel::historyAt(double t) const {
  if (t <= history_.front().first) return history_.front().second;
  // Samples are 1 ms apart: find the pair around t.
  auto it = std::lower_bound(history_.begin(), history_.end(), t,
                             [](const std::pair<double, double>& s, double v) { return s.first < v; });
  if (it == history_.begin()) return it->second;
  const auto& b = *it;
  const auto& a = *(it - 1);
  const double w = (t - a.first) / (b.first - a.first);
  return a.second + w * (b.second - a.second);
}

core::TiltChain HeadGeometry::chain() const {
  core::TiltChain c;
  c.base_to_joint = Eigen::Isometry3d::Identity();
  c.base_to_joint.translation() = axis_origin;
  c.joint_to_laser = Eigen::Isometry3d::Identity();
  c.joint_to_laser.translation() = laser_offset;
  if (spinning) {
    c.base_to_joint.rotate(Eigen::AngleAxisd(spin_pitch, Eigen::Vector3d::UnitY()));
    c.base_to_joint.rotate(Eigen::AngleAxisd(tilt_offset, Eigen::Vector3d::UnitX()));
    c.axis = Eigen::Vector3d::UnitX();
    c.joint_to_laser.rotate(Eigen::AngleAxisd(laser_to_axis, Eigen::Vector3d::UnitY()));
  } else {
    c.base_to_joint.rotate(Eigen::AngleAxisd(tilt_offset, Eigen::Vector3d::UnitY()));
    c.axis = Eigen::Vector3d::UnitY();
  }
  return c;
}

Eigen::Isometry3d HeadGeometry::laserPose(double tilt) const { return chain().laserPose(tilt); }

HeadGeometry HeadGeometry::load(const std::string& path) {
  HeadGeometry g;
  YAML::Node n;
  try {
    n = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("cannot read head geometry " + path + ": " + e.what());
  }
  const auto vec3 = [&](const char* key, Eigen::Vector3d& v) {
    if (!n[key]) return;
    if (!n[key].IsSequence() || n[key].size() != 3) throw std::runtime_error(path + ": " + key + " needs 3 numbers");
    v = Eigen::Vector3d(n[key][0].as<double>(), n[key][1].as<double>(), n[key][2].as<double>());
  };
  vec3("axis_origin", g.axis_origin);
  vec3("laser_offset", g.laser_offset);
  if (n["tilt_offset_deg"]) g.tilt_offset = n["tilt_offset_deg"].as<double>() * M_PI / 180.0;
  if (n["spinning"]) g.spinning = n["spinning"].as<bool>();
  if (n["spin_pitch_deg"]) g.spin_pitch = n["spin_pitch_deg"].as<double>() * M_PI / 180.0;
  if (n["laser_to_axis_deg"]) g.laser_to_axis = n["laser_to_axis_deg"].as<double>() * M_PI / 180.0;
  return g;
}

void setRealistic(RigErrors& rig, NoiseParams& noise) {
  const double deg = M_PI / 180.0;
  rig.tilt_noise = 0.5 * 2.0 * M_PI / 4096.0;  // half an encoder step
  rig.quantize = true;
  rig.backlash = 0.3 * deg;
  rig.time_offset = 0.005;
  rig.line_jitter = 0.001;
  rig.joint_offset = 0.5 * deg;
  rig.mount_roll = 0.3 * deg;
  rig.mount_yaw = 0.3 * deg;
  noise.footprint = 1.0 * deg;
}

const char* rigOptionsUsage() {
  return "  rig errors (the truth's departures from head.yaml; default none):\n"
         "    --tilt-noise-deg S   joint reading noise (sigma)     --backlash-deg B   gear play (full width)\n"
         "    --time-offset-ms T   scan stamp minus true time      --line-jitter-ms J per-scan stamp error (sigma)\n"
         "    --joint-offset-deg O true minus reported tilt       --mount-error-deg R[,Y] laser roll (and yaw) on its link\n"
         "    --footprint-deg F    beam footprint (mixed pixels over several beams)\n"
         "    --rain P             chance per beam of a drop between 0.3 and 4 m (a weak first echo)\n"
         "    --realistic          a real rig's set (doc/simulator.md); options after it change single values\n";
}

bool parseRigOption(int argc, char** argv, int& i, RigErrors& rig, NoiseParams& noise) {
  const std::string a = argv[i];
  const double deg = M_PI / 180.0;
  if (a == "--realistic") {
    setRealistic(rig, noise);
    return true;
  }
  static const char* with_value[] = {"--tilt-noise-deg", "--backlash-deg", "--time-offset-ms", "--line-jitter-ms",
                                     "--joint-offset-deg", "--mount-error-deg", "--footprint-deg", "--rain"};
  if (std::find(std::begin(with_value), std::end(with_value), a) == std::end(with_value)) return false;
  if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
  const std::string v = argv[++i];
  const auto number = [&](const std::string& text) { return optionNumber(a, text); };
  const auto nonNegative = [&](double x) { return nonNegativeOption(a, x); };
  if (a == "--tilt-noise-deg") rig.tilt_noise = nonNegative(number(v)) * deg;
  else if (a == "--backlash-deg") rig.backlash = nonNegative(number(v)) * deg;
  else if (a == "--time-offset-ms") rig.time_offset = number(v) * 1e-3;
  else if (a == "--line-jitter-ms") rig.line_jitter = nonNegative(number(v)) * 1e-3;
  else if (a == "--joint-offset-deg") rig.joint_offset = number(v) * deg;
  else if (a == "--footprint-deg") noise.footprint = nonNegative(number(v)) * deg;
  else if (a == "--rain") {
    noise.rain_probability = nonNegative(number(v));
    if (noise.rain_probability > 1.0) throw std::invalid_argument("--rain is a probability (0..1)");
  }
  else {  // --mount-error-deg R or R,Y
    const std::size_t comma = v.find(',');
    rig.mount_roll = number(v.substr(0, comma)) * deg;
    rig.mount_yaw = comma == std::string::npos ? rig.mount_roll : number(v.substr(comma + 1)) * deg;
  }
  return true;
}

SweepController::SweepController(ServoModel& servo, const core::TiltProfileParams& params)
    : servo_(servo), profile_(params) {
  servo_.setAccelerationLimit(0.0, params.acceleration);
}

bool SweepController::update(double t, core::Sweep* sweep) {
  core::TiltCommand cmd;
  core::Sweep done;
  bool ended = false;
  if (profile_.update(t, servo_.state(t).position, cmd, done, &ended)) {
    servo_.setVelocityLimit(t, cmd.velocity);
    servo_.setGoal(t, cmd.goal);
  }
  if (ended && sweep) *sweep = done;
  return ended;
}

HeadSimulator::HeadSimulator(const Scene& scene, const HeadGeometry& head, ServoModel& servo,
                             const NoiseParams& noise, std::uint64_t seed, const LidarModel& model, const RigErrors& rig)
    : scene_(scene), head_(head), servo_(servo), lidar_(scene, model, noise, seed), rig_(rig), mount_(rig.calibration().mount()),
      rng_(seed ^ 0x5eedf00dULL) {
  if (rig_.tilt_noise > 0.0) servo_.setReadingNoise(rig_.tilt_noise, seed ^ 0x7e57ULL);
}

void HeadSimulator::scan(double t0, HeadScan& out) {
  const LidarModel& m = lidar_.model();
  // The true time of beam 0: the stamp less its offset and this line's jitter.
  double start = t0 - rig_.time_offset;
  if (rig_.line_jitter > 0.0) start += rig_.line_jitter * std::normal_distribution<double>(0.0, 1.0)(rng_);
  out.tilt.resize(m.beams);
  const double half_play = 0.5 * rig_.backlash;
  for (int i = 0; i < m.beams; ++i) {
    const double horn = servo_.positionAt(start + m.beamTime(i));
    // Gear play: the laser stays where it is until the horn pushes it.
    if (!load_set_) {
      load_ = horn;
      load_set_ = true;
    }
    load_ = std::clamp(load_, horn - half_play, horn + half_play);
    out.tilt[i] = static_cast<float>(load_ + rig_.joint_offset);
  }
  const bool mounted_off = rig_.mount_roll != 0.0 || rig_.mount_yaw != 0.0;
  const PoseFunction pose = [&](double t) {
    const int i = static_cast<int>(std::lround((t - t0) / m.timeIncrement()));
    const double tilt = (i >= 0 && i < m.beams) ? out.tilt[i] : servo_.positionAt(t - rig_.time_offset) + rig_.joint_offset;
    const Eigen::Isometry3d laser = mounted_off ? Eigen::Isometry3d(head_.laserPose(tilt) * mount_) : head_.laserPose(tilt);
    return walk_ ? Eigen::Isometry3d(walk_->truePose(t - t0 + start) * laser) : laser;
  };
  lidar_.scan(t0, pose, out.scan);
}

std::vector<float> trueHeightMap(const Scene& scene, double ox, double oy, double r, int width, int height) {
  std::vector<float> h(static_cast<std::size_t>(width) * height);
  for (int iy = 0; iy < height; ++iy)
    for (int ix = 0; ix < width; ++ix)
      h[static_cast<std::size_t>(iy) * width + ix] = static_cast<float>(scene.heightAt(ox + (ix + 0.5) * r, oy + (iy + 0.5) * r));
  return h;
}

}  // namespace sim
}  // namespace tilt_laser_perception
