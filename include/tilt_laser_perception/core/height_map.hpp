/**
 * @file height_map.hpp
 * @brief A 2.5D height map for footstep planning from the planes and points of
 *        a sweep: cells inside a (near-)horizontal plane's polygon take the
 *        plane's height there; points outside such planes mark obstacles with
 *        their top height, except those of steep planes no taller than a
 *        step (risers: the treads around them already tell the height); the
 *        rest stays unknown (NaN). ROS-free; [m].
 */
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "tilt_laser_perception/core/noise_model.hpp"
#include "tilt_laser_perception/core/sweep.hpp"

namespace tilt_laser_perception {
namespace core {

enum class CellClass : std::uint8_t { Unknown = 0, Floor = 1, Step = 2, Obstacle = 3 };

/// A class as an occupancy value (nav_msgs/OccupancyGrid, costmaps, rviz's
/// Map display): unknown -1, floor 0 (free), step 50 (walkable with care:
/// another level), obstacle 100.
inline std::int8_t occupancyOfClass(CellClass c) {
  switch (c) {
    case CellClass::Floor: return 0;
    case CellClass::Step: return 50;
    case CellClass::Obstacle: return 100;
    default: return -1;
  }
}

struct HeightMapParams {
  double resolution = 0.01;   ///< [m/cell]
  double origin_x = -0.5;     ///< corner of cell (0, 0) in the map frame [m]
  double origin_y = -2.0;
  int width = 400;            ///< cells along x
  int height = 400;           ///< cells along y
  double max_slope_deg = 15.0;       ///< planes steeper than this are not walkable surfaces
  double floor_tolerance = 0.03;     ///< cells within this of the floor's height are floor [m]
  double obstacle_min_height = 0.05; ///< points this far above a cell's surface make it an obstacle [m]
  double max_step_height = 0.2;      ///< steep planes no taller than this are step faces (risers), not obstacles [m]
  /// The rig's range noise and the one significance level: a point of no
  /// plane within significance range sigmas of a face along its ray, beside
  /// its outline, is that face's point.
  NoiseModel noise;
};

struct HeightMapGrid {
  HeightMapParams params;
  std::vector<float> heights;          ///< row-major (y rows, x columns) [m], NaN unknown
  std::vector<std::int32_t> plane_ids; ///< -1 none
  std::vector<CellClass> classes;
  double floor_height = 0.0;           ///< height of the floor plane [m] (NaN when none was found)
  int floor_plane = -1;
  /// The box of the cells buildHeightMap gave a height (inclusive; empty when x1 < x0).
  int box_x0 = 0, box_y0 = 0, box_x1 = -1, box_y1 = -1;
  std::size_t index(int ix, int iy) const { return static_cast<std::size_t>(iy) * params.width + ix; }
};

/// Whether all of a segment's points lie beside a map's area (cells
/// [0, width) x [0, height)): its ends both beyond one side by more than
/// 0.1 m. Its points lie along the line between its ends within the split's
/// tolerance (centimetres), so they are beside it too: the far walls and
/// floor, most of a sweep's points, are not looked at one by one.
bool besideMap(const Segment3& s, const HeightMapParams& params);

/// A foot a planner would place: HRP-4's sole by default.
struct FootParams {
  double length = 0.24;         ///< [m]
  double width = 0.14;          ///< [m]
  double max_tilt_deg = 15.0;   ///< the plane under it, from level [deg]
  /// The plane's rms about its fit [m]: a surface rougher than this, beyond
  /// the laser's own noise (10 mm), holds no foot flat.
  double max_roughness = 0.02;
  std::string validate() const;
  /// The radius a foot centred on a cell sweeps over all its yaws [m].
  double radius() const { return 0.5 * std::hypot(length, width); }
};

/// Steppable cells: a foot centred on the cell rests on one plane whatever
/// its yaw. Every cell within the foot's radius (the disc all its yaws
/// cover) is known, of one walkable plane (not an obstacle), that plane
/// within max_tilt_deg of level and max_roughness rms; two such planes that
/// meet at a crease shallow enough (radius x tan(angle) plus the step
/// between them within max_roughness) count as one. Per cell, row-major:
/// 1 steppable, 0 not, 255 unknown (the cell itself unknown). `planes` are
/// those the map's plane ids name (Plane::id).
void steppableCells(const HeightMapGrid& grid, const std::vector<Plane>& planes, const FootParams& foot,
                    std::vector<std::uint8_t>& out);

/// Builds the height map of a sweep (planes and points in the map frame, z up):
/// walkable planes between their lines (seen from above, the higher wins),
/// points above them as obstacles, and unknown what lies more than
/// obstacle_min_height beneath where a walkable plane may go on unseen (across
/// its outermost line, up to where the next line's rays passed its height:
/// the floor under a table's edges).
/// When `out` holds the map an earlier call made of the same size (unchanged
/// since), only that map's box is cleared first, not the whole grid.
void buildHeightMap(const SweepResult& sweep, const HeightMapParams& params, HeightMapGrid& out);

}  // namespace core
}  // namespace tilt_laser_perception
