// The offline pipeline over a recording, shared by group_bag and calibrate:
// the rig's chain from its URDF, the base's pose from the bag's tf, each scan
// split and assembled into sweeps as the nodelets do, with a calibration
// (calibrate's output) applied as the launch files apply it.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "tilt_laser_perception/core/calibration.hpp"
#include "tilt_laser_perception/core/sweep.hpp"

namespace tilt_laser_perception {
namespace tools {

struct BagPipelineOptions {
  std::string bag, urdf, frame = "base_footprint", joint = "head_tilt_joint", laser = "laser";
  core::SweepParams sweep;
  core::HeadCalibration calibration;  ///< joint + joint_offset, stamps - time_offset, the mount on the laser
};

struct BagPipelineResult {
  int scans = 0, sweeps = 0;
  int joint_states = 0;                 ///< joint states of the tilt joint
  std::vector<std::string> joint_names; ///< the joints the recording names (the first few)
  bool closed_by_end = false;           ///< the last sweep was closed by the recording's end, not a reversal
  core::SweepCounters counters;
  std::string last_warning;
  core::TiltChain chain;          ///< the URDF's, calibration applied
  /// The chain's base in the assembly frame (the last pose tf gave: a standing robot's).
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
};

/// Runs the pipeline; false with a message in `error` when the URDF or the bag cannot be read.
bool runBagPipeline(const BagPipelineOptions& o, const std::function<void(double t, double q)>& on_joint,
                    const std::function<void(const core::SweepResult&)>& on_sweep, BagPipelineResult& result,
                    std::string& error);

/// Why a run gave no sweep, in words a user can act on (empty when it gave one).
std::string noSweepReason(const BagPipelineOptions& o, const BagPipelineResult& r);

/// Parses the options shared by the tools (--urdf --frame --joint --laser --calibration FILE, --spin-span RAD,
/// --reverse) at argv[i];
/// false if not one; throws std::runtime_error on a calibration file it cannot read.
bool parseBagOption(int argc, char** argv, int& i, BagPipelineOptions& o);

}  // namespace tools
}  // namespace tilt_laser_perception
