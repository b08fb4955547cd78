#include "tilt_laser_perception/core/height_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tilt_laser_perception {
namespace core {

void buildHeightMap(const SweepResult& sweep, const HeightMapParams& p, HeightMapGrid& out) {
  const std::size_t cells = static_cast<std::size_t>(p.width) * p.height;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  out.params = p;
  out.heights.assign(cells, nan);
  out.plane_ids.assign(cells, -1);
  out.classes.assign(cells, CellClass::Unknown);
  out.floor_plane = -1;
  out.floor_height = std::numeric_limits<double>::quiet_NaN();

  const double cos_max = std::cos(p.max_slope_deg * M_PI / 180.0);
  std::vector<char> walkable(sweep.planes.size(), 0), step_face(sweep.planes.size(), 0);
  double floor_area = 0.0;
  for (const Plane& pl : sweep.planes) {
    if (std::abs(pl.fit.normal.z()) < cos_max) {
      double zmin = 1e300, zmax = -1e300;
      for (const Eigen::Vector3d& v : pl.boundary) {
        zmin = std::min(zmin, v.z());
        zmax = std::max(zmax, v.z());
      }
      step_face[pl.id] = zmax - zmin <= p.max_step_height;
      continue;
    }
    walkable[pl.id] = 1;
    if (pl.area > floor_area) {
      floor_area = pl.area;
      out.floor_plane = pl.id;
      out.floor_height = pl.fit.centroid.z();
    }
  }

  // Fill each walkable plane's polygon (holes by the even-odd rule) row by row.
  std::vector<double> xs;
  for (const Plane& pl : sweep.planes) {
    if (!walkable[pl.id]) continue;
    std::vector<const std::vector<Eigen::Vector3d>*> rings{&pl.boundary};
    for (const auto& h : pl.holes) rings.push_back(&h);
    double ymin = 1e300, ymax = -1e300;
    for (const Eigen::Vector3d& v : pl.boundary) {
      ymin = std::min(ymin, v.y());
      ymax = std::max(ymax, v.y());
    }
    const int iy0 = std::max(0, static_cast<int>(std::floor((ymin - p.origin_y) / p.resolution)));
    const int iy1 = std::min(p.height - 1, static_cast<int>(std::floor((ymax - p.origin_y) / p.resolution)));
    const Eigen::Vector3d& n = pl.fit.normal;
    for (int iy = iy0; iy <= iy1; ++iy) {
      const double y = p.origin_y + (iy + 0.5) * p.resolution;
      xs.clear();
      for (const auto* ring : rings) {
        const std::size_t m = ring->size();
        for (std::size_t i = 0; i < m; ++i) {
          const Eigen::Vector3d& a = (*ring)[i];
          const Eigen::Vector3d& b = (*ring)[(i + 1) % m];
          if ((a.y() <= y) == (b.y() <= y)) continue;
          xs.push_back(a.x() + (y - a.y()) / (b.y() - a.y()) * (b.x() - a.x()));
        }
      }
      std::sort(xs.begin(), xs.end());
      for (std::size_t k = 0; k + 1 < xs.size(); k += 2) {
        const int ix0 = std::max(0, static_cast<int>(std::ceil((xs[k] - p.origin_x) / p.resolution - 0.5)));
        const int ix1 = std::min(p.width - 1, static_cast<int>(std::floor((xs[k + 1] - p.origin_x) / p.resolution - 0.5)));
        for (int ix = ix0; ix <= ix1; ++ix) {
          const double x = p.origin_x + (ix + 0.5) * p.resolution;
          const double z = (pl.fit.offset - n.x() * x - n.y() * y) / n.z();
          const std::size_t c = out.index(ix, iy);
          if (std::isnan(out.heights[c]) || z > out.heights[c]) {  // seen from above: the higher surface
            out.heights[c] = static_cast<float>(z);
            out.plane_ids[c] = pl.id;
          }
        }
      }
    }
  }
  for (std::size_t c = 0; c < cells; ++c) {
    if (out.plane_ids[c] < 0) continue;
    out.classes[c] = (out.floor_plane >= 0 && std::abs(out.heights[c] - out.floor_height) <= p.floor_tolerance)
                         ? CellClass::Floor
                         : CellClass::Step;
  }

  // Obstacles: points outside walkable planes that stand above the cell's surface.
  std::vector<int> point_plane;
  for (std::size_t li = 0; li < sweep.lines.size(); ++li) {
    const SweepLine& line = sweep.lines[li];
    point_plane.assign(line.points.size(), -1);
    for (std::size_t si = 0; si < sweep.segments.size(); ++si) {
      const Segment3& s = sweep.segments[si];
      if (s.line != static_cast<int>(li)) continue;
      const int pid = sweep.segment_plane[si];
      for (int i = s.first; i <= s.last; ++i) point_plane[i] = pid;
    }
    for (std::size_t i = 0; i < line.points.size(); ++i) {
      if (!std::isfinite(line.points[i].x())) continue;
      const int pid = point_plane[i];
      if (pid >= 0 && (walkable[pid] || step_face[pid])) continue;
      // A point of a plane (a wall, a box's side) is put on its plane: range
      // noise would otherwise spill it into the cells in front.
      Eigen::Vector3d q = line.points[i].cast<double>();
      if (pid >= 0) q -= (sweep.planes[pid].fit.normal.dot(q) - sweep.planes[pid].fit.offset) * sweep.planes[pid].fit.normal;
      const Eigen::Vector3f pt = q.cast<float>();
      const int ix = static_cast<int>(std::floor((pt.x() - p.origin_x) / p.resolution));
      const int iy = static_cast<int>(std::floor((pt.y() - p.origin_y) / p.resolution));
      if (ix < 0 || iy < 0 || ix >= p.width || iy >= p.height) continue;
      const std::size_t c = out.index(ix, iy);
      const bool known_surface = out.classes[c] == CellClass::Floor || out.classes[c] == CellClass::Step;
      if (known_surface && pt.z() < out.heights[c] + p.obstacle_min_height) continue;
      if (out.classes[c] == CellClass::Obstacle && pt.z() <= out.heights[c]) continue;
      if (!known_surface && out.classes[c] != CellClass::Obstacle && !std::isnan(out.floor_height) &&
          pt.z() < out.floor_height + p.obstacle_min_height)
        continue;  // a stray point at floor level: not an obstacle
      out.heights[c] = pt.z();
      out.classes[c] = CellClass::Obstacle;
      out.plane_ids[c] = -1;
    }
  }
}

}  // namespace core
}  // namespace tilt_laser_perception
