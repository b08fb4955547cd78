/**
 * @file evaluation.hpp
 * @brief Scoring split results against the simulator's ground truth, and the
 *        paper's Figure 3 experiment (fixed against range-adaptive threshold). ROS-free.
 */
#pragma once

#include <string>
#include <vector>

#include "tilt_laser_perception/core/scan_split.hpp"
#include "tilt_laser_perception/sim/lidar_sim.hpp"

namespace tilt_laser_perception {
namespace sim {

/// Edge points scored against true edges.
struct EdgeScore {
  int edge_points = 0;  ///< edge points found
  int spurious = 0;     ///< edge points farther than `tolerance` beams from every true edge
  int true_edges = 0;   ///< true edges
  int found = 0;        ///< true edges with an edge point within `tolerance` beams
};

/// Scores edge points against true edges (both sorted or not), within `tolerance` beams.
EdgeScore scoreEdges(const std::vector<core::EdgePoint>& edges, const std::vector<TrueEdge>& truth,
                     int tolerance = 2);

/// One row of the Figure 3 table: means over the seeds.
struct Figure3Row {
  std::string scene;
  double distance_m = 0.0;
  std::string mode;  ///< "fixed" or "adaptive"
  double segments = 0.0;
  double edge_points = 0.0;
  double spurious_edges = 0.0;
  double true_edges_found = 0.0;
  double true_edges = 0.0;
};

/// Runs one case: `seeds` noisy scans (seeds 1..N) of `scene` from a sensor at
/// the origin, split with `params`; returns the means.
Figure3Row runFigure3Case(const Scene& scene, double distance_m, const core::SplitParams& params, int seeds,
                          const NoiseParams& noise = NoiseParams());

/// The cases of the experiment: scene file name and distance [m].
struct Figure3Case {
  std::string scene;
  double distance_m;
};
std::vector<Figure3Case> figure3Cases();

}  // namespace sim
}  // namespace tilt_laser_perception
