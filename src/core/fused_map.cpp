#include "tilt_laser_perception/core/fused_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tilt_laser_perception {
namespace core {

std::string FusedMapParams::validate() const {
  if (!(size > 0.0) || !std::isfinite(size)) return "size must be positive";
  if (!(forget_time > 0.0)) return "forget_time must be positive";
  if (!(sigma_min > 0.0) || !(sigma_range >= 0.0) || !std::isfinite(sigma_range)) return "sigma_min must be positive, sigma_range not negative";
  if (!(drift_per_metre >= 0.0) || !std::isfinite(drift_per_metre)) return "drift_per_metre must not be negative";
  if (!(gate > 0.0)) return "gate must be positive";
  if (!(min_plane_overlap > 0.0 && min_plane_overlap <= 1.0)) return "min_plane_overlap must be in (0, 1]";
  return "";
}

namespace {
const float kNaN = std::numeric_limits<float>::quiet_NaN();

/// Moves a row-major grid by (dx, dy) cells: new (ix, iy) = old (ix + dx, iy + dy); `fill` where there was none.
template <class T>
void shiftGrid(std::vector<T>& v, int w, int h, int dx, int dy, const T& fill, std::vector<T>& scratch) {
  scratch.assign(v.size(), fill);
  const int x0 = std::max(0, -dx), x1 = std::min(w, w - dx);
  if (x1 > x0)
    for (int iy = std::max(0, -dy); iy < std::min(h, h - dy); ++iy)
      std::copy(v.begin() + (static_cast<std::size_t>(iy + dy) * w + x0 + dx),
                v.begin() + (static_cast<std::size_t>(iy + dy) * w + x1 + dx),
                scratch.begin() + (static_cast<std::size_t>(iy) * w + x0));
  v.swap(scratch);
}
}  // namespace

FusedHeightMap::FusedHeightMap(const HeightMapParams& cells, const FusedMapParams& params) : p_(params) {
  grid_.params = cells;
  const int n = std::max(1, static_cast<int>(std::lround(p_.size / cells.resolution)));
  grid_.params.width = grid_.params.height = n;
  clear();
}

void FusedHeightMap::clear() {
  const std::size_t cells = static_cast<std::size_t>(grid_.params.width) * grid_.params.height;
  grid_.heights.assign(cells, kNaN);
  grid_.plane_ids.assign(cells, -1);
  grid_.classes.assign(cells, CellClass::Unknown);
  grid_.floor_plane = -1;
  grid_.floor_height = std::numeric_limits<double>::quiet_NaN();
  var_.assign(cells, kNaN);
  seen_.assign(cells, std::numeric_limits<double>::quiet_NaN());
  walked_.assign(cells, 0.0f);
  planes_.clear();
}

void FusedHeightMap::recentre(double x, double y) {
  HeightMapParams& g = grid_.params;
  const double r = g.resolution;
  // The corner on the cell lattice (multiples of the resolution), so cells keep their place in the frame.
  const double ox = std::round((x - 0.5 * g.width * r) / r) * r, oy = std::round((y - 0.5 * g.height * r) / r) * r;
  if (!placed_) {
    g.origin_x = ox;
    g.origin_y = oy;
    placed_ = true;
    return;
  }
  const int dx = static_cast<int>(std::lround((ox - g.origin_x) / r)), dy = static_cast<int>(std::lround((oy - g.origin_y) / r));
  if (dx == 0 && dy == 0) return;
  g.origin_x += dx * r;
  g.origin_y += dy * r;
  if (std::abs(dx) >= g.width || std::abs(dy) >= g.height) {
    const HeightMapParams keep = g;
    clear();
    grid_.params = keep;
    return;
  }
  const int w = g.width, h = g.height;
  std::vector<float> sf;
  shiftGrid(grid_.heights, w, h, dx, dy, kNaN, sf);
  shiftGrid(var_, w, h, dx, dy, kNaN, sf);
  shiftGrid(walked_, w, h, dx, dy, 0.0f, sf);
  std::vector<std::int32_t> si;
  shiftGrid(grid_.plane_ids, w, h, dx, dy, -1, si);
  std::vector<CellClass> sc;
  shiftGrid(grid_.classes, w, h, dx, dy, CellClass::Unknown, sc);
  std::vector<double> sd;
  shiftGrid(seen_, w, h, dx, dy, std::numeric_limits<double>::quiet_NaN(), sd);
}

double FusedHeightMap::sigma(std::size_t c, double travelled) const {
  if (std::isnan(grid_.heights[c])) return std::numeric_limits<double>::quiet_NaN();
  const double drift = p_.drift_per_metre * std::max(0.0, travelled - walked_[c]);
  return std::sqrt(var_[c] + drift * drift);
}

double FusedHeightMap::lastSeen(std::size_t c) const { return seen_[c]; }

void FusedHeightMap::addSweep(const SweepResult& sweep, const Eigen::Vector3d& sensor, double stamp, double travelled) {
  placed_ = true;
  const HeightMapParams& g = grid_.params;
  buildHeightMap(sweep, g, sweep_);
  const float gate2 = static_cast<float>(p_.gate * p_.gate);
  const float sigma_floor2 = static_cast<float>(0.25 * p_.sigma_min * p_.sigma_min);
  const float tolerance = static_cast<float>(g.obstacle_min_height);

  // The cells the sweep's points fell in (mixed pixels aside), with their
  // lowest and highest point, and the box around them: what the sweep saw.
  int bx0 = g.width, by0 = g.height, bx1 = -1, by1 = -1;
  for (std::size_t c : touched_) {
    pmin_[c] = kNaN;
    pmax_[c] = kNaN;
  }
  touched_.clear();
  if (pmin_.size() != grid_.heights.size()) {
    pmin_.assign(grid_.heights.size(), kNaN);
    pmax_.assign(grid_.heights.size(), kNaN);
  }
  const float inv_res = static_cast<float>(1.0 / g.resolution), ox = static_cast<float>(g.origin_x),
              oy = static_cast<float>(g.origin_y);
  for (const SweepLine& line : sweep.lines) {
    std::size_t ei = 0;
    for (std::size_t i = 0; i < line.points.size(); ++i) {
      const Eigen::Vector3f& q = line.points[i];
      const float fx = (q.x() - ox) * inv_res, fy = (q.y() - oy) * inv_res;  // NaN fails the tests below
      if (!(fx >= 0.0f && fy >= 0.0f && fx < g.width && fy < g.height)) continue;
      while (ei < line.edges.size() && line.edges[ei].first < static_cast<int>(i)) ++ei;
      if (ei < line.edges.size() && line.edges[ei].first == static_cast<int>(i) && line.edges[ei].second == EdgeKind::Veil)
        continue;
      const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
      const std::size_t c = grid_.index(ix, iy);
      if (std::isnan(pmin_[c])) {
        pmin_[c] = pmax_[c] = q.z();
        touched_.push_back(c);
      } else {
        pmin_[c] = std::min(pmin_[c], q.z());
        pmax_[c] = std::max(pmax_[c], q.z());
      }
      bx0 = std::min(bx0, ix);
      bx1 = std::max(bx1, ix);
      by0 = std::min(by0, iy);
      by1 = std::max(by1, iy);
    }
  }
  // The walkable planes' polygons reach past their points (to the rays that bound them).
  for (const Plane& pl : sweep.planes)
    for (const Eigen::Vector3d& v : pl.boundary) {
      const int ix = static_cast<int>(std::floor((v.x() - g.origin_x) * inv_res)),
                iy = static_cast<int>(std::floor((v.y() - g.origin_y) * inv_res));
      bx0 = std::min(bx0, ix);
      bx1 = std::max(bx1, ix);
      by0 = std::min(by0, iy);
      by1 = std::max(by1, iy);
    }
  bx0 = std::max(bx0, 0);
  by0 = std::max(by0, 0);
  bx1 = std::min(bx1, g.width - 1);
  by1 = std::min(by1, g.height - 1);

  // The variance of each new cell's height: it grows with the range it was seen from.
  const auto newVariance = [&](int ix, int iy, float z) {
    const double dx = g.origin_x + (ix + 0.5) * g.resolution - sensor.x(),
                 dy = g.origin_y + (iy + 0.5) * g.resolution - sensor.y(), dz = z - sensor.z();
    const double s = p_.sigma_min + p_.sigma_range * std::sqrt(dx * dx + dy * dy + dz * dz);
    return static_cast<float>(s * s);
  };
  const auto oldVariance = [&](std::size_t c) {
    const float drift = static_cast<float>(p_.drift_per_metre) * std::max(0.0f, static_cast<float>(travelled) - walked_[c]);
    return var_[c] + drift * drift;
  };

  // Persistent plane ids: each new walkable plane votes with its cells (every
  // 4th in x and y) for the old id of the cells it agrees with; it takes the
  // id with most votes when they are min_plane_overlap of its cells, and no
  // other new plane took more of that id's (one new plane per old id; the
  // rest get new ids).
  std::map<int, int> size;                   // new plane -> cells sampled
  std::map<std::pair<int, int>, int> votes;  // (new, old) -> agreeing cells sampled
  for (int iy = by0; iy <= by1; iy += 4)
    for (int ix = bx0; ix <= bx1; ix += 4) {
      const std::size_t c = grid_.index(ix, iy);
      const int pn = sweep_.plane_ids[c];
      if (pn < 0) continue;
      ++size[pn];
      const int po = grid_.plane_ids[c];
      if (po < 0) continue;
      const float d = sweep_.heights[c] - grid_.heights[c];
      if (d * d <= gate2 * (newVariance(ix, iy, sweep_.heights[c]) + oldVariance(c))) ++votes[{pn, po}];
    }
  std::vector<std::pair<int, std::pair<int, int>>> ranked;  // (votes, (new, old))
  for (const auto& [key, n] : votes)
    if (n >= p_.min_plane_overlap * size[key.first]) ranked.push_back({n, key});
  std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<int> id_of(sweep.planes.size() + 1, -1);  // new plane -> persistent id
  std::map<int, int> taken;                             // persistent id -> new plane
  for (const auto& [n, key] : ranked)
    if (id_of[key.first] < 0 && !taken.count(key.second)) {
      id_of[key.first] = key.second;
      taken[key.second] = key.first;
    }
  // Small planes may have no sampled cell: every plane that has cells gets an id.
  for (int iy = by0; iy <= by1; ++iy)
    for (int ix = bx0; ix <= bx1; ++ix) {
      const int pn = sweep_.plane_ids[grid_.index(ix, iy)];
      if (pn >= 0 && id_of[pn] < 0) id_of[pn] = next_id_++;
    }
  for (const Plane& pl : sweep.planes) {
    if (pl.id < 0 || pl.id >= static_cast<int>(id_of.size()) || id_of[pl.id] < 0) continue;
    TerrainPlane& tp = planes_[id_of[pl.id]];
    tp.plane = pl;
    tp.plane.id = id_of[pl.id];
    tp.plane.members.clear();
    tp.last_seen = stamp;
  }

  // Fuse every cell the sweep saw. A cell it made no height for keeps its old
  // one unless the sweep's points in it disagree with that (a point well
  // below the old surface went through it; one well above stands on it): a
  // polygon that reached too far in an earlier sweep is taken back so.
  for (int iy = by0; iy <= by1; ++iy)
    for (int ix = bx0; ix <= bx1; ++ix) {
      const std::size_t c = grid_.index(ix, iy);
      const float hn = sweep_.heights[c], ho = grid_.heights[c];
      if (std::isnan(hn)) {
        if (!std::isnan(ho) && !std::isnan(pmin_[c]) && (pmin_[c] < ho - tolerance || pmax_[c] > ho + tolerance)) {
          grid_.heights[c] = kNaN;
          grid_.plane_ids[c] = -1;
          grid_.classes[c] = CellClass::Unknown;
          var_[c] = kNaN;
          seen_[c] = std::numeric_limits<double>::quiet_NaN();
        }
        continue;
      }
      const float vn = newVariance(ix, iy, hn);
      float h = hn, v = vn;
      if (!std::isnan(ho) && grid_.classes[c] == sweep_.classes[c]) {
        const float vo = oldVariance(c), d = hn - ho;
        if (d * d <= gate2 * (vn + vo)) {
          v = std::max(vo * vn / (vo + vn), sigma_floor2);
          h = (ho * vn + hn * vo) / (vo + vn);
        }
      }
      grid_.heights[c] = h;
      var_[c] = v;
      seen_[c] = stamp;
      walked_[c] = static_cast<float>(travelled);
      grid_.classes[c] = sweep_.classes[c];
      const int pn = sweep_.plane_ids[c];
      grid_.plane_ids[c] = pn >= 0 ? id_of[pn] : -1;
    }
  if (sweep_.floor_plane >= 0) {
    grid_.floor_plane = id_of[sweep_.floor_plane];
    grid_.floor_height = sweep_.floor_height;
  }
  forget(stamp);
}

void FusedHeightMap::forget(double now) {
  const double before = now - p_.forget_time;
  for (std::size_t c = 0; c < grid_.heights.size(); ++c)
    if (seen_[c] < before) {  // NaN (never seen) is not
      grid_.heights[c] = kNaN;
      grid_.plane_ids[c] = -1;
      grid_.classes[c] = CellClass::Unknown;
      var_[c] = kNaN;
      seen_[c] = std::numeric_limits<double>::quiet_NaN();
    }
  for (auto it = planes_.begin(); it != planes_.end();)
    it = it->second.last_seen < before ? planes_.erase(it) : std::next(it);
}

}  // namespace core
}  // namespace tilt_laser_perception
