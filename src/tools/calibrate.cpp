// The head calibrates itself from a recording: the tilt joint's zero offset,
// the servo-to-laser time offset and the laser's roll and yaw on the tilt
// link (core/calibration.hpp), from a few sweeps up and down of a robot
// standing on a flat floor with walls or boxes in view.
//   calibrate BAG [--urdf FILE] [--out FILE.yaml] [--out-urdf FILE] [--driver-params FILE]
//             [--no-floor] [--hold NAME[,NAME]] [--passes N] [--frame F] [--joint J] [--laser L]
// Prints one line (joint_offset_deg= time_offset_ms= mount_roll_deg=
// mount_yaw_deg= plane_rms_before_m= plane_rms_after_m=, with the standard
// errors) and the notes on what the recording could not tell. --out writes
// the YAML that hrp4.launch takes (calibration:=FILE): the driver's
// joint_offset and time_offset (those of --driver-params, default
// config/driver.yaml, with the estimate applied) and the estimate itself;
// --out-urdf the URDF with the laser's mount corrected (urdf:=FILE).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <urdf/model.h>
#include <yaml-cpp/yaml.h>

#include "bag_pipeline.hpp"
#include "calibration_yaml.hpp"
#include "tilt_laser_perception/ros/conversions.hpp"
#include "tilt_laser_perception/sim/scene.hpp"

using namespace tilt_laser_perception;

namespace {
constexpr double kDeg = M_PI / 180.0;

void usage() {
  std::fprintf(stderr,
               "usage: calibrate BAG [--urdf FILE] [--out FILE.yaml] [--out-urdf FILE] [--driver-params FILE]\n"
               "                 [--no-floor] [--hold NAME[,NAME]] [--passes N] [--frame F] [--joint J] [--laser L]\n"
               "                 [--spin-span RAD]\n"
               "  NAME: joint_offset, time_offset, mount_roll, mount_yaw (held at zero, not estimated)\n"
               "  --passes 2 (default): a second pass over the recording with the first estimate applied\n"
               "  --no-floor: the robot does not stand on a floor at z = 0 of the frame (the joint offset is then held)\n"
               "  --spin-span RAD: a spinning head's recording, a sweep each RAD of the joint (pi: a half turn; the\n"
               "                   time offset is then held: turning one way, it is a joint offset at that rate)\n");
}

/// The URDF's text with the origin of the laser's own joint rotated by the mount correction.
bool correctedUrdf(const std::string& path, const std::string& laser, const core::HeadCalibration& c, std::string& text,
                   std::string& error) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  text = ss.str();
  urdf::Model model;
  if (!model.initString(text)) {
    error = "cannot parse URDF " + path;
    return false;
  }
  const urdf::LinkConstSharedPtr link = model.getLink(laser);
  if (!link || !link->parent_joint || link->parent_joint->type != urdf::Joint::FIXED) {
    error = "the laser frame '" + laser + "' has no fixed joint of its own to correct";
    return false;
  }
  const urdf::Pose& o = link->parent_joint->parent_to_joint_origin_transform;
  const Eigen::Matrix3d R = toIsometry(o).linear() * c.mount().linear();
  // URDF rpy: R = Rz(yaw) Ry(pitch) Rx(roll), pitch within +-90 degrees
  const double roll = std::atan2(R(2, 1), R(2, 2)), pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0)),
               yaw = std::atan2(R(1, 0), R(0, 0));
  char origin[256];
  std::snprintf(origin, sizeof(origin), "<origin xyz=\"%.6g %.6g %.6g\" rpy=\"%.9g %.9g %.9g\"/>", o.position.x,
                o.position.y, o.position.z, roll, pitch, yaw);
  const std::string name = link->parent_joint->name;
  std::size_t j = text.find("name=\"" + name + "\"");
  if (j == std::string::npos) j = text.find("name='" + name + "'");
  const std::size_t end = j == std::string::npos ? j : text.find("</joint>", j);
  const std::size_t a = j == std::string::npos ? j : text.find("<origin", j);
  if (a == std::string::npos || a > end) {
    // no origin element: add one
    if (end == std::string::npos) {
      error = "cannot find joint '" + name + "' in " + path;
      return false;
    }
    text.insert(end, std::string("  ") + origin + "\n  ");
    return true;
  }
  const std::size_t b = text.find('>', a);
  text.replace(a, b - a + 1, origin);
  return true;
}
}  // namespace

int main(int argc, char** argv) {
  tools::BagPipelineOptions o;
  o.sweep.max_lines = 5000;
  o.urdf = sim::configDirectory() + "/../urdf/hrp4_head.urdf";
  std::string out, out_urdf, driver_params = sim::configDirectory() + "/driver.yaml";
  core::CalibrationOptions co;
  int passes = 2;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      const bool v = i + 1 < argc;
      if (tools::parseBagOption(argc, argv, i, o)) continue;
      if (a == "--out" && v) out = argv[++i];
      else if (a == "--out-urdf" && v) out_urdf = argv[++i];
      else if (a == "--driver-params" && v) driver_params = argv[++i];
      else if (a == "--no-floor") co.floor = false;
      else if (a == "--passes" && v) passes = std::max(1, std::atoi(argv[++i]));
      else if (a == "--hold" && v) {
        std::stringstream names(argv[++i]);
        std::string n;
        while (std::getline(names, n, ',')) {
          int k = 0;
          while (k < core::HeadCalibration::kParams && n != core::HeadCalibration::name(k)) ++k;
          if (k == core::HeadCalibration::kParams) throw std::runtime_error("--hold: no parameter '" + n + "'");
          co.estimate[k] = false;
        }
      } else if (a[0] != '-' && o.bag.empty()) o.bag = a;
      else {
        usage();
        return a == "-h" || a == "--help" ? 0 : 2;
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calibrate: %s\n", e.what());
    return 2;
  }
  if (o.bag.empty()) {
    usage();
    return 2;
  }
  const auto t_start = std::chrono::steady_clock::now();
  core::HeadCalibration total;
  core::CalibrationResult res;
  bool held_now = false;  // a pass held what an earlier one had estimated (and applied): one more pass without it
  for (int pass = 0; pass < passes || (held_now && pass < passes + 2); ++pass) {
    o.calibration = total;
    // The calibrator's chain has the base folded in: it is known once tf gave the first pose.
    std::unique_ptr<core::HeadCalibrator> cal;
    std::vector<std::pair<double, double>> early;
    tools::BagPipelineResult r;
    const auto on_joint = [&](double t, double q) {
      if (cal) cal->addJoint(t, q);
      else early.emplace_back(t, q);
    };
    const auto on_sweep = [&](const core::SweepResult& sw) {
      if (!cal) {
        core::TiltChain chain = r.chain;
        chain.base_to_joint = r.base * chain.base_to_joint;
        cal = std::make_unique<core::HeadCalibrator>(chain, co);
        for (const auto& [t, q] : early) cal->addJoint(t, q);
      }
      cal->addSweep(sw);
    };
    std::string error;
    if (!tools::runBagPipeline(o, on_joint, on_sweep, r, error)) {
      std::fprintf(stderr, "calibrate: %s\n", error.c_str());
      return 1;
    }
    if (!cal) {
      std::fprintf(stderr, "calibrate: no sweep in %s (%d scans): %s\n", o.bag.c_str(), r.scans,
                   tools::noSweepReason(o, r).c_str());
      return 1;
    }
    const core::CalibrationResult pr = cal->solve();
    if (!pr.ok) {
      std::fprintf(stderr, "calibrate: pass %d: no estimate:", pass + 1);
      for (const auto& n : pr.notes) std::fprintf(stderr, " %s;", n.c_str());
      std::fprintf(stderr, "\n");
      return 1;
    }
    const double rms_before = pass == 0 ? pr.rms_before : res.rms_before;
    std::fprintf(stderr, "pass %d: %d sweeps (%d up), %d surfaces, %d points (%d on the floor): %s\n", pass + 1,
                 pr.sweeps, pr.up_sweeps, pr.surfaces, pr.points, pr.floor_points,
                 core::HeadCalibrator::summary(pr).c_str());
    const auto estimated = pass == 0 ? pr.estimated : res.estimated;
    std::vector<std::string> notes = res.notes;  // every pass's, once each
    for (const auto& n : pr.notes)
      if (std::find(notes.begin(), notes.end(), n) == notes.end()) notes.push_back(n);
    res = pr;
    res.notes = notes;
    res.rms_before = rms_before;
    // The pass estimates what is left after the previous ones: small angles
    // add. What one pass could not tell is not applied.
    held_now = false;
    for (int k = 0; k < core::HeadCalibration::kParams; ++k) {
      res.estimated[k] = estimated[k] && pr.estimated[k];
      held_now |= total[k] != 0.0 && !res.estimated[k];
      total[k] = res.estimated[k] ? total[k] + pr.calibration[k] : 0.0;
      co.estimate[k] = co.estimate[k] && res.estimated[k];  // held stays held
    }
  }
  res.calibration = total;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  std::printf("%s\n", core::HeadCalibrator::summary(res).c_str());
  for (const auto& n : res.notes) std::printf("note: %s\n", n.c_str());
  std::printf("calibrate: %d sweeps, %d points, %.1f s\n", res.sweeps, res.points, seconds);

  if (!out.empty()) {
    double joint_offset = 0.0, time_offset = 0.0;
    try {
      const YAML::Node d = YAML::LoadFile(driver_params);
      joint_offset = d["joint_offset"].as<double>(0.0);
      time_offset = d["time_offset"].as<double>(0.0);
    } catch (const YAML::Exception& e) {
      std::fprintf(stderr, "calibrate: cannot read %s (%s): the driver's offsets taken as 0\n", driver_params.c_str(),
                   e.what());
    }
    std::FILE* f = std::fopen(out.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "calibrate: cannot write %s\n", out.c_str());
      return 1;
    }
    const std::time_t now = std::time(nullptr);
    char when[64];
    std::strftime(when, sizeof(when), "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    std::fprintf(f, "# calibrate %s, %s\n# %s\n", o.bag.c_str(), when, core::HeadCalibrator::summary(res).c_str());
    for (const auto& n : res.notes) std::fprintf(f, "# note: %s\n", n.c_str());
    std::fprintf(f,
                 "# The driver's parameters (%s's, the estimate applied); hrp4.launch calibration:=THIS_FILE loads them.\n"
                 "joint_offset: %.9g   # [rad] %s + %.6f deg\n"
                 "time_offset: %.9g    # [s] %s - %.4f ms\n",
                 driver_params.c_str(), joint_offset + total.joint_offset, "previous", total.joint_offset / kDeg,
                 time_offset - total.time_offset, "previous", total.time_offset * 1e3);
    std::fprintf(f,
                 "# The head's errors found (as the simulator's rig errors define them); the mount goes in the URDF\n"
                 "# (calibrate --out-urdf). evaluate, group_bag: --calibration THIS_FILE.\n"
                 "estimate:\n  joint_offset_deg: %.6f\n  time_offset_ms: %.4f\n  mount_roll_deg: %.6f\n"
                 "  mount_yaw_deg: %.6f\n",
                 total.joint_offset / kDeg, total.time_offset * 1e3, total.mount_roll / kDeg, total.mount_yaw / kDeg);
    std::fprintf(f, "standard_error:\n  joint_offset_deg: %.6f\n  time_offset_ms: %.4f\n  mount_roll_deg: %.6f\n"
                 "  mount_yaw_deg: %.6f\n",
                 res.standard_error.joint_offset / kDeg, res.standard_error.time_offset * 1e3,
                 res.standard_error.mount_roll / kDeg, res.standard_error.mount_yaw / kDeg);
    std::fprintf(f, "plane_rms_before_m: %.5f\nplane_rms_after_m: %.5f\n", res.rms_before, res.rms_after);
    std::fclose(f);
    std::printf("wrote %s\n", out.c_str());
  }
  if (!out_urdf.empty()) {
    std::string text, error;
    if (!correctedUrdf(o.urdf, o.laser, total, text, error)) {
      std::fprintf(stderr, "calibrate: %s\n", error.c_str());
      return 1;
    }
    std::ofstream(out_urdf) << text;
    std::printf("wrote %s (the laser's mount corrected)\n", out_urdf.c_str());
  }
  return 0;
}
