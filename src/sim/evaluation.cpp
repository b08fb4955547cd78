#include "tilt_laser_perception/sim/evaluation.hpp"

#include <cstdlib>
#include <set>

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

void RegionOverlap::add(int truth, int found) {
  if (truth >= 0) ++truth_count[truth];
  if (found >= 0) ++found_count[found];
  if (truth >= 0 && found >= 0) ++overlap[{found, truth}];
}

RegionOverlap RegionOverlap::of(const std::vector<int>& truth, const std::vector<int>& found) {
  RegionOverlap o;
  for (std::size_t i = 0; i < truth.size() && i < found.size(); ++i) o.add(truth[i], found[i]);
  return o;
}

RegionOverlap RegionOverlap::ofPlaneLabels(const std::vector<int>& truth, const std::vector<std::uint32_t>& labels,
                                           const std::vector<Eigen::Vector3f>& points) {
  RegionOverlap o;
  for (std::size_t i = 0; i < truth.size() && i < labels.size() && i < points.size(); ++i)
    if (points[i].allFinite()) o.add(truth[i], static_cast<int>(labels[i]) - 1);
  return o;
}

HooverScore hooverScore(const RegionOverlap& o, double T, const std::function<bool(int)>& expected,
                        int min_noise_points) {
  HooverScore h;
  const auto count = [](const std::map<int, int>& m, int k) {
    const auto it = m.find(k);
    return it == m.end() ? 0 : it->second;
  };
  std::set<int> wanted;
  for (const auto& [t, n] : o.truth_count)
    if (expected(t)) wanted.insert(t);
  h.expected = static_cast<int>(wanted.size());
  std::set<int> truth_done, found_done;
  for (const auto& [key, n] : o.overlap) {
    const auto [d, t] = key;
    if (n >= T * count(o.found_count, d) && n >= T * count(o.truth_count, t) && wanted.count(t)) {
      ++h.correct;
      h.correct_pairs.emplace_back(d, t);
      truth_done.insert(t);
      found_done.insert(d);
    }
  }
  for (int t : wanted) {  // over-segmented
    if (truth_done.count(t)) continue;
    int sum = 0;
    std::vector<int> ds;
    for (const auto& [key, n] : o.overlap)
      if (key.second == t && n >= T * count(o.found_count, key.first)) {
        sum += n;
        ds.push_back(key.first);
      }
    if (ds.size() >= 2 && sum >= T * count(o.truth_count, t)) {
      ++h.over;
      truth_done.insert(t);
      found_done.insert(ds.begin(), ds.end());
    }
  }
  for (const auto& [d, nd] : o.found_count) {  // under-segmented
    if (found_done.count(d)) continue;
    int sum = 0;
    std::vector<int> ts;
    for (const auto& [key, n] : o.overlap)
      if (key.first == d && n >= T * count(o.truth_count, key.second)) {
        sum += n;
        ts.push_back(key.second);
      }
    if (ts.size() >= 2 && sum >= T * nd) {
      ++h.under;
      found_done.insert(d);
      truth_done.insert(ts.begin(), ts.end());
    }
  }
  for (int t : wanted)
    if (!truth_done.count(t)) {
      ++h.missed;
      h.missed_truth.push_back(t);
    }
  for (const auto& [d, nd] : o.found_count) {  // noise
    if (found_done.count(d) || nd < min_noise_points) continue;
    int best = 0, best_t = -1;
    for (const auto& [key, n] : o.overlap)
      if (key.first == d && n > best) {
        best = n;
        best_t = key.second;
      }
    if (best_t >= 0 && !wanted.count(best_t) && best >= T * nd) continue;
    ++h.noise;
    h.noise_found.push_back(d);
  }
  return h;
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
