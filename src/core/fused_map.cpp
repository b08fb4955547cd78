#include "tilt_laser_perception/core/fused_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tilt_laser_perception {
namespace core {

std::string FusedMapParams::validate() const {
  if (!(size > 0.0) || !std::isfinite(size)) return "size must be positive";
  if (!(resolution >= 0.0) || !std::isfinite(resolution) || resolution > 0.5 * size) return "resolution must be 0 (the sweep map's) or positive and under half the size";
  if (!(forget_time > 0.0)) return "forget_time must be positive";
  if (!(sigma_min > 0.0) || !(sigma_range >= 0.0) || !std::isfinite(sigma_range)) return "sigma_min must be positive, sigma_range not negative";
  if (!(drift_per_metre >= 0.0) || !std::isfinite(drift_per_metre)) return "drift_per_metre must not be negative";
  if (!(sigma_pose >= 0.0 && sigma_pose < 0.2)) return "sigma_pose must be in [0, 0.2) rad";
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
  if (p_.resolution > 0.0) grid_.params.resolution = p_.resolution;
  const int n = std::max(1, static_cast<int>(std::lround(p_.size / grid_.params.resolution)));
  grid_.params.width = grid_.params.height = n;
  clear();
}

void FusedHeightMap::setClassification(const HeightMapParams& p) {
  HeightMapParams& g = grid_.params;
  g.max_slope_deg = p.max_slope_deg;
  g.floor_tolerance = p.floor_tolerance;
  g.obstacle_min_height = p.obstacle_min_height;
  g.max_step_height = p.max_step_height;
}

void FusedHeightMap::clear() {
  const std::size_t cells = static_cast<std::size_t>(grid_.params.width) * grid_.params.height;
  grid_.heights.assign(cells, kNaN);
  grid_.plane_ids.assign(cells, -1);
  grid_.classes.assign(cells, CellClass::Unknown);
  grid_.floor_plane = -1;
  grid_.floor_height = std::numeric_limits<double>::quiet_NaN();
  var_.assign(cells, kNaN);
  bias_.assign(cells, kNaN);
  seen_.assign(cells, kNaN);
  have_epoch_ = false;
  walked_.assign(cells, 0.0f);
  row_oldest_.assign(static_cast<std::size_t>(grid_.params.height), std::numeric_limits<float>::infinity());
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
  shiftGrid(bias_, w, h, dx, dy, kNaN, sf);
  shiftGrid(walked_, w, h, dx, dy, 0.0f, sf);
  std::vector<std::int32_t> si;
  shiftGrid(grid_.plane_ids, w, h, dx, dy, -1, si);
  std::vector<CellClass> sc;
  shiftGrid(grid_.classes, w, h, dx, dy, CellClass::Unknown, sc);
  shiftGrid(seen_, w, h, dx, dy, kNaN, sf);
  // The rows' bounds move with their rows (a bound stays one when cells leave a row).
  shiftGrid(row_oldest_, 1, h, 0, dy, std::numeric_limits<float>::infinity(), sf);
}

void FusedHeightMap::forgetCell(std::size_t c) {
  grid_.heights[c] = kNaN;
  grid_.plane_ids[c] = -1;
  grid_.classes[c] = CellClass::Unknown;
  var_[c] = kNaN;
  bias_[c] = kNaN;
  seen_[c] = kNaN;
}

double FusedHeightMap::sigma(std::size_t c, double travelled) const {
  if (std::isnan(grid_.heights[c])) return std::numeric_limits<double>::quiet_NaN();
  const double drift = p_.drift_per_metre * std::max(0.0, travelled - walked_[c]);
  return std::sqrt(var_[c] + bias_[c] * bias_[c] + drift * drift);
}

double FusedHeightMap::lastSeen(std::size_t c) const { return epoch_ + seen_[c]; }

void FusedHeightMap::uncertainty(double now, double travelled, std::vector<float>& sigmas, std::vector<float>& ages) const {
  const std::size_t n = grid_.heights.size();
  sigmas.resize(n);
  ages.resize(n);
  const float t = static_cast<float>(now - epoch_), walked = static_cast<float>(travelled),
              drift = static_cast<float>(p_.drift_per_metre);
  for (std::size_t c = 0; c < n; ++c) {
    const bool known = !std::isnan(grid_.heights[c]);
    const float d = drift * std::max(0.0f, walked - walked_[c]);
    sigmas[c] = known ? std::sqrt(var_[c] + bias_[c] * bias_[c] + d * d) : kNaN;
    ages[c] = known ? t - seen_[c] : kNaN;
  }
}

SweepNoise::SweepNoise(const FusedMapParams& p, const HeightMapParams& g, const Eigen::Vector3d& sensor)
    : s0_(static_cast<float>(p.sigma_min * p.sigma_min)),
      k2_(static_cast<float>(p.sigma_range * p.sigma_range)),
      pose_(static_cast<float>(p.sigma_pose)),
      sx_(static_cast<float>(sensor.x() - g.origin_x)),
      sy_(static_cast<float>(sensor.y() - g.origin_y)),
      sz_(static_cast<float>(sensor.z())),
      res_(static_cast<float>(g.resolution)) {}

void sweepUncertainty(const HeightMapGrid& grid, const Eigen::Vector3d& sensor, const FusedMapParams& p,
                      std::vector<float>& sigmas) {
  // SweepNoise's variance plus its bias squared, in one sqrt a known cell:
  // s0 + (k2 + pose^2) (dx^2 + dy^2) + k2 dz^2. Run on every sweep the
  // grouper publishes (bench_sweep's sigma_ms). Every cell of the map's box
  // is computed without a branch (an unknown cell's NaN height gives NaN),
  // a row at a time in Eigen's vector arithmetic; only the cells beyond the
  // box are filled with NaN.
  const HeightMapParams& g = grid.params;
  const std::size_t n = grid.heights.size();
  sigmas.resize(n);
  const int x0 = std::max(0, grid.box_x0), x1 = std::min(grid.box_x1, g.width - 1);
  const int y0 = std::max(0, grid.box_y0), y1 = std::min(grid.box_y1, g.height - 1);
  if (x1 < x0 || y1 < y0) {
    std::fill(sigmas.begin(), sigmas.end(), kNaN);
    return;
  }
  const float s0 = static_cast<float>(p.sigma_min * p.sigma_min), k2 = static_cast<float>(p.sigma_range * p.sigma_range);
  const float kh = k2 + static_cast<float>(p.sigma_pose * p.sigma_pose), res = static_cast<float>(g.resolution);
  const float sx = static_cast<float>(sensor.x() - g.origin_x), sy = static_cast<float>(sensor.y() - g.origin_y),
              sz = static_cast<float>(sensor.z());
  const int bw = x1 - x0 + 1;
  Eigen::ArrayXf dx2(bw);  // dx^2 of the box's columns
  for (int k = 0; k < bw; ++k) {
    const float dx = (x0 + k + 0.5f) * res - sx;
    dx2[k] = dx * dx;
  }
  std::fill_n(sigmas.begin(), grid.index(x0, y0), kNaN);
  for (int iy = y0; iy <= y1; ++iy) {
    const float dy = (iy + 0.5f) * res - sy;
    const std::size_t c0 = grid.index(x0, iy);
    const Eigen::Map<const Eigen::ArrayXf> h(grid.heights.data() + c0, bw);
    Eigen::Map<Eigen::ArrayXf> out(sigmas.data() + c0, bw);
    out = ((s0 + kh * (dx2 + dy * dy)) + (k2 * (h - sz)) * (h - sz)).sqrt();
    // Beyond the box: from this row's end to the next row's start (or the map's end).
    const std::size_t end = iy < y1 ? grid.index(x0, iy + 1) : n;
    std::fill(sigmas.begin() + c0 + bw, sigmas.begin() + end, kNaN);
  }
}

void FusedHeightMap::addSweep(const SweepResult& sweep, const Eigen::Vector3d& sensor, double stamp, double travelled) {
  placed_ = true;
  if (!have_epoch_) {
    epoch_ = stamp;
    have_epoch_ = true;
  }
  const float now = static_cast<float>(stamp - epoch_);
  const HeightMapParams& g = grid_.params;
  buildHeightMap(sweep, g, sweep_);
  const float gate2 = static_cast<float>(p_.gate * p_.gate);
  const float sigma_floor2 = static_cast<float>(0.25 * p_.sigma_min * p_.sigma_min);

  // The cells the sweep's own map gave a height.
  const int bx0 = sweep_.box_x0, bx1 = sweep_.box_x1, by0 = sweep_.box_y0, by1 = sweep_.box_y1;
  const double inv_res = 1.0 / g.resolution;

  // A new height's variance and the head pose's share of its error (SweepNoise).
  const SweepNoise fresh(p_, g, sensor);
  const auto newVariance = [&](int ix, int iy, float z) { return fresh.variance(ix, iy, z); };
  const auto newBias = [&](int ix, int iy) { return fresh.bias(ix, iy); };
  const float drift = static_cast<float>(p_.drift_per_metre), walked_now = static_cast<float>(travelled);
  const auto oldVariance = [&](std::size_t c) {
    const float d = drift * std::max(0.0f, walked_now - walked_[c]);
    return var_[c] + d * d;
  };

  // Persistent plane ids: each new walkable plane votes with its cells (every
  // 4th in x and y) for the old id of the cells it agrees with; it takes the
  // id with most votes when they are min_plane_overlap of its cells, and no
  // other new plane took more of that id's (one new plane per old id; the
  // rest get new ids).
  std::vector<int> size(sweep.planes.size(), 0);  // new plane -> cells sampled
  std::map<std::pair<int, int>, int> votes;       // (new, old) -> agreeing cells sampled
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
  std::vector<int> id_of(sweep.planes.size(), -1);  // new plane -> persistent id
  std::map<int, int> taken;                         // persistent id -> new plane
  for (const auto& [n, key] : ranked)
    if (id_of[key.first] < 0 && !taken.count(key.second)) {
      id_of[key.first] = key.second;
      taken[key.second] = key.first;
    }

  // Fuse every cell the sweep made a height for.
  for (int iy = by0; iy <= by1; ++iy) {
    const std::size_t row = grid_.index(0, iy);
    row_oldest_[iy] = std::min(row_oldest_[iy], now);
    for (int ix = bx0; ix <= bx1; ++ix) {
      const std::size_t c = row + ix;
      const float hn = sweep_.heights[c];
      if (std::isnan(hn)) continue;
      const float vn = newVariance(ix, iy, hn), bn = newBias(ix, iy), ho = grid_.heights[c];
      float h = hn, v = vn, b = bn;
      if (!std::isnan(ho) && grid_.classes[c] == sweep_.classes[c]) {
        // The gate and the weights by the errors that differ from sweep to
        // sweep; the pose's share, common to both, carried by the same weights.
        const float vo = oldVariance(c), d = hn - ho;
        if (d * d <= gate2 * (vn + vo)) {
          v = std::max(vo * vn / (vo + vn), sigma_floor2);
          h = (ho * vn + hn * vo) / (vo + vn);
          b = (bias_[c] * vn + bn * vo) / (vo + vn);
        }
      }
      grid_.heights[c] = h;
      var_[c] = v;
      bias_[c] = b;
      seen_[c] = now;
      walked_[c] = walked_now;
      grid_.classes[c] = sweep_.classes[c];
      const int pn = sweep_.plane_ids[c];
      if (pn >= 0 && id_of[pn] < 0) id_of[pn] = next_id_++;  // a new plane (or one too small to be sampled)
      grid_.plane_ids[c] = pn >= 0 ? id_of[pn] : -1;
    }
  }
  for (const Plane& pl : sweep.planes) {
    if (pl.id < 0 || pl.id >= static_cast<int>(id_of.size()) || id_of[pl.id] < 0) continue;
    TerrainPlane& tp = planes_[id_of[pl.id]];
    tp.plane = pl;
    tp.plane.id = id_of[pl.id];
    tp.plane.members.clear();
    tp.last_seen = stamp;
  }
  if (sweep_.floor_plane >= 0) {
    grid_.floor_plane = id_of[sweep_.floor_plane];
    grid_.floor_height = sweep_.floor_height;
  }

  // A cell the sweep made no height for keeps its old one unless the sweep's
  // points in it disagree with it by more than obstacle_min_height (below
  // it: a ray went through the old surface; above it: something stands
  // there, or a riser rises): a polygon that reached too far in an earlier
  // sweep is taken back so. Mixed pixels say nothing.
  const float tolerance = static_cast<float>(g.obstacle_min_height), ox = static_cast<float>(g.origin_x),
              oy = static_cast<float>(g.origin_y), inv_r = static_cast<float>(inv_res);
  // The points of walkable planes are in the cells their polygons filled, and
  // those of segments beside the map in none: skipped.
  const double cos_max = std::cos(g.max_slope_deg * M_PI / 180.0);
  std::vector<char> walkable(sweep.planes.size(), 0);
  for (const Plane& pl : sweep.planes)
    if (pl.id >= 0 && pl.id < static_cast<int>(walkable.size())) walkable[pl.id] = std::abs(pl.fit.normal.z()) >= cos_max;
  std::size_t si = 0;
  for (std::size_t li = 0; li < sweep.lines.size(); ++li) {
    const SweepLine& line = sweep.lines[li];
    std::size_t ei = 0;
    // Beams outside the line's returns have no point to look at.
    const auto [begin, end] = line.returns();
    for (std::size_t i = begin; i < static_cast<std::size_t>(end); ++i) {
      while (si < sweep.segments.size() &&
             (sweep.segments[si].line < static_cast<int>(li) ||
              (sweep.segments[si].line == static_cast<int>(li) && sweep.segments[si].last < static_cast<int>(i))))
        ++si;
      if (si < sweep.segments.size() && sweep.segments[si].line == static_cast<int>(li) &&
          sweep.segments[si].first <= static_cast<int>(i)) {
        const int pid = sweep.segment_plane[si];
        if ((pid >= 0 && pid < static_cast<int>(walkable.size()) && walkable[pid]) ||
            besideMap(sweep.segments[si], g)) {
          i = sweep.segments[si].last;  // the rest of the segment
          continue;
        }
      }
      const Eigen::Vector3f& q = line.points[i];
      const float fx = (q.x() - ox) * inv_r, fy = (q.y() - oy) * inv_r;
      if (!(fx >= 0.0f && fy >= 0.0f && fx < g.width && fy < g.height)) continue;  // NaN too
      const std::size_t c = grid_.index(static_cast<int>(fx), static_cast<int>(fy));
      const float ho = grid_.heights[c];
      if (!std::isnan(sweep_.heights[c]) || std::isnan(ho) || std::abs(q.z() - ho) <= tolerance) continue;
      while (ei < line.edges.size() && line.edges[ei].first < static_cast<int>(i)) ++ei;
      if (ei < line.edges.size() && line.edges[ei].first == static_cast<int>(i) && line.edges[ei].second == EdgeKind::Veil)
        continue;
      forgetCell(c);
    }
  }
  forget(stamp);
}

void FusedHeightMap::forget(double now) {
  const float before = static_cast<float>(now - p_.forget_time - epoch_);
  const int w = grid_.params.width;
  for (int iy = 0; iy < grid_.params.height; ++iy) {
    if (!(row_oldest_[iy] < before)) continue;  // nothing in this row is that old
    const std::size_t c0 = grid_.index(0, iy);
    float oldest = std::numeric_limits<float>::infinity();
    for (std::size_t c = c0; c < c0 + static_cast<std::size_t>(w); ++c) {
      if (seen_[c] < before) forgetCell(c);  // NaN (never seen) is not
      else if (seen_[c] < oldest) oldest = seen_[c];
    }
    row_oldest_[iy] = oldest;
  }
  for (auto it = planes_.begin(); it != planes_.end();)
    it = it->second.last_seen < now - p_.forget_time ? planes_.erase(it) : std::next(it);
}

void FusedMapTracker::addSweep(const SweepResult& sweep, const Eigen::Vector2d* robot) {
  if (sweep.end < last_end_ - 1.0) {  // the clock went back (a recording started again): so does the map
    map_.clear();
    robot_known_ = false;
    travelled_ = 0.0;
  }
  last_end_ = sweep.end;
  if (robot) {
    if (robot_known_) travelled_ += (*robot - robot_).norm();
    robot_ = *robot;
    robot_known_ = true;
  }
  map_.recentre(robot_.x(), robot_.y());
  map_.addSweep(sweep, meanOrigin(sweep), sweep.end, travelled_);
}

}  // namespace core
}  // namespace tilt_laser_perception
