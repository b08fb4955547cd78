// calibrate's output file: the estimate (the head's errors in the simulator's
// RigErrors convention) and, for the driver, its joint_offset and time_offset
// with the estimate applied. Read by evaluate, group_bag and the launch files.
#pragma once

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>

#include <yaml-cpp/yaml.h>

#include "tilt_laser_perception/core/calibration.hpp"

namespace tilt_laser_perception {
namespace tools {

/// The estimate of a file calibrate wrote (its `estimate` map); throws std::runtime_error.
inline core::HeadCalibration readCalibrationYaml(const std::string& path) {
  YAML::Node n;
  try {
    n = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("cannot read calibration " + path + ": " + e.what());
  }
  const YAML::Node e = n["estimate"];
  if (!e || !e.IsMap()) throw std::runtime_error(path + ": no 'estimate' map (is it calibrate's output?)");
  core::HeadCalibration c;
  const double deg = M_PI / 180.0;
  c.joint_offset = e["joint_offset_deg"].as<double>(0.0) * deg;
  c.time_offset = e["time_offset_ms"].as<double>(0.0) * 1e-3;
  c.mount_roll = e["mount_roll_deg"].as<double>(0.0) * deg;
  c.mount_yaw = e["mount_yaw_deg"].as<double>(0.0) * deg;
  return c;
}

}  // namespace tools
}  // namespace tilt_laser_perception
