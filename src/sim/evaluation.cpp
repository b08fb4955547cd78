#include "tilt_laser_perception/sim/evaluation.hpp"

#include <cstdlib>

namespace tilt_laser_perception {
namespace sim {

EdgeScore scoreEdges(const std::vector<core::EdgePoint>& edges, const std::vector<TrueEdge>& truth, int tolerance) {
  EdgeScore s;
  s.true_edges = static_cast<int>(truth.size());
  for (const auto& e : edges) {
    if (e.kind == core::EdgeKind::Veil) continue;  // a mark on no surface, not an edge of one
    ++s.edge_points;
    bool near = false;
    for (const auto& t : truth) near = near || std::abs(e.index - t.index) <= tolerance;
    s.spurious += !near;
  }
  for (const auto& t : truth) {
    bool hit = false;
    for (const auto& e : edges) hit = hit || (e.kind != core::EdgeKind::Veil && std::abs(e.index - t.index) <= tolerance);
    s.found += hit;
  }
  return s;
}

Figure3Row runFigure3Case(const Scene& scene, double distance_m, const core::SplitParams& params, int seeds,
                          const NoiseParams& noise) {
  Figure3Row row;
  row.scene = scene.name;
  row.distance_m = distance_m;
  row.mode = params.mode == core::SplitMode::Fixed ? "fixed" : "adaptive";
  core::ScanSplitter splitter(params);
  core::SplitResult result;
  SimScan scan;
  const PoseFunction at_origin = [](double) { return Eigen::Isometry3d::Identity(); };
  for (int seed = 1; seed <= seeds; ++seed) {
    LidarSimulator sim(scene, LidarModel(), noise, static_cast<std::uint64_t>(seed));
    sim.scan(0.0, at_origin, scan);
    splitter.split(scan.view(), result);
    const EdgeScore score = scoreEdges(result.edges, scan.edges);
    row.segments += static_cast<double>(result.segments.size());
    row.edge_points += score.edge_points;
    row.spurious_edges += score.spurious;
    row.true_edges_found += score.found;
    row.true_edges += score.true_edges;
  }
  const double k = seeds > 0 ? 1.0 / seeds : 0.0;
  row.segments *= k;
  row.edge_points *= k;
  row.spurious_edges *= k;
  row.true_edges_found *= k;
  row.true_edges *= k;
  return row;
}

std::vector<Figure3Case> figure3Cases() {
  return {{"figure3_board_1m", 1.0},
          {"figure3_board_2m", 2.0},
          {"figure3_wall_10m", 10.0},
          {"figure3_wall_20m", 20.0},
          {"figure3_wall_30m", 30.0}};
}

}  // namespace sim
}  // namespace tilt_laser_perception
