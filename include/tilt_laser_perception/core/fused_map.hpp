/**
 * @file fused_map.hpp
 * @brief A robot-centric height map fused over sweeps, for a robot that walks:
 *        a square grid in a fixed frame (odom) whose centre follows the
 *        robot (its cells shifted when the robot moves a cell, never
 *        recomputed); every cell keeps its height, an uncertainty that grows
 *        with the range it was seen from and with the distance walked since
 *        (odometry drifts), and when it was seen. Each sweep's own height map
 *        (buildHeightMap on the same cells) is fused in: a new height that
 *        agrees with the old within `gate` standard deviations is averaged
 *        with it by their variances, one that does not replaces it (the
 *        newest sweep wins where they disagree: something moved, or the old
 *        one was wrong); a cell it made no height for but whose points
 *        disagree with the old height (below it: a ray went through; above
 *        it: something stands there) is forgotten. Cells not seen for `forget_time` are forgotten. The
 *        walkable planes keep their ids from sweep to sweep (a new plane
 *        takes the id of the old one its cells agree with), so a planner can
 *        step on a tread after it left the laser's view. ROS-free; [m], [s].
 */
#pragma once

#include <cmath>
#include <map>
#include <vector>

#include "tilt_laser_perception/core/height_map.hpp"

namespace tilt_laser_perception {
namespace core {

struct FusedMapParams {
  double size = 6.0;              ///< side of the square grid, centred on the robot [m]
  /// Cell side [m]; 0: the sweep's own map's (HeightMapParams::resolution).
  /// 2 cm: a quarter of 1 cm's cells (bench_sweep's fused_ms 1.0-1.2 ms against
  /// 2.3 ms for the code with 1 cm cells in the same runs; evaluate's 0.56 against
  /// 2.04 ms), for about 0.1 cm more RMSE (doc/notes/walking.md).
  double resolution = 0.02;
  double forget_time = 30.0;      ///< cells and planes not seen for this long are forgotten [s]
  double sigma_min = 0.005;       ///< a cell's height uncertainty seen from up close [m, sigma] ...
  double sigma_range = 0.003;     ///< ... and per metre of range [1] (the two added in quadrature)
  double drift_per_metre = 0.01;  ///< odometry's error per metre walked since a cell was seen [1]
  /// The head's own pose error common to every sweep (the joint's zero, the
  /// laser's mount, the time offset: what calibration leaves) [rad, sigma]:
  /// a cell seen from a horizontal distance d is off by about d x this in
  /// height in every sweep alike, so fusing sweeps does not shrink it. 0.5
  /// degrees: a head not calibrated (the simulator's --realistic rig is 0.5
  /// degrees off in its joint, 0.3 in its mount); calibrate's standard errors
  /// for one that is.
  double sigma_pose = 0.5 * M_PI / 180.0;
  double gate = 3.0;              ///< a new height within this many sigmas of the old is fused with it [1]
  double min_plane_overlap = 0.2; ///< a new plane takes an old one's id when this share of its cells agrees with it [1]
  /// Empty when valid, else a message naming the parameter.
  std::string validate() const;
};

/// One sweep's height error in a cell, as the noise model gives it: the
/// range noise's variance (sigma_min and sigma_range x the range from the
/// sensor, in quadrature) and the head pose's share, sigma_pose x the
/// horizontal distance, which is the same in every sweep.
class SweepNoise {
 public:
  SweepNoise(const FusedMapParams& p, const HeightMapParams& grid, const Eigen::Vector3d& sensor);
  /// [m^2] of a height z in cell (ix, iy)
  float variance(int ix, int iy, float z) const {
    const float dx = (ix + 0.5f) * res_ - sx_, dy = (iy + 0.5f) * res_ - sy_, dz = z - sz_;
    return s0_ + k2_ * (dx * dx + dy * dy + dz * dz);
  }
  /// [m, sigma]
  float bias(int ix, int iy) const { return pose_ * std::hypot((ix + 0.5f) * res_ - sx_, (iy + 0.5f) * res_ - sy_); }

 private:
  float s0_, k2_, pose_, sx_, sy_, sz_, res_;
};

/// A sweep's own map's uncertainty layer: each known cell's sigma (both of
/// SweepNoise's terms) seen from `sensor`, NaN where unknown.
void sweepUncertainty(const HeightMapGrid& grid, const Eigen::Vector3d& sensor, const FusedMapParams& p,
                      std::vector<float>& sigmas);

/// A walkable plane of the fused map: the newest sweep's plane and polygon
/// under a persistent id, and when it was last seen.
struct TerrainPlane {
  Plane plane;  ///< plane.id is the persistent id
  double last_seen = 0.0;
};

class FusedHeightMap {
 public:
  /// `cells`: the classes' thresholds, and the resolution unless
  /// params.resolution gives one (origin and size are the fused grid's own).
  FusedHeightMap(const HeightMapParams& cells, const FusedMapParams& params);

  /// Moves the grid so that its centre is at the cell of (x, y); the cells
  /// that stay in it keep their contents, the new ones are unknown.
  void recentre(double x, double y);
  /// The cells' classification (slope, step and obstacle heights, floor
  /// tolerance) for the sweeps to come; the grid's size and place stay.
  void setClassification(const HeightMapParams& p);
  /// Fuses a sweep (planes and points in the map's frame) seen from `sensor`,
  /// finished at `stamp`, when the robot had walked `travelled` metres in
  /// all; then forgets what is older than forget_time.
  void addSweep(const SweepResult& sweep, const Eigen::Vector3d& sensor, double stamp, double travelled);
  /// Forgets cells and planes last seen before now - forget_time.
  void forget(double now);
  void clear();

  /// The map as published: heights, persistent plane ids, classes.
  const HeightMapGrid& grid() const { return grid_; }
  /// The sweep's own map of the last addSweep (on the same cells).
  const HeightMapGrid& lastSweep() const { return sweep_; }
  /// A cell's uncertainty now [m, sigma]: its own, grown with the distance walked since; NaN unknown.
  double sigma(std::size_t cell, double travelled) const;
  /// When a cell was last seen [s] (NaN unknown).
  double lastSeen(std::size_t cell) const;
  /// Every cell's sigma (as sigma()) and age (now minus when it was last seen) [m, s]; NaN unknown.
  void uncertainty(double now, double travelled, std::vector<float>& sigmas, std::vector<float>& ages) const;
  const std::map<int, TerrainPlane>& planes() const { return planes_; }
  const FusedMapParams& params() const { return p_; }

 private:
  void forgetCell(std::size_t c);
  FusedMapParams p_;
  HeightMapGrid grid_, sweep_;
  std::vector<float> var_;       ///< height variance when last seen [m^2] (what fusing sweeps shrinks)
  std::vector<float> bias_;      ///< the head pose's share of the height's error [m, sigma] (what it does not)
  std::vector<float> seen_;      ///< when last seen, after epoch_ [s] (float: a millisecond after 4 hours)
  double epoch_ = 0.0;
  bool have_epoch_ = false;
  std::vector<float> walked_;    ///< distance walked when last seen [m]
  /// Per row, at most the oldest seen_ of its cells (+inf: none seen): rows
  /// with nothing to forget are skipped without looking at their cells.
  std::vector<float> row_oldest_;
  std::map<int, TerrainPlane> planes_;
  int next_id_ = 0;
  bool placed_ = false;
};

/// The fused map of a walking robot with its odometry bookkeeping (the
/// grouper's): the distance walked between sweeps (each cell's sigma grows
/// with it), the grid kept centred on the robot, and a clock that goes back
/// (a recording that loops) starting the map again.
class FusedMapTracker {
 public:
  FusedMapTracker(const HeightMapParams& cells, const FusedMapParams& params) : map_(cells, params) {}
  /// Fuses a sweep; `robot` is the robot's place (x, y) in the map's frame at
  /// the sweep's last beam, or null when it is not known (the map then stays
  /// where it was: its cells are still right in the fixed frame).
  void addSweep(const SweepResult& sweep, const Eigen::Vector2d* robot);
  /// The distance walked since the map began [m].
  double travelled() const { return travelled_; }
  const FusedHeightMap& map() const { return map_; }
  FusedHeightMap& map() { return map_; }

 private:
  FusedHeightMap map_;
  Eigen::Vector2d robot_ = Eigen::Vector2d::Zero();
  bool robot_known_ = false;
  double travelled_ = 0.0, last_end_ = -1e300;
};

}  // namespace core
}  // namespace tilt_laser_perception
