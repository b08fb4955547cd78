#include "tilt_laser_perception/sim/scene_eval.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <unordered_map>

#include "tilt_laser_perception/dynamixel/mx64.hpp"
#include "tilt_laser_perception/sim/evaluation.hpp"

namespace tilt_laser_perception {
namespace sim {

namespace {
double cpuNow() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

/// The scene's true heights on the cell lattice of a resolution (cell (i, j)
/// centred at ((i + 0.5) r, (j + 0.5) r)): the highest surface above the
/// centre, ray cast once per cell as maps ask for them (kept for the cells
/// over the scene's faces). A cell that a vertical face reaching above `top`
/// crosses (a wall: the head cannot see its top) is not judged (NaN).
class TruthHeights {
 public:
  TruthHeights(const Scene& scene, double resolution, double top) : scene_(scene), r_(resolution) {
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (const Face& f : scene.faces) {
      double zmax = -1e300;
      Eigen::Vector2d a(1e300, 0), b(-1e300, 0);
      for (const Eigen::Vector3d& c : f.corners()) {
        zmax = std::max(zmax, c.z());
        x0 = std::min(x0, c.x());
        x1 = std::max(x1, c.x());
        y0 = std::min(y0, c.y());
        y1 = std::max(y1, c.y());
        if (c.x() < a.x() || (c.x() == a.x() && c.y() < a.y())) a = c.head<2>();
        if (c.x() > b.x() || (c.x() == b.x() && c.y() > b.y())) b = c.head<2>();
      }
      if (std::abs(f.normal.z()) <= 0.2 && zmax > top) walls_.push_back({a, b});
    }
    if (x1 >= x0) {
      i0_ = static_cast<long>(std::floor(x0 / r_)) - 1;
      j0_ = static_cast<long>(std::floor(y0 / r_)) - 1;
      w_ = std::min<long>(static_cast<long>(std::ceil(x1 / r_)) + 1 - i0_, 20000);
      h_ = std::min<long>(static_cast<long>(std::ceil(y1 / r_)) + 1 - j0_, 20000);
      cache_.assign(static_cast<std::size_t>(w_) * h_, kUnknown);
    }
  }
  float at(long i, long j) {
    const bool kept = i >= i0_ && j >= j0_ && i < i0_ + w_ && j < j0_ + h_;
    float* slot = kept ? &cache_[static_cast<std::size_t>(j - j0_) * w_ + (i - i0_)] : nullptr;
    if (slot && *slot != kUnknown) return *slot;
    const Eigen::Vector2d c((i + 0.5) * r_, (j + 0.5) * r_);
    bool wall = false;
    for (const auto& [a, b] : walls_) {
      const Eigen::Vector2d ab = b - a;
      const double s = std::clamp((c - a).dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
      wall = wall || (a + s * ab - c).norm() <= 0.75 * r_;
    }
    const float h = wall ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(scene_.heightAt(c.x(), c.y()));
    if (slot) *slot = h;
    return h;
  }

 private:
  static constexpr float kUnknown = -1e30f;  ///< not cast yet
  const Scene& scene_;
  double r_;
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> walls_;  ///< footprints of the tall vertical faces
  long i0_ = 0, j0_ = 0, w_ = 0, h_ = 0;                            ///< the kept cells (over the faces)
  std::vector<float> cache_;
};

struct MapScore {
  double rmse = 0.0, coverage = 0.0, front = 0.0, front_observable = 0.0;
  double walkable_rmse = 0.0;  ///< over the cells of walkable surfaces away from their edges
  double invented = 0.0;       ///< share of the known cells whose true surface the sensor could not see
  double steppable_precision = 0.0, steppable_recall = 0.0;  ///< of the steppable layer (when planes are given)
  /// Of the walkable cells, the share whose error exceeds twice the sigma the
  /// map states for them (when it states one): an honest sigma leaves 5 %.
  double overconfident = 0.0;
  /// Step edges: the distance from each true step edge (a centimetre of it)
  /// to the map's, median and 95th percentile [m] (NaN: none in view), over
  /// those the map shows; the share of them it does not (unknown around).
  double edge_median = std::numeric_limits<double>::quiet_NaN(), edge_p95 = edge_median, edge_unknown = edge_median;
};

/// The map cells (world indices at one resolution) that points fell in, and when.
using HitCells = std::unordered_map<std::uint64_t, double>;
/// The map cells that points fell in, and by which line (-1: two or more).
using LineCells = std::unordered_map<std::uint64_t, int>;
std::uint64_t cellKey(long i, long j) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(i)) << 32) | static_cast<std::uint32_t>(j);
}

/// A map against the truth: RMSE and coverage of the cells within `radius`
/// of the base, and coverage of the front_length x front_width in front of it.
/// Walkable away from edges: the true heights 5 cm away along x and y (a
/// foot's margin) all lie within the walkable slope of the cell's (no step
/// edge, wall or drop within 5 cm, no slope steeper than max_slope_deg).
/// Invented (when `scene` and `eye` are given): a known cell whose true
/// surface point is hidden from `eye` (the sensor) by something more than
/// 2 cm nearer along its ray (one cell in four looked at).
MapScore scoreMap(const core::HeightMapGrid& grid, TruthHeights& truth, const Eigen::Isometry3d& base,
                  const SceneEvalOptions& o, const HitCells* hits = nullptr, double seen_after = 0.0,
                  const Scene* scene = nullptr, const Eigen::Vector3d* eye = nullptr,
                  const std::vector<core::Plane>* planes = nullptr, const std::vector<float>* sigmas = nullptr,
                  const LineCells* on_surface = nullptr) {
  // The steppable layer against the truth: a foot centred on the cell rests
  // on one true plane whatever its yaw when the true heights at its centre
  // and on circles of its radius and half of it (16 points) lie within 5 mm
  // of one plane within the foot's tilt.
  std::vector<std::uint8_t> steppable;
  if (planes) core::steppableCells(grid, *planes, o.foot, steppable);
  const double rc = std::floor(o.foot.radius() / grid.params.resolution);  // whole cells within the disc
  // Along each row, the map's unknown cells before each cell (the row's
  // width + 1 counts): whether a foot's disc is all known, row by row.
  std::vector<int> unknown_before;
  std::vector<long> half;  // the disc's half width at each row from its centre
  for (long dy = 0; dy <= static_cast<long>(rc); ++dy)
    half.push_back(std::lround(std::floor(std::sqrt(rc * rc - static_cast<double>(dy * dy)))));
  if (!steppable.empty()) {
    const int w = grid.params.width;
    unknown_before.assign(static_cast<std::size_t>(w + 1) * grid.params.height, 0);
    for (int y = 0; y < grid.params.height; ++y)
      for (int x = 0; x < w; ++x)
        unknown_before[static_cast<std::size_t>(y) * (w + 1) + x + 1] =
            unknown_before[static_cast<std::size_t>(y) * (w + 1) + x] + !std::isfinite(grid.heights[grid.index(x, y)]);
  }
  // The k-th of the disc's 17 points (8 on its rim, 8 half way, its centre), in cells.
  const auto discPoint = [&](int k, long& di, long& dj) {
    const double ang = (k % 8) * M_PI / 4.0, rad = k == 16 ? 0.0 : (k < 8 ? rc : 0.5 * rc);
    di = std::lround(rad * std::cos(ang));
    dj = std::lround(rad * std::sin(ang));
  };
  const auto trulySteppable = [&](long i, long j) {
    Eigen::Matrix<double, 17, 3> A;
    Eigen::Matrix<double, 17, 1> z;
    for (int k = 0; k < 17; ++k) {
      long di, dj;
      discPoint(k, di, dj);
      const float t = truth.at(i + di, j + dj);
      if (std::isnan(t)) return false;
      A.row(k) << 1.0, static_cast<double>(di), static_cast<double>(dj);
      z(k) = t;
    }
    const Eigen::Vector3d c = A.colPivHouseholderQr().solve(z);
    const double slope = std::hypot(c(1), c(2)) / grid.params.resolution;
    return (A * c - z).cwiseAbs().maxCoeff() <= 0.005 && slope <= std::tan(o.foot.max_tilt_deg * M_PI / 180.0);
  };
  int map_step = 0, true_step = 0, both = 0;
  const core::HeightMapParams& hp = grid.params;
  const long i0 = std::lround(hp.origin_x / hp.resolution), j0 = std::lround(hp.origin_y / hp.resolution);
  const Eigen::Vector2d c = base.translation().head<2>();
  const Eigen::Vector2d fwd = (base.linear() * Eigen::Vector3d::UnitX()).head<2>().normalized();
  double se = 0.0, se_walk = 0.0;
  int known = 0, expected = 0, front_known = 0, front_expected = 0, front_hit = 0, walk_known = 0;
  int looked = 0, invented = 0, beyond_2_sigma = 0;
  const long margin = std::max(1L, std::lround(0.05 / hp.resolution));
  const double rise = margin * hp.resolution * std::tan(hp.max_slope_deg * M_PI / 180.0);
  for (int iy = 0; iy < hp.height; ++iy)
    for (int ix = 0; ix < hp.width; ++ix) {
      const Eigen::Vector2d d = Eigen::Vector2d(hp.origin_x + (ix + 0.5) * hp.resolution,
                                                hp.origin_y + (iy + 0.5) * hp.resolution) - c;
      const double ahead = d.dot(fwd), side = fwd.x() * d.y() - fwd.y() * d.x();
      const bool front = ahead >= 0.0 && ahead <= o.front_length && std::abs(side) <= 0.5 * o.front_width;
      const bool near = d.norm() <= o.heightmap_radius;
      if (!near && !front) continue;
      const float t = truth.at(i0 + ix, j0 + iy);
      if (std::isnan(t)) continue;
      const float h = grid.heights[grid.index(ix, iy)];
      front_expected += front;
      front_known += front && !std::isnan(h);
      if (front && hits) {
        const auto it = hits->find(cellKey(i0 + ix, j0 + iy));
        front_hit += it != hits->end() && it->second >= seen_after;
      }
      if (!near) continue;
      ++expected;
      if (std::isnan(h)) continue;
      ++known;
      se += (h - t) * (h - t);
      bool walkable = true;
      for (const auto& [di, dj] : {std::pair<long, long>{margin, 0}, {-margin, 0}, {0, margin}, {0, -margin}}) {
        const float tn = truth.at(i0 + ix + di, j0 + iy + dj);
        walkable = walkable && !std::isnan(tn) && std::abs(tn - t) <= rise;
      }
      if (walkable) {
        ++walk_known;
        se_walk += (h - t) * (h - t);
        if (sigmas) beyond_2_sigma += !(std::abs(h - t) <= 2.0 * (*sigmas)[grid.index(ix, iy)]);
      }
      if (!steppable.empty() && ix % 2 == 0 && iy % 2 == 0) {  // one cell in four
        // Recall over the cells whose foot's disc the map knows, every cell of it.
        bool seen = ix >= rc && iy >= rc && ix + rc < hp.width && iy + rc < hp.height;
        for (long dy = -static_cast<long>(rc); dy <= rc && seen; ++dy) {
          const long hw = half[std::labs(dy)];
          const std::size_t row = static_cast<std::size_t>(iy + dy) * (hp.width + 1);
          seen = unknown_before[row + ix + hw + 1] == unknown_before[row + ix - hw];
        }
        const bool m = steppable[grid.index(ix, iy)] == 1, tr = seen && trulySteppable(i0 + ix, j0 + iy);
        map_step += m;
        true_step += tr;
        both += m && tr;  // (a cell the map calls steppable has its whole disc known)
      }
      if (scene && eye && ix % 2 == 0 && iy % 2 == 0) {
        const Eigen::Vector3d q(hp.origin_x + (ix + 0.5) * hp.resolution, hp.origin_y + (iy + 0.5) * hp.resolution, t);
        const Eigen::Vector3d ray = q - *eye;
        const double dist = ray.norm();
        Hit hit;
        ++looked;
        invented += dist > 0.05 && scene->raycast(*eye, ray / dist, dist - 0.02, hit);
      }
    }
  // Step edges. A true step edge: between two cells along x or y the true
  // height rises by obstacle_min_height to max_step_height, flat for 3 cells
  // on each side (a tread's nosing over a floor or a lower tread, not a wall's
  // foot), and in view: points of two of the sweep's lines or more fell on
  // its higher surface within 10 cm of it along the line and 5 cm across
  // (`on_surface`, when given; an edge the sensor did not see, beyond its
  // field of view or in a shadow, no map can place, nor one line's few
  // points, which fit no plane). The map's edge there: the nearest place
  // along the same row (x or y) where the higher surface it knows ends
  // towards the lower, within 10 cm along it; none counts 10 cm, unless the
  // map knows no cell of the row within 10 cm on either side: an edge it
  // does not show (unknown there), counted apart (edge_unknown). Its error
  // is that distance across the edge (times the cosine of the row's angle
  // to the edge's normal), each edge judged by the row nearer its normal:
  // along the other, an edge at 10 degrees to the row, a centimetre across
  // it is six.
  std::vector<double> edge_err;
  std::size_t edges_unknown = 0;
  const long reach = std::lround(0.10 / hp.resolution);
  const long kAround = std::lround(0.05 / hp.resolution);
  const auto mapAt = [&](long ix, long iy) {
    return ix < 0 || iy < 0 || ix >= hp.width || iy >= hp.height
               ? std::numeric_limits<float>::quiet_NaN()
               : grid.heights[grid.index(static_cast<int>(ix), static_cast<int>(iy))];
  };
  for (int iy = 0; iy < hp.height; ++iy)
    for (int ix = 0; ix < hp.width; ++ix)
      for (const auto& [ax, ay] : {std::pair<int, int>{1, 0}, {0, 1}}) {
        const Eigen::Vector2d d = Eigen::Vector2d(hp.origin_x + (ix + 0.5) * hp.resolution,
                                                  hp.origin_y + (iy + 0.5) * hp.resolution) - c;
        if (d.norm() > o.heightmap_radius) continue;
        const auto t = [&](int k) { return truth.at(i0 + ix + k * ax, j0 + iy + k * ay); };
        const float a = t(0), b = t(1);
        const float rise = std::abs(b - a);
        if (std::isnan(a) || std::isnan(b) || rise < hp.obstacle_min_height || rise > hp.max_step_height) continue;
        bool flat = true;
        for (int k = 1; k <= 3 && flat; ++k) flat = std::abs(t(-k) - a) < 0.005f && std::abs(t(1 + k) - b) < 0.005f;
        if (!flat) continue;
        // Across the edge: the higher surface's cells about it, less the
        // lower's, lie towards its normal (kAround cells either way). An edge
        // whose normal lies more than 45 degrees off this row is the other
        // row's to judge: along this row a centimetre across it is many.
        Eigen::Vector2d towards = Eigen::Vector2d::Zero();
        for (long dj = -kAround; dj <= kAround; ++dj)
          for (long di = -kAround; di <= kAround; ++di) {
            const float h = truth.at(i0 + ix + di, j0 + iy + dj);
            const double side = std::abs(h - b) < 0.005f ? 1.0 : std::abs(h - a) < 0.005f ? -1.0 : 0.0;
            towards += side * Eigen::Vector2d(di - 0.5 * ax, dj - 0.5 * ay);
          }
        const double across = std::abs(towards.dot(Eigen::Vector2d(ax, ay))) / std::max(towards.norm(), 1e-9);
        if (across < std::sqrt(0.5)) continue;  // (a distance along the row times this is one across the edge)
        if (on_surface) {
          int line = -2;  // the one line seen so far (-2: none; -1: two or more)
          for (long k = 1; k <= reach && line != -1; ++k)
            for (long q = -reach / 2; q <= reach / 2 && line != -1; ++q) {
              const long kk = b > a ? k : 1 - k;  // cells on the high side (b's, from 1; a's, from 0)
              const auto it = on_surface->find(cellKey(i0 + ix + kk * ax + q * ay, j0 + iy + kk * ay + q * ax));
              if (it != on_surface->end()) line = line == -2 || line == it->second ? it->second : -1;
            }
          if (line != -1) continue;
        }
        // Along the line, where the map's higher surface ends towards the
        // lower: a cell it knows above the mid height beside one it knows
        // below it or does not know (a planner keeps its feet where the map
        // knows the higher surface). The true edge lies between cells 0 and 1.
        const float mid = 0.5f * (a + b);
        const int up = b > a ? 1 : 0;  // which of a boundary's two cells is on the high side
        const auto high = [&](long k) {
          const float h = mapAt(ix + k * ax, iy + k * ay);
          return !std::isnan(h) && h > mid;
        };
        bool shown = false;
        for (long k = -reach; k <= reach + 1 && !shown; ++k) shown = !std::isnan(mapAt(ix + k * ax, iy + k * ay));
        if (!shown) {
          ++edges_unknown;
          continue;
        }
        long best = reach;
        for (long k = -reach; k <= reach; ++k)
          if (high(k + up) && !high(k + 1 - up)) best = std::min(best, std::labs(k));
        edge_err.push_back(best * hp.resolution * across);
      }
  MapScore m;
  if (edges_unknown + edge_err.size() > 0)
    m.edge_unknown = static_cast<double>(edges_unknown) / static_cast<double>(edges_unknown + edge_err.size());
  if (!edge_err.empty()) {
    std::sort(edge_err.begin(), edge_err.end());
    m.edge_median = edge_err[edge_err.size() / 2];
    m.edge_p95 = edge_err[std::min(edge_err.size() - 1, static_cast<std::size_t>(0.95 * edge_err.size()))];
  }
  m.rmse = known ? std::sqrt(se / known) : 0.0;
  m.walkable_rmse = walk_known ? std::sqrt(se_walk / walk_known) : 0.0;
  m.overconfident = walk_known ? static_cast<double>(beyond_2_sigma) / walk_known : 0.0;
  m.invented = looked ? static_cast<double>(invented) / looked : 0.0;
  m.steppable_precision = map_step ? static_cast<double>(both) / map_step : 1.0;
  m.steppable_recall = true_step ? static_cast<double>(both) / true_step : 1.0;
  m.coverage = expected ? static_cast<double>(known) / expected : 0.0;
  m.front = front_expected ? static_cast<double>(front_known) / front_expected : 0.0;
  m.front_observable = front_expected ? static_cast<double>(front_hit) / front_expected : 0.0;
  return m;
}

struct LineTruth {
  std::vector<int> face;
  std::vector<float> ranges;
  std::vector<TrueEdge> edges;
  std::vector<core::EdgePoint> found;
  int veil_segments = 0;  // segments most of whose points are mixed pixels
  int overhanging = 0;    // segments with own points more than 1 cm beyond their ends
  int mixed = 0, mixed_in_segments = 0;  // mixed pixels, and those in segments
  std::vector<unsigned char> is_mixed;   // by beam: a mixed pixel
};

SweepEval judge(const Scene& scene, TruthHeights& truth_h, TruthHeights& truth_fused, const core::SweepResult& sw,
                const std::map<double, LineTruth>& truth, const std::map<double, double>& split_time,
                const SceneEvalOptions& o, double latency, const Eigen::Isometry3d& base, double travelled,
                core::HeightMapGrid& grid, core::FusedHeightMap& fused, HitCells& hits) {
  SweepEval e;
  e.lines = static_cast<int>(sw.lines.size());
  // Points judged: valid returns within the radius; their true face and detected plane.
  RegionOverlap ov;
  std::vector<std::vector<int>> plane_of(sw.lines.size());
  for (std::size_t li = 0; li < sw.lines.size(); ++li) plane_of[li].assign(sw.lines[li].points.size(), -1);
  std::vector<core::Plane> external_planes;
  if (o.segmenter) {
    const double t0 = cpuNow();
    o.segmenter(sw, plane_of, external_planes);
    e.external_ms = (cpuNow() - t0) * 1e3;
  } else {
    for (std::size_t si = 0; si < sw.segments.size(); ++si) {
      const core::Segment3& s = sw.segments[si];
      for (int i = s.first; i <= s.last; ++i) plane_of[s.line][i] = sw.segment_plane[si];
    }
  }
  const std::vector<core::Plane>& planes = o.segmenter ? external_planes : sw.planes;
  e.planes = static_cast<int>(planes.size());
  int edges_found = 0, edges_spurious = 0, edges_true = 0, edges_hit = 0;
  for (std::size_t li = 0; li < sw.lines.size(); ++li) {
    const auto it = truth.find(sw.lines[li].stamp);
    if (it == truth.end()) continue;
    const LineTruth& t = it->second;
    e.veil_segments += t.veil_segments;
    e.overhanging_segments += t.overhanging;
    e.mixed_pixels += t.mixed;
    e.mixed_in_segments += t.mixed_in_segments;
    const EdgeScore es = scoreEdges(t.found, t.edges);
    edges_found += es.edge_points;
    edges_spurious += es.spurious;
    edges_true += es.true_edges;
    edges_hit += es.found;
    for (std::size_t i = 0; i < sw.lines[li].points.size(); ++i) {
      const Eigen::Vector3f& p = sw.lines[li].points[i];
      if (!std::isfinite(p.x()) ||
          std::hypot(p.x() - base.translation().x(), p.y() - base.translation().y()) > o.eval_radius)
        continue;
      // A mixed pixel (a range between two faces) measures neither: it is no
      // face's point, as a careful hand labelling leaves it out.
      if (!o.judge_mixed && i < t.is_mixed.size() && t.is_mixed[i]) continue;
      ov.add(t.face[i], plane_of[li][i]);
    }
  }
  e.edge_precision = edges_found ? 1.0 - static_cast<double>(edges_spurious) / edges_found : 1.0;
  e.edge_recall = edges_true ? static_cast<double>(edges_hit) / edges_true : 1.0;

  const HooverScore h = hooverScore(
      ov, o.overlap,
      [&](int f) { return ov.truth_count.at(f) >= o.min_face_points && scene.faces[f].area() >= o.min_face_area; },
      o.min_face_points);
  e.true_faces = h.expected;
  e.correct = h.correct;
  e.over = h.over;
  e.under = h.under;
  e.missed = h.missed;
  e.noise = h.noise;
  for (const auto& [d, f] : h.correct_pairs) {
    const Face& face = scene.faces[f];
    const core::Plane& pl = planes[d];
    e.normal_err_deg += std::acos(std::min(1.0, std::abs(pl.fit.normal.dot(face.normal)))) * 180.0 / M_PI / e.correct;
    e.offset_err_m += std::abs(face.normal.dot(pl.fit.centroid - face.origin)) / e.correct;
  }
  const auto& face_count = ov.truth_count;
  const auto& plane_count = ov.found_count;
  const auto& overlap = ov.overlap;
  for (int d : h.noise_found) {
    // What it holds: "plane P (N points: object/label:count ..., none:count), lines A-B".
    std::string what = "plane " + std::to_string(d) + " (" + std::to_string(plane_count.at(d)) + " points:";
    for (const auto& [key, n] : overlap)
      if (key.first == d)
        what += " " + (key.second >= 0 ? scene.faces[key.second].object + "/" + scene.faces[key.second].label
                                       : std::string("none")) + ":" + std::to_string(n);
    int lo = -1, hi = -1;
    for (std::size_t si = 0; si < sw.segments.size() && !o.segmenter; ++si)
      if (sw.segment_plane[si] == d) {
        lo = lo < 0 ? sw.segments[si].line : std::min(lo, sw.segments[si].line);
        hi = std::max(hi, sw.segments[si].line);
      }
    e.noise_planes.push_back(what + ")" + (lo >= 0 ? ", lines " + std::to_string(lo) + "-" + std::to_string(hi) : ""));
  }
  for (int f : h.missed_truth) {
    // Where its points went: "object/label (N points: plane:count ..., none:count)".
    std::string where = scene.faces[f].object + "/" + scene.faces[f].label + " (" +
                        std::to_string(face_count.at(f)) + " points:";
    int assigned = 0;
    for (const auto& [key, n] : overlap)
      if (key.second == f) {
        where += " plane" + std::to_string(key.first) + "[" + std::to_string(plane_count.at(key.first)) +
                 "]:" + std::to_string(n);
        assigned += n;
      }
    where += " none:" + std::to_string(face_count.at(f) - assigned) + ")";
    e.missed_faces.push_back(where);
    if (o.segmenter) continue;
    for (std::size_t si = 0; si < sw.segments.size(); ++si) {
      const core::Segment3& s = sw.segments[si];
      const auto it = truth.find(sw.lines[s.line].stamp);
      if (it == truth.end()) continue;
      std::map<int, int> faces;
      for (int i = s.first; i <= s.last; ++i) ++faces[it->second.face[i]];
      const int pl = sw.segment_plane[si];
      const auto on_face = overlap.find({pl, f});
      const auto on_it = faces.find(f);
      if ((on_it == faces.end() || on_it->second < 3) && !(on_face != overlap.end() && on_face->second >= 0.1 * face_count.at(f))) continue;
      int mf = -1, mn = -1;
      for (const auto& [face, n] : faces)
        if (n > mn) {
          mn = n;
          mf = face;
        }
      e.missed_segments.push_back(
          scene.faces[f].label + ": line " + std::to_string(s.line) + " beams " + std::to_string(s.first) + "-" +
          std::to_string(s.last) + " (" + std::to_string(static_cast<int>(s.moments.n)) + " points, " +
          std::to_string(on_it == faces.end() ? 0 : on_it->second) + " on it, mostly " +
          (mf >= 0 ? scene.faces[mf].object + "/" + scene.faces[mf].label : std::string("none")) + ") -> plane " +
          std::to_string(pl));
    }
  }

  // The sweep's own map, its origin relative to the base (as today's grouper
  // keeps it in its frame), and the map fused over sweeps, against the truth.
  const Eigen::Vector3d at = base.translation();
  core::HeightMapParams hp = o.heightmap;
  hp.origin_x = std::round((at.x() + hp.origin_x) / hp.resolution) * hp.resolution;
  hp.origin_y = std::round((at.y() + hp.origin_y) / hp.resolution) * hp.resolution;
  const double t0 = cpuNow();
  core::buildHeightMap(sw, hp, grid);
  latency += cpuNow() - t0;
  const std::string frame = o.walk.walking() ? "odom" : "base_footprint";
  if (!o.dump_prefix.empty()) dumpSweep(sw, grid, o.dump_prefix, base, frame);
  const Eigen::Vector3d eye = core::meanOrigin(sw);
  std::vector<float> sweep_sigmas;
  core::sweepUncertainty(grid, eye, o.fused, sweep_sigmas);
  // The map's cells that the sweep's points fell in on their true surface
  // (within 2 cm of its height): where the sensor saw the surface, and by
  // which line (its index; -1: two lines or more).
  LineCells on_surface;
  for (int li = 0; li < static_cast<int>(sw.lines.size()); ++li)
    for (const Eigen::Vector3f& q : sw.lines[li].points) {
      if (!q.allFinite()) continue;
      const long i = std::lround(std::floor(q.x() / hp.resolution)), j = std::lround(std::floor(q.y() / hp.resolution));
      if (!(std::abs(q.z() - truth_h.at(i, j)) <= 0.02)) continue;
      const auto [it, fresh] = on_surface.emplace(cellKey(i, j), li);
      if (!fresh && it->second != li) it->second = -1;
    }
  const MapScore single =
      scoreMap(grid, truth_h, base, o, nullptr, 0.0, &scene, &eye, &sw.planes, &sweep_sigmas, &on_surface);
  e.steppable_precision = single.steppable_precision;
  e.steppable_recall = single.steppable_recall;
  e.heightmap_rmse_m = single.rmse;
  e.walkable_rmse_m = single.walkable_rmse;
  e.overconfident = single.overconfident;
  e.step_edge_median_m = single.edge_median;
  e.step_edge_p95_m = single.edge_p95;
  e.step_edge_unknown = single.edge_unknown;
  e.invented = single.invented;
  e.heightmap_coverage = single.coverage;
  e.front_coverage = single.front;
  const double f0 = cpuNow();
  fused.recentre(at.x(), at.y());
  fused.addSweep(sw, core::meanOrigin(sw), sw.end, travelled);
  e.fused_ms = (cpuNow() - f0) * 1e3;
  if (!o.dump_prefix.empty()) dumpSweep(sw, fused.grid(), o.dump_prefix + "_fused", base, frame, true);
  // Every point of the sweep, in the fused map's cells (forgotten as the map forgets).
  const double fr = fused.grid().params.resolution;
  for (const core::SweepLine& line : sw.lines)
    for (const Eigen::Vector3f& q : line.points)
      if (q.allFinite()) hits[cellKey(std::lround(std::floor(q.x() / fr)), std::lround(std::floor(q.y() / fr)))] = sw.end;
  std::vector<float> sigmas, ages;
  fused.uncertainty(sw.end, travelled, sigmas, ages);
  const MapScore f = scoreMap(fused.grid(), truth_fused, base, o, &hits, sw.end - o.fused.forget_time, nullptr,
                              nullptr, nullptr, &sigmas);
  e.fused_rmse_m = f.rmse;
  e.fused_walkable_rmse_m = f.walkable_rmse;
  e.fused_overconfident = f.overconfident;
  e.fused_coverage = f.coverage;
  e.fused_front_coverage = f.front;
  e.front_observable = f.front_observable;
  e.travelled_m = travelled;
  double split = 0.0;
  for (const auto& line : sw.lines) {
    const auto it = split_time.find(line.stamp);
    if (it != split_time.end()) split += it->second;
  }
  e.split_ms = split * 1e3;
  e.group_ms = (sw.group_seconds + latency) * 1e3;
  e.latency_ms = latency * 1e3;
  return e;
}
}  // namespace

std::vector<SweepEval> evaluateScene(const SceneEvalOptions& o) {
  const Scene scene = loadScene(o.scene);
  const bool spin = o.profile.mode == core::TiltProfileParams::Mode::Spin;
  const HeadGeometry head = HeadGeometry::load(
      o.head_file.empty() ? configDirectory() + (spin ? "/head_spin.yaml" : "/head.yaml") : o.head_file);
  if (head.spinning != spin || spin != (o.sweep.spin_span > 0.0))
    throw std::runtime_error("a spinning head needs the spin profile and sweeps cut by angle, a nodding one neither");
  ServoModel servo(spin ? 0.0 : o.profile.min_angle, 0.0);
  SweepController sweep(servo, o.profile);
  HeadSimulator head_sim(scene, head, servo, o.noise, o.seed, LidarModel(), o.rig);
  const WalkModel walk(scene, o.walk);
  if (o.walk.walking()) head_sim.setWalk(&walk);
  const LidarModel& m = head_sim.model();
  // The odometry's pose of the base at every line's time (the tf a robot gives).
  core::SweepAssembler::BasePose base_pose;
  if (o.walk.walking() && o.pose_per_line)
    base_pose = [&walk](double t, Eigen::Isometry3d& pose) {
      pose = walk.odomPose(t);
      return core::SweepAssembler::PoseStatus::Ok;
    };
  core::SweepAssembler assembler(o.sweep, o.calibration.correct(head.chain()), base_pose);
  core::ScanSplitter splitter(o.split);
  core::SplitResult split;
  HeadScan hs;
  std::map<double, LineTruth> truth;
  std::map<double, double> split_time;
  std::vector<SweepEval> out;
  core::HeightMapGrid grid;
  core::FusedHeightMap fused(o.heightmap, o.fused);
  HitCells hits;
  TruthHeights truth_h(scene, o.heightmap.resolution, head.axis_origin.z());
  const double fused_res = fused.grid().params.resolution;  // its own cells, or the sweep map's
  std::unique_ptr<TruthHeights> own_fused_truth;
  if (fused_res != o.heightmap.resolution)
    own_fused_truth = std::make_unique<TruthHeights>(scene, fused_res, head.axis_origin.z());
  TruthHeights& truth_f = own_fused_truth ? *own_fused_truth : truth_h;
  double next_joint = 0.0, next_scan = 0.0;
  const double joint_period = 1.0 / o.joint_rate;
  for (double t = 0.0; static_cast<int>(out.size()) < o.sweeps && t < 600.0; t += 0.001) {
    sweep.update(t);
    if (t + 1e-9 >= next_joint) {
      double q = servo.reading(t);
      if (spin) q = std::remainder(q, 2.0 * M_PI);  // a servo reads its position within one turn
      if (o.quantize_joint) q = dynamixel::positionToRad(dynamixel::radToPosition(q));
      q += o.calibration.joint_offset;
      if (o.on_joint) o.on_joint(t, q);
      assembler.addJoint(t, q);
      next_joint += joint_period;
    }
    if (t + 1e-9 >= next_scan + m.scan_period) {
      head_sim.scan(next_scan, hs);
      if (o.echo != scip::EchoChoice::First) selectEcho(hs.scan, o.echo);
      const double s0 = cpuNow();
      splitter.split(hs.scan.view(), split);
      const double st = cpuNow() - s0;
      core::LineInput in;
      in.ranges = hs.scan.ranges;
      in.angle_min = m.angleMin();
      in.angle_increment = m.angle_increment;
      in.range_min = m.range_min;
      in.range_max = m.range_max;
      const double stamp = next_scan - o.calibration.time_offset;
      in.stamp = stamp;
      in.time_increment = m.timeIncrement();
      for (const auto& s : split.segments) in.segments.emplace_back(s.first, s.last);
      for (const auto& e : split.edges) in.edges.emplace_back(e.index, e.kind);
      LineTruth lt;
      lt.face = hs.scan.face;
      lt.ranges = hs.scan.ranges;
      lt.edges = hs.scan.edges;
      lt.found = split.edges;
      for (const unsigned char m : hs.scan.mixed) lt.mixed += m;
      lt.is_mixed = hs.scan.mixed;
      for (const auto& s : split.segments) {
        int mixed = 0;
        for (int i = s.first; i <= s.last; ++i) mixed += hs.scan.mixed[i];
        lt.veil_segments += 2 * mixed > s.count;
        lt.mixed_in_segments += mixed;
        lt.overhanging += core::segmentOverhang(hs.scan.view(), s) > 0.01;
      }
      truth[stamp] = std::move(lt);
      split_time[stamp] = st;
      assembler.addLine(std::move(in), t);
      next_scan += m.scan_period;
    }
    core::SweepResult done;
    while (assembler.poll(t, done)) {
      const Eigen::Isometry3d end_pose = walk.odomPose(done.end);
      // Without a pose per line: the sweep as the head saw it, put where the base was at its end.
      if (o.walk.walking() && !o.pose_per_line) core::transformSweep(done, end_pose);
      if (o.on_sweep) o.on_sweep(done);
      out.push_back(judge(scene, truth_h, truth_f, done, truth, split_time, o, done.finish_seconds, end_pose,
                          walk.travelled(done.end), grid, fused, hits));
      // Forget the truth of lines before this sweep.
      truth.erase(truth.begin(), truth.lower_bound(done.start));
    }
  }
  return out;
}

void dumpSweep(const core::SweepResult& sw, const core::HeightMapGrid& grid, const std::string& prefix,
               const Eigen::Isometry3d& robot, const std::string& frame, bool fused) {
  if (std::FILE* f = std::fopen((prefix + "_planes.csv").c_str(), "w")) {
    std::fprintf(f, "kind,id,a,b,c,d,e,f,g\n");
    for (const core::Plane& p : sw.planes) {
      std::fprintf(f, "plane,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f\n", p.id, p.area, p.fit.normal.x(), p.fit.normal.y(),
                   p.fit.normal.z(), p.fit.centroid.x(), p.fit.centroid.y(), p.fit.centroid.z());
      for (const auto& v : p.boundary) std::fprintf(f, "vertex,%d,%.4f,%.4f,%.4f,,,,\n", p.id, v.x(), v.y(), v.z());
    }
    std::fclose(f);
  }
  if (std::FILE* f = std::fopen((prefix + "_heightmap.bin").c_str(), "wb")) {
    std::fwrite(grid.heights.data(), sizeof(float), grid.heights.size(), f);
    std::fclose(f);
  }
  if (std::FILE* f = std::fopen((prefix + "_heightmap.txt").c_str(), "w")) {
    std::fprintf(f, "%f %f %f %d %d\n", grid.params.origin_x, grid.params.origin_y, grid.params.resolution,
                 grid.params.width, grid.params.height);
    const Eigen::Vector3d x = robot.linear().col(0);
    std::fprintf(f, "robot %f %f %f %s %s\n", robot.translation().x(), robot.translation().y(), std::atan2(x.y(), x.x()),
                 frame.c_str(), fused ? "fused" : "sweep");
    std::fclose(f);
  }
}

std::string evalCsvHeader() {
  return "sweep,lines,planes,true_faces,correct,over,under,missed,noise,normal_err_deg,offset_err_m,edge_precision,"
         "edge_recall,heightmap_rmse_m,heightmap_coverage,split_ms,group_ms,latency_ms,veil_segments,overhanging_segments,"
         "front_coverage,fused_rmse_m,fused_coverage,fused_front_coverage,fused_ms,travelled_m,mixed_pixels,"
         "mixed_in_segments,front_observable,walkable_rmse_m,fused_walkable_rmse_m,invented,steppable_precision,"
         "steppable_recall,fused_overconfident,step_edge_median_m,step_edge_p95_m,overconfident,step_edge_unknown";
}

std::string evalCsvRow(int sweep, const SweepEval& e) {
  char buf[800];
  std::snprintf(buf, sizeof(buf),
                "%d,%d,%d,%d,%d,%d,%d,%d,%d,%.3f,%.4f,%.3f,%.3f,%.4f,%.3f,%.2f,%.2f,%.3f,%d,%d,%.3f,%.4f,%.3f,%.3f,%.3f,%.3f,"
                "%d,%d,%.3f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.3f,%.3f,%.4f,%.4f",
                sweep, e.lines, e.planes, e.true_faces, e.correct, e.over, e.under, e.missed, e.noise,
                e.normal_err_deg, e.offset_err_m, e.edge_precision, e.edge_recall, e.heightmap_rmse_m,
                e.heightmap_coverage, e.split_ms, e.group_ms, e.latency_ms, e.veil_segments, e.overhanging_segments,
                e.front_coverage, e.fused_rmse_m, e.fused_coverage, e.fused_front_coverage, e.fused_ms, e.travelled_m,
                e.mixed_pixels, e.mixed_in_segments, e.front_observable, e.walkable_rmse_m, e.fused_walkable_rmse_m,
                e.invented, e.steppable_precision, e.steppable_recall, e.fused_overconfident, e.step_edge_median_m,
                e.step_edge_p95_m, e.overconfident, e.step_edge_unknown);
  return buf;
}

std::string evalSummary(const std::vector<SweepEval>& ev) {
  const double kNan = std::numeric_limits<double>::quiet_NaN();
  SweepEval s;
  const double n = ev.empty() ? 1.0 : static_cast<double>(ev.size());
  double correct = 0, over = 0, under = 0, missed = 0, noise = 0;
  int veil = 0, overhanging = 0;
  double mixed = 0, mixed_in = 0, edge_median = 0, edge_p95 = 0, edge_unknown = 0;
  int edge_sweeps = 0, edge_seen_sweeps = 0;
  // The front of the feet is judged once the robot has walked its length
  // (before, the fused map has only what a standing robot sees): over the
  // sweeps after 1 m walked, or all when it stands.
  bool walked = false;
  for (const SweepEval& e : ev) walked = walked || e.travelled_m > 0.0;
  double front = 0.0, fused_front = 0.0, observable = 0.0;
  int front_n = 0;
  for (const SweepEval& e : ev) {
    if (!walked || e.travelled_m >= 1.0) {
      front += e.front_coverage;
      fused_front += e.fused_front_coverage;
      observable += e.front_observable;
      ++front_n;
    }
    s.fused_rmse_m += e.fused_rmse_m / n;
    s.fused_coverage += e.fused_coverage / n;
    s.fused_ms += e.fused_ms / n;
    veil += e.veil_segments;
    overhanging += e.overhanging_segments;
    mixed += e.mixed_pixels / n;
    mixed_in += e.mixed_in_segments / n;
    correct += e.correct;
    over += e.over;
    under += e.under;
    missed += e.missed;
    noise += e.noise;
    s.normal_err_deg += e.normal_err_deg / n;
    s.offset_err_m += e.offset_err_m / n;
    s.edge_precision += e.edge_precision / n;
    s.edge_recall += e.edge_recall / n;
    s.heightmap_rmse_m += e.heightmap_rmse_m / n;
    s.walkable_rmse_m += e.walkable_rmse_m / n;
    s.fused_walkable_rmse_m += e.fused_walkable_rmse_m / n;
    s.fused_overconfident += e.fused_overconfident / n;
    s.overconfident += e.overconfident / n;
    if (!std::isnan(e.step_edge_median_m)) {  // sweeps that saw a step edge
      edge_median += e.step_edge_median_m;
      edge_p95 += e.step_edge_p95_m;
      ++edge_sweeps;
    }
    if (!std::isnan(e.step_edge_unknown)) {  // sweeps with a step edge in view
      edge_unknown += e.step_edge_unknown;
      ++edge_seen_sweeps;
    }
    s.invented += e.invented / n;
    s.steppable_precision += e.steppable_precision / n;
    s.steppable_recall += e.steppable_recall / n;
    s.heightmap_coverage += e.heightmap_coverage / n;
    s.split_ms += e.split_ms / n;
    s.group_ms += e.group_ms / n;
    s.latency_ms += e.latency_ms / n;
  }
  if (front_n) {
    front /= front_n;
    fused_front /= front_n;
    observable /= front_n;
  }
  char buf[1536];
  std::snprintf(buf, sizeof(buf),
                "correct=%.2f over=%.2f under=%.2f missed=%.2f noise=%.2f normal_err_deg=%.3f offset_err_m=%.4f "
                "edge_precision=%.3f edge_recall=%.3f heightmap_rmse_m=%.4f heightmap_coverage=%.3f split_ms=%.2f "
                "group_ms=%.2f latency_ms=%.3f veil_segments=%d overhanging_segments=%d front_coverage=%.3f "
                "fused_rmse_m=%.4f fused_coverage=%.3f fused_front_coverage=%.3f fused_ms=%.3f mixed_pixels=%.1f "
                "mixed_in_segments=%.1f front_observable=%.3f walkable_rmse_m=%.4f fused_walkable_rmse_m=%.4f "
                "invented=%.4f steppable_precision=%.4f steppable_recall=%.4f fused_overconfident=%.4f "
                "step_edge_median_m=%.3f step_edge_p95_m=%.3f overconfident=%.4f step_edge_unknown=%.4f",
                correct / n, over / n, under / n, missed / n, noise / n, s.normal_err_deg, s.offset_err_m,
                s.edge_precision, s.edge_recall, s.heightmap_rmse_m, s.heightmap_coverage, s.split_ms, s.group_ms,
                s.latency_ms, veil, overhanging, front, s.fused_rmse_m, s.fused_coverage, fused_front, s.fused_ms, mixed,
                mixed_in, observable, s.walkable_rmse_m, s.fused_walkable_rmse_m, s.invented, s.steppable_precision,
                s.steppable_recall, s.fused_overconfident, edge_sweeps ? edge_median / edge_sweeps : kNan,
                edge_sweeps ? edge_p95 / edge_sweeps : kNan, s.overconfident,
                edge_seen_sweeps ? edge_unknown / edge_seen_sweeps : kNan);
  return buf;
}

}  // namespace sim
}  // namespace tilt_laser_perception
