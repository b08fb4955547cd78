#include "tilt_laser_perception/sim/walk.hpp"

#include "tilt_laser_perception/sim/options.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace tilt_laser_perception {
namespace sim {

namespace {
constexpr double kGroundStep = 0.01;  // [m]
constexpr double kGroundLength = 100.0;
}  // namespace

WalkModel::WalkModel(const Scene& scene, const WalkParams& params) : p_(params) {
  if (!p_.walking() || !p_.follow_ground) return;
  // The ground under the path: the highest surface at every centimetre (a
  // step's tread, the floor), 0 where there is none.
  const double length = std::min(p_.distance + p_.speed * p_.step_period, kGroundLength);
  const int n = static_cast<int>(std::ceil(length / kGroundStep)) + 2;
  prefix_.assign(n + 1, 0.0);
  for (int k = 0; k < n; ++k) {
    Eigen::Vector2d xy;
    double heading = 0.0;
    path(k * kGroundStep, xy, heading);
    const double z = scene.heightAt(xy.x(), xy.y());
    prefix_[k + 1] = prefix_[k] + (std::isnan(z) ? 0.0 : z);
  }
}

double WalkModel::travelled(double t) const {
  return p_.walking() ? std::clamp(p_.speed * (t - p_.start_time), 0.0, p_.distance) : 0.0;
}

void WalkModel::path(double s, Eigen::Vector2d& p, double& heading) const {
  const double h0 = p_.start.z();
  const Eigen::Vector2d p0 = p_.start.head<2>();
  if (p_.turn_radius == 0.0) {
    heading = h0;
    p = p0 + s * Eigen::Vector2d(std::cos(h0), std::sin(h0));
    return;
  }
  const double R = p_.turn_radius;
  heading = h0 + s / R;
  p = p0 + R * Eigen::Vector2d(std::sin(heading) - std::sin(h0), std::cos(h0) - std::cos(heading));
}

double WalkModel::groundHeight(double s) const {
  if (prefix_.size() < 2) return 0.0;
  // The mean over one step's length about s: the base rises while a foot
  // goes up the step, not at once.
  const int n = static_cast<int>(prefix_.size()) - 1;
  const double half = 0.5 * std::max(p_.speed * p_.step_period, 2 * kGroundStep);
  const int a = std::clamp(static_cast<int>(std::lround((s - half) / kGroundStep)), 0, n - 1);
  const int b = std::clamp(static_cast<int>(std::lround((s + half) / kGroundStep)), a + 1, n);
  return (prefix_[b] - prefix_[a]) / (b - a);
}

Eigen::Isometry3d WalkModel::truePose(double t) const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (!p_.walking()) return T;
  const double s = travelled(t);
  Eigen::Vector2d xy;
  double heading = 0.0;
  path(s, xy, heading);
  // The gait fades in over the first step and out over the last.
  const double step_length = p_.speed * p_.step_period;
  const double envelope = std::clamp(s / step_length, 0.0, 1.0) * std::clamp((p_.distance - s) / step_length, 0.0, 1.0);
  const double step = 2.0 * M_PI * (t - p_.start_time) / p_.step_period, stride = 0.5 * step;
  const Eigen::Vector2d left(-std::sin(heading), std::cos(heading));
  xy += envelope * p_.sway * std::sin(stride) * left;
  const double z = (p_.follow_ground ? groundHeight(s) : 0.0) + envelope * p_.bob * std::sin(step);
  T.translation() = Eigen::Vector3d(xy.x(), xy.y(), z);
  T.linear() = (Eigen::AngleAxisd(heading + envelope * p_.yaw * std::sin(stride), Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(envelope * p_.roll * std::sin(stride), Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return T;
}

Eigen::Isometry3d WalkModel::odomPose(double t) const {
  Eigen::Isometry3d T = truePose(t);
  if (p_.odom_scale_error == 0.0 && p_.odom_yaw_drift == 0.0) return T;
  // Dead reckoning's errors: the distance off by a scale, the heading by an
  // angle that grows with the distance walked (both about the start).
  const double drift = p_.odom_yaw_drift * travelled(t);
  const Eigen::Matrix3d D = Eigen::AngleAxisd(drift, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d start(p_.start.x(), p_.start.y(), 0.0);
  Eigen::Vector3d d = T.translation() - start;
  const double z = d.z();
  d.z() = 0.0;
  T.translation() = start + D * ((1.0 + p_.odom_scale_error) * d) + Eigen::Vector3d(0, 0, z);
  T.linear() = D * T.linear();
  return T;
}

const char* walkOptionsUsage() {
  return "  a walking robot (default: it stands):\n"
         "    --walk SPEED         walk at SPEED m/s         --path straight|turn|step (turn: right, radius 1.2 m;\n"
         "                                                    step: 1.35 m onto the stairs' first tread, then stand)\n"
         "    --turn-radius R      >0 left, <0 right [m]     --walk-distance D  stop after D m\n"
         "    --start X,Y,YAW_DEG  start pose               --step-period S    [s] (0.8)\n"
         "    --bob M, --sway M    gait amplitudes [m] (0.01, 0.03)  --gait-yaw-deg D, --gait-roll-deg D (1.5, 1.0)\n"
         "    --odom-drift PCT[,DEG_PER_M]  odometry's distance error and heading drift\n";
}

bool parseWalkOption(int argc, char** argv, int& i, WalkParams& w) {
  const std::string a = argv[i];
  static const char* with_value[] = {"--walk",  "--path",        "--turn-radius",  "--walk-distance",
                                     "--start", "--step-period", "--bob",          "--sway",
                                     "--gait-yaw-deg", "--gait-roll-deg", "--odom-drift"};
  if (std::find(std::begin(with_value), std::end(with_value), a) == std::end(with_value)) return false;
  if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
  const std::string v = argv[++i];
  const auto number = [&](const std::string& text) { return optionNumber(a, text); };
  const auto list = [&](std::size_t min, std::size_t max) {
    std::vector<double> out;
    std::size_t from = 0;
    while (true) {
      const std::size_t comma = v.find(',', from);
      out.push_back(number(v.substr(from, comma == std::string::npos ? std::string::npos : comma - from)));
      if (comma == std::string::npos) break;
      from = comma + 1;
    }
    if (out.size() < min || out.size() > max) throw std::invalid_argument(a + ": wrong number of values: '" + v + "'");
    return out;
  };
  const auto nonNegative = [&](double x) { return nonNegativeOption(a, x); };
  const double deg = M_PI / 180.0;
  if (a == "--walk") w.speed = nonNegative(number(v));
  else if (a == "--path") {
    if (v == "straight") w.turn_radius = 0.0;
    else if (v == "turn") w.turn_radius = -1.2;
    else if (v == "step") {
      w.turn_radius = 0.0;
      w.distance = 1.35;
    } else throw std::invalid_argument("--path: straight, turn or step, not '" + v + "'");
  } else if (a == "--turn-radius") w.turn_radius = number(v);
  else if (a == "--walk-distance") w.distance = nonNegative(number(v));
  else if (a == "--start") {
    const std::vector<double> s = list(2, 3);
    w.start = Eigen::Vector3d(s[0], s[1], s.size() > 2 ? s[2] * deg : 0.0);
  } else if (a == "--step-period") {
    w.step_period = number(v);
    if (!(w.step_period > 0.0)) throw std::invalid_argument("--step-period must be positive");
  } else if (a == "--bob") w.bob = nonNegative(number(v));
  else if (a == "--sway") w.sway = nonNegative(number(v));
  else if (a == "--gait-yaw-deg") w.yaw = nonNegative(number(v)) * deg;
  else if (a == "--gait-roll-deg") w.roll = nonNegative(number(v)) * deg;
  else {  // --odom-drift
    const std::vector<double> d = list(1, 2);
    w.odom_scale_error = d[0] / 100.0;
    w.odom_yaw_drift = d.size() > 1 ? d[1] * deg : 0.0;
  }
  return true;
}

}  // namespace sim
}  // namespace tilt_laser_perception
