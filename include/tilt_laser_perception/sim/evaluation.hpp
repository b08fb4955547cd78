/**
 * @file evaluation.hpp
 * @brief Scoring split results against the simulator's ground truth, and the
 *        paper's Figure 3 experiment (fixed against range-adaptive threshold). ROS-free.
 */
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
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

/// Point counts of a segmentation against the truth: per true region, per
/// found region, and per (found, true) pair.
struct RegionOverlap {
  std::map<int, int> truth_count, found_count;
  std::map<std::pair<int, int>, int> overlap;  ///< (found, truth) -> points in both
  void add(int truth, int found);              ///< one point; -1: in no region
  /// From one label per point (-1: none).
  static RegionOverlap of(const std::vector<int>& truth, const std::vector<int>& found);
  /// From an organized cloud's plane labels as core::segmentOrganized gives
  /// them (0: none, else plane id + 1) against its true labels (-1: none);
  /// points without coordinates count for neither.
  static RegionOverlap ofPlaneLabels(const std::vector<int>& truth, const std::vector<std::uint32_t>& labels,
                                     const std::vector<Eigen::Vector3f>& points);
};

/// Hoover et al.'s comparison ("An experimental comparison of range image
/// segmentation algorithms", 1996) at tolerance T.
struct HooverScore {
  int expected = 0;  ///< true regions expected to be found
  int correct = 0, over = 0, under = 0, missed = 0, noise = 0;
  std::vector<std::pair<int, int>> correct_pairs;  ///< (found, truth)
  std::vector<int> missed_truth;                   ///< expected true regions missed
  std::vector<int> noise_found;                    ///< found regions counted as noise
};

/// Correct: a pair sharing at least T of both regions; over-segmented: a
/// true region covered for T by several found regions each lying T in it;
/// under-segmented: the converse; missed: expected true regions none of
/// these; noise: the remaining found regions of `min_noise_points` or more,
/// unless they lie T on a true region that was not expected.
HooverScore hooverScore(const RegionOverlap& o, double tolerance, const std::function<bool(int)>& expected,
                        int min_noise_points = 0);

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
