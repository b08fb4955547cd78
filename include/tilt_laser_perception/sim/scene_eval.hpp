/**
 * @file scene_eval.hpp
 * @brief Evaluation of split, grouping and height map on simulated sweeps of
 *        a scene against its ground truth: planes by Hoover et al.'s criteria
 *        (correct, over- and under-segmented, missed, noise at 80 % overlap),
 *        normal and offset errors, edge precision and recall, height map
 *        error and coverage, and the time each stage takes. ROS-free.
 */
#pragma once

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "tilt_laser_perception/core/calibration.hpp"
#include "tilt_laser_perception/core/fused_map.hpp"
#include "tilt_laser_perception/core/height_map.hpp"
#include "tilt_laser_perception/sim/head.hpp"

namespace tilt_laser_perception {
namespace sim {

struct SceneEvalOptions {
  std::string scene = "stairs";
  int sweeps = 3;
  std::uint64_t seed = 1;
  core::TiltProfileParams profile;      ///< default: 10..60 deg at 1 rad/s
  double joint_rate = 200.0;            ///< joint states per second [Hz]
  bool quantize_joint = true;           ///< joint angles in the MX-64's 4096 steps a turn
  double eval_radius = 4.0;             ///< points farther than this (horizontally) are not judged [m]
  double min_face_area = 0.05;          ///< smaller true faces are not expected [m^2]
  int min_face_points = 50;             ///< nor faces seen with fewer points
  double overlap = 0.8;                 ///< Hoover's tolerance
  /// Judge mixed pixels as points of the face their beam's centre hits
  /// (default: not judged, as no face's points).
  bool judge_mixed = false;
  double heightmap_radius = 3.0;        ///< cells farther than this are not judged [m]
  NoiseParams noise;
  /// The echo the pipeline takes (a multi-echo sensor's driver with ~echo):
  /// first is the single-echo range.
  scip::EchoChoice echo = scip::EchoChoice::First;
  RigErrors rig;                        ///< the rig's errors (none by default)
  /// Applied to the believed geometry as the launch files apply calibrate's
  /// output: joint readings + joint_offset, scan stamps - time_offset, the mount on the laser.
  core::HeadCalibration calibration;
  core::SplitParams split;
  core::SweepParams sweep;
  core::HeightMapParams heightmap;     ///< the single sweep's map (its origin relative to the robot's base)
  core::FootParams foot;                ///< the steppable layer's foot (HRP-4's sole)
  WalkParams walk;                      ///< the robot walks (default: it stands)
  /// Each line put in the frame with the odometry's pose at its own time
  /// (false: every line of a sweep with the pose of the sweep's end, as one
  /// look-up a sweep gives).
  bool pose_per_line = true;
  core::FusedMapParams fused;           ///< the map fused over sweeps (judged beside the single sweep's)
  double front_length = 1.0;            ///< "in front of the feet": this far ahead of the base ... [m]
  double front_width = 1.0;             ///< ... and this wide [m]
  std::string head_file;                ///< empty: config/head.yaml
  std::string dump_prefix;              ///< non-empty: the last sweep's planes and height map go to PREFIX_*
  /// Another segmentation to judge in place of the grouping's planes (for
  /// comparisons, e.g. PCL's): given the assembled sweep, one label per point
  /// (labels[line][beam], an index into planes or -1) and the planes (normal
  /// and centroid used). Its time goes to SweepEval::external_ms.
  std::function<void(const core::SweepResult&, std::vector<std::vector<int>>& labels, std::vector<core::Plane>& planes)>
      segmenter;
  /// Called with every joint reading (as the assembler takes it) and every
  /// finished sweep (before it is judged): for the calibration's tests and benchmark.
  std::function<void(double t, double q)> on_joint;
  std::function<void(const core::SweepResult&)> on_sweep;
};


/// Writes a sweep's planes (PREFIX_planes.csv: one row per plane, then its
/// boundary vertices) and height map (PREFIX_heightmap.bin: float32 heights,
/// row-major; PREFIX_heightmap.txt: origin_x origin_y resolution width height,
/// then a line "robot X Y YAW_RAD FRAME WHAT": where the base was, the map's
/// frame, and "fused" or "sweep").
void dumpSweep(const core::SweepResult& sweep, const core::HeightMapGrid& grid, const std::string& prefix,
               const Eigen::Isometry3d& robot = Eigen::Isometry3d::Identity(), const std::string& frame = "base_footprint",
               bool fused = false);

struct SweepEval {
  int lines = 0, planes = 0, true_faces = 0;
  int correct = 0, over = 0, under = 0, missed = 0, noise = 0;
  double normal_err_deg = 0.0, offset_err_m = 0.0;  ///< means over correct planes
  double edge_precision = 0.0, edge_recall = 0.0;
  double heightmap_rmse_m = 0.0, heightmap_coverage = 0.0;  ///< the sweep's own map, within heightmap_radius of the base
  /// The same over the cells of walkable surfaces away from their edges (the
  /// true heights 5 cm away along x and y within the walkable slope), of the
  /// sweep's map and of the fused one.
  double walkable_rmse_m = 0.0, fused_walkable_rmse_m = 0.0;
  /// Of the fused map's walkable cells, the share whose error exceeds twice
  /// the sigma it states for them (its uncertainty layer): honest, about 5 %.
  double fused_overconfident = 0.0;
  double overconfident = 0.0;  ///< the same of the sweep's own map (its sigmas: core::sweepUncertainty)
  /// The sweep map's step edges against the true ones (a true edge: a rise
  /// between obstacle_min_height and max_step_height with 3 cm flat on each
  /// side, in view: two of the sweep's lines fell on its higher surface
  /// within 10 cm of it; the map's: where its heights pass the mid height
  /// along the same row or column, within 10 cm, else 10 cm; measured across
  /// the edge): median and 95th percentile over each centimetre of edge the
  /// map shows [m]; NaN when none is in view.
  double step_edge_median_m = std::numeric_limits<double>::quiet_NaN(), step_edge_p95_m = step_edge_median_m;
  /// Of the step edges in view, the share the map does not show: it knows no
  /// cell of the row within 10 cm on either side (unknown, which a planner
  /// does not step on; no place to judge). NaN when none is in view.
  double step_edge_unknown = std::numeric_limits<double>::quiet_NaN();
  /// The share of the sweep's known cells whose true surface the sensor could
  /// not see (hidden by something nearer along its ray): cells invented.
  double invented = 0.0;
  /// The steppable layer (core::steppableCells, SceneEvalOptions::foot)
  /// against the truth (a foot's disc on one true plane within its tilt):
  /// the share of the cells it calls steppable that are, and of the truly
  /// steppable cells whose foot's disc it knows cell by cell (within the
  /// map's radius) that it finds.
  double steppable_precision = 0.0, steppable_recall = 0.0;
  double front_coverage = 0.0;        ///< the sweep's own map, in front of the feet (front_length x front_width)
  double fused_rmse_m = 0.0, fused_coverage = 0.0, fused_front_coverage = 0.0;  ///< the same of the fused map
  /// The front's cells (with a true height) that a point of this sweep or of
  /// an earlier one not yet forgotten fell in, at the fused map's cells: what
  /// the points alone reach (the maps' polygons fill the gaps between lines too).
  double front_observable = 0.0;
  double fused_ms = 0.0;              ///< time to fuse the sweep into the fused map (its own map included)
  double travelled_m = 0.0;           ///< how far the robot had walked at the sweep's end
  double split_ms = 0.0, group_ms = 0.0, latency_ms = 0.0;
  double external_ms = 0.0;               ///< SceneEvalOptions::segmenter's time
  int veil_segments = 0;                  ///< segments most of whose points are mixed pixels (truth)
  int overhanging_segments = 0;           ///< segments with own points more than 1 cm beyond their ends
  int mixed_pixels = 0;                   ///< beams whose range lies between two faces (truth)
  int mixed_in_segments = 0;              ///< of them, those the split put in a segment
  std::vector<std::string> missed_faces;  ///< the faces missed: "object/label (N points: where they went)"
  /// For each missed face, the segments on it or in a plane that took its
  /// points: "line L beams A-B (N points, mostly FACE) -> plane P".
  std::vector<std::string> missed_segments;
  /// The planes counted as noise: "plane P (N points: object/label:count ..., none:count), lines A-B".
  std::vector<std::string> noise_planes;
};

/// Simulates `sweeps` sweeps (after the first reversal) and judges each.
std::vector<SweepEval> evaluateScene(const SceneEvalOptions& options);

/// The header and a row of the per-sweep CSV, and the summary line (means over sweeps).
std::string evalCsvHeader();
std::string evalCsvRow(int sweep, const SweepEval& e);
std::string evalSummary(const std::vector<SweepEval>& evals);

}  // namespace sim
}  // namespace tilt_laser_perception
