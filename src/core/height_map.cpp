#include "tilt_laser_perception/core/height_map.hpp"
#include "tilt_laser_perception/core/noise_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace tilt_laser_perception {
namespace core {

namespace {
/// Points and segments this far beside the map's area are not looked at [m].
constexpr double kMapMargin = 0.1;
}  // namespace

bool besideMap(const Segment3& s, const HeightMapParams& p) {
  const double x_lo = p.origin_x - kMapMargin, x_hi = p.origin_x + p.width * p.resolution + kMapMargin;
  const double y_lo = p.origin_y - kMapMargin, y_hi = p.origin_y + p.height * p.resolution + kMapMargin;
  return std::max(s.start.x(), s.end.x()) < x_lo || std::min(s.start.x(), s.end.x()) > x_hi ||
         std::max(s.start.y(), s.end.y()) < y_lo || std::min(s.start.y(), s.end.y()) > y_hi;
}

void buildHeightMap(const SweepResult& sweep, const HeightMapParams& p, HeightMapGrid& out) {
  const std::size_t cells = static_cast<std::size_t>(p.width) * p.height;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  if (out.heights.size() == cells && out.plane_ids.size() == cells && out.classes.size() == cells &&
      out.params.width == p.width && out.params.height == p.height) {
    // The last map of this size is still there: every cell it wrote lies in
    // its box, so clearing the box is clearing the map (for a 6 m map of 1 cm
    // cells, a fraction of its 360,000 cells).
    // The box's first row is filled, the others copied from it (a float
    // fill is a scalar loop; a copy is the C library's wide one).
    const int x0 = std::max(0, out.box_x0), x1 = std::min(out.box_x1, p.width - 1);
    const int y0 = std::max(0, out.box_y0), y1 = std::min(out.box_y1, p.height - 1);
    if (x1 >= x0 && y1 >= y0) {
      const std::size_t n = static_cast<std::size_t>(x1 - x0 + 1), first = out.index(x0, y0);
      std::fill_n(out.heights.begin() + first, n, nan);
      std::fill_n(out.plane_ids.begin() + first, n, -1);
      std::fill_n(out.classes.begin() + first, n, CellClass::Unknown);
      for (int iy = y0 + 1; iy <= y1; ++iy) {
        const std::size_t c = out.index(x0, iy);
        std::memcpy(&out.heights[c], &out.heights[first], n * sizeof(float));
        std::memcpy(&out.plane_ids[c], &out.plane_ids[first], n * sizeof(std::int32_t));
        std::memcpy(&out.classes[c], &out.classes[first], n * sizeof(CellClass));
      }
    }
  } else {
    out.heights.assign(cells, nan);
    out.plane_ids.assign(cells, -1);
    out.classes.assign(cells, CellClass::Unknown);
  }
  out.params = p;
  out.floor_plane = -1;
  out.floor_height = std::numeric_limits<double>::quiet_NaN();
  out.box_x0 = p.width;
  out.box_y0 = p.height;
  out.box_x1 = out.box_y1 = -1;
  const auto inBox = [&out](int ix0, int ix1, int iy) {
    out.box_x0 = std::min(out.box_x0, ix0);
    out.box_x1 = std::max(out.box_x1, ix1);
    out.box_y0 = std::min(out.box_y0, iy);
    out.box_y1 = std::max(out.box_y1, iy);
  };

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

  const float floor_h = static_cast<float>(out.floor_height), floor_tol = static_cast<float>(p.floor_tolerance);
  // A run of a row's cells on a walkable plane: seen from above, the higher
  // surface wins.
  const double inv_res = 1.0 / p.resolution;
  double inv_nz = 0.0;  // of the plane being filled
  float dz = 0.0f;      // its height's step from a cell to the next along a row
  const auto fillRow = [&](const Plane& pl, int iy, double xa, double xb) {
    const int ix0 = std::max(0, static_cast<int>(std::ceil((xa - p.origin_x) * inv_res - 0.5)));
    const int ix1 = std::min(p.width - 1, static_cast<int>(std::floor((xb - p.origin_x) * inv_res - 0.5)));
    const int count = ix1 - ix0 + 1;
    if (count <= 0) return;
    inBox(ix0, ix1, iy);
    // z along the row: a ramp from the first cell's height
    const Eigen::Vector3d& n = pl.fit.normal;
    const double y = p.origin_y + (iy + 0.5) * p.resolution;
    const float z0 = static_cast<float>((pl.fit.offset - n.x() * (p.origin_x + (ix0 + 0.5) * p.resolution) - n.y() * y) * inv_nz);
    const std::size_t c0 = out.index(ix0, iy);
    float* __restrict h = out.heights.data() + c0;
    std::int32_t* __restrict id = out.plane_ids.data() + c0;
    CellClass* __restrict cls = out.classes.data() + c0;
    // Without branches (masks): a vector at a time.
#pragma omp simd
    for (int k = 0; k < count; ++k) {
      const float z = z0 + static_cast<float>(k) * dz;
      const float old = h[k];
      // All ones where z is higher: seen from above, the higher surface wins (NaN: none yet).
      const std::int32_t higher = -static_cast<std::int32_t>(!(old >= z));
      // NaN while the floor is unknown: a step
      const std::int32_t c = static_cast<std::int32_t>(CellClass::Step) -
                             static_cast<std::int32_t>(std::abs(z - floor_h) <= floor_tol);
      h[k] = old >= z ? old : z;
      id[k] = (pl.id & higher) | (id[k] & ~higher);
      cls[k] = static_cast<CellClass>((c & higher) | (static_cast<std::int32_t>(cls[k]) & ~higher));
    }
  };
  // Polygons (x, y) filled by the even-odd rule, row by row: each edge listed
  // under the rows whose centre line it crosses (the half-open rule).
  struct Edge {
    double ax, ay, bx, by;
    int lo, hi;  // rows it crosses
  };
  std::vector<Edge> edges;
  std::vector<int> row_count, row_fill, row_edges;
  std::vector<double> xs;
  const auto fillRings = [&](const Plane& pl, const std::vector<std::vector<Eigen::Vector2d>>& polys,
                             const auto& rowOp) {
    double ymin = 1e300, ymax = -1e300;
    for (const auto& ring : polys)
      for (const Eigen::Vector2d& v : ring) {
        ymin = std::min(ymin, v.y());
        ymax = std::max(ymax, v.y());
      }
    const int iy0 = std::max(0, static_cast<int>(std::floor((ymin - p.origin_y) / p.resolution)));
    const int iy1 = std::min(p.height - 1, static_cast<int>(std::floor((ymax - p.origin_y) / p.resolution)));
    if (iy1 < iy0) return;
    const auto rowOf = [&](double y) { return (y - p.origin_y) * inv_res - 0.5; };
    row_count.assign(iy1 - iy0 + 2, 0);
    edges.clear();
    for (const auto& ring : polys) {
      const std::size_t m = ring.size();
      for (std::size_t i = 0; i < m; ++i) {
        const Eigen::Vector2d& u = ring[i];
        const Eigen::Vector2d& w = ring[(i + 1) % m];
        if (u.y() == w.y()) continue;
        const double ru = rowOf(u.y()), rw = rowOf(w.y());
        const int lo = std::max(iy0, static_cast<int>(std::ceil(std::min(ru, rw))));
        const int hi = std::min(iy1, static_cast<int>(std::ceil(std::max(ru, rw))) - 1);
        if (hi < lo) continue;
        edges.push_back({u.x(), u.y(), w.x(), w.y(), lo, hi});
        for (int r = lo; r <= hi; ++r) ++row_count[r - iy0 + 1];
      }
    }
    for (std::size_t r = 1; r < row_count.size(); ++r) row_count[r] += row_count[r - 1];
    row_edges.resize(row_count.back());
    row_fill.assign(row_count.begin(), row_count.end());
    for (std::size_t e = 0; e < edges.size(); ++e)
      for (int r = edges[e].lo; r <= edges[e].hi; ++r) row_edges[row_fill[r - iy0]++] = static_cast<int>(e);
    for (int iy = iy0; iy <= iy1; ++iy) {
      const double y = p.origin_y + (iy + 0.5) * p.resolution;
      xs.clear();
      for (int k = row_count[iy - iy0]; k < row_count[iy - iy0 + 1]; ++k) {
        const Edge& e = edges[row_edges[k]];
        xs.push_back(e.ax + (y - e.ay) / (e.by - e.ay) * (e.bx - e.ax));
      }
      std::sort(xs.begin(), xs.end());
      for (std::size_t k = 0; k + 1 < xs.size(); k += 2) rowOp(pl, iy, xs[k], xs[k + 1]);
    }
  };
  std::vector<std::vector<Eigen::Vector2d>> rings;
  // A chain: one segment on each of successive lines, each side by side with
  // the next and with nothing else there: their ends, there and back, bound
  // one polygon.
  struct Chain {
    std::vector<Eigen::Vector2d> from, to;
  };
  std::vector<Chain> chains;
  std::vector<int> chain_of, next_chain_of, partners_s, partners_t;
  struct Piece {
    int line;
    std::size_t first, last;  // its segments (in the plane's sorted members)
    int beam_first, beam_last;
    Eigen::Vector2d from = Eigen::Vector2d::Zero(), to = Eigen::Vector2d::Zero();  // its ends on the plane
    bool beside = false;                                                          // beside the map
  };
  std::vector<Piece> pieces;
  const auto flushChain = [&](const Plane& pl, Chain& ch) {
    if (ch.from.size() >= 2) {
      rings.assign(1, ch.from);
      rings[0].insert(rings[0].end(), ch.to.rbegin(), ch.to.rend());
      fillRings(pl, rings, fillRow);
    }
    ch.from.clear();
    ch.to.clear();
  };
  std::vector<int> mem;
  // Whether the ray of beam b of line l passed the plane: it ends beyond it
  // by more than obstacle_min_height (`at`: where it crossed the plane, x
  // y), or nowhere (no return; `at` NaN). Beside the plane's end there, that
  // is the surface's own edge, not the foot of what hid it nor a step too
  // low to tell from a rough surface.
  const auto passed = [&](const PlaneFit& f, int l, int b, Eigen::Vector2d& at) {
    at.setConstant(std::numeric_limits<double>::quiet_NaN());
    if (l < 0 || l >= static_cast<int>(sweep.lines.size())) return false;
    const SweepLine& line = sweep.lines[l];
    if (b < 0 || b >= static_cast<int>(line.points.size())) return false;
    if (!line.points[b].allFinite()) return true;
    const Eigen::Vector3d o = line.origin.cast<double>(), r = line.points[b].cast<double>() - o;
    const double t = (f.offset - f.normal.dot(o)) / f.normal.dot(r);
    // (The normal points towards the sensor: beyond is below the offset.)
    if (!(t > 0.0 && f.normal.dot(o + r) - f.offset < -p.obstacle_min_height)) return false;
    at = (o + t * r).head<2>();
    return true;
  };
  // Whether a piece's end at beam b of line l is the surface's own edge: the
  // beams beyond it, outwards (step -1 or +1), passed the plane (as above).
  // The split's veil beams there are looked past: mixed pixels (a footprint
  // across the edge reports a range between the surface and what lies
  // behind it) tell nothing of where the surface ends. So are beams of no
  // segment within the distance threshold of the plane: the surface itself,
  // a run too short for a segment of its own.
  const auto inSegment = [&](int l, int c) {
    auto it = std::lower_bound(sweep.segments.begin(), sweep.segments.end(), l,
                               [](const Segment3& t, int line) { return t.line < line; });
    for (; it != sweep.segments.end() && it->line == l; ++it)
      if (it->first <= c && c <= it->last) return true;
    return false;
  };
  // `beams`: how many beams out that one lies (1: the beam beside the end).
  const auto ownEdge = [&](const PlaneFit& f, int l, int b, int step, Eigen::Vector2d& at, int& beams) {
    at.setConstant(std::numeric_limits<double>::quiet_NaN());
    beams = 1;
    if (l < 0 || l >= static_cast<int>(sweep.lines.size())) return false;
    const SweepLine& line = sweep.lines[l];
    const auto& edges = line.edges;
    const auto veil = [&](int c) {
      return std::any_of(edges.begin(), edges.end(),
                         [c](const std::pair<int, EdgeKind>& e) { return e.first == c && e.second == EdgeKind::Veil; });
    };
    const auto onPlane = [&](int c) {
      if (c < 0 || c >= static_cast<int>(line.points.size()) || !line.points[c].allFinite()) return false;
      const Eigen::Vector3d q = line.points[c].cast<double>();
      return std::abs(f.normal.dot(q) - f.offset) <= sweep.grouping.threshold((q - line.origin.cast<double>()).norm()) &&
             !inSegment(l, c);
    };
    int c = b + step;
    while (veil(c) || onPlane(c)) c += step;
    beams = std::abs(c - b);
    return passed(f, l, c, at);
  };
  const auto cross = [](const Eigen::Vector2d& u, const Eigen::Vector2d& w) { return u.x() * w.y() - u.y() * w.x(); };
  std::vector<Eigen::Vector2d> outline, free_at;
  std::vector<double> end_slack;
  std::vector<char> own_edge;
  // Corners its lines cut: where the plane's own edges turn between two of
  // its lines, or beyond its outermost line, no line saw the corner; the
  // edges run on straight to it, by no more than one step of their lines
  // each, and not past where a ray crossed the plane's height unblocked (a
  // landing's or a box top's corner, the lines across it at an angle). The
  // outline: each line's entry in order, then each line's exit back; an
  // edge is two successive entries (or exits) both the surface's own edge;
  // a corner, two edges that turn by more than their ends' jitter.
  const auto fillCutCorners = [&](const Plane& pl) {
    outline.clear();
    own_edge.clear();
    free_at.clear();
    end_slack.clear();
    Eigen::Vector2d at;
    const auto end = [&](const Piece& pc, bool entry) {
      outline.push_back(entry ? pc.from : pc.to);
      int beams = 1;
      own_edge.push_back(ownEdge(pl.fit, pc.line, entry ? pc.beam_first : pc.beam_last, entry ? -1 : 1, at, beams));
      // How far short of the edge the end may lie: up to the first beam
      // that passed it.
      end_slack.push_back(beams * (pc.to - pc.from).norm() / std::max(1, pc.beam_last - pc.beam_first));
      if (at.allFinite()) free_at.push_back(at);
    };
    for (std::size_t k = 0; k < pieces.size(); ++k)
      if (k == 0 || pieces[k - 1].line != pieces[k].line) end(pieces[k], true);
    const std::size_t lines = outline.size();
    for (std::size_t k = pieces.size(); k-- > 0;)
      if (k + 1 == pieces.size() || pieces[k + 1].line != pieces[k].line) end(pieces[k], false);
    const std::size_t m = outline.size();
    if (lines < 2) return;
    // Beyond the outermost lines: where the next lines' rays crossed it.
    for (const Piece& pc : pieces) {
      const int next = pc.line == pieces.front().line ? pc.line - 1 : pc.line == pieces.back().line ? pc.line + 1 : -1;
      if (next < 0) continue;
      for (int b = pc.beam_first; b <= pc.beam_last; ++b)
        if (passed(pl.fit, next, b, at) && at.allFinite()) free_at.push_back(at);
    }
    double area2 = 0.0;  // twice the outline's signed area: its orientation
    for (std::size_t i = 0; i < m; ++i) area2 += cross(outline[i], outline[(i + 1) % m]);
    // Whether outline[k - 1], outline[k], outline[k + 1] are three ends of
    // one straight edge (the middle one within how far short of the edge it
    // may lie of the chord of the others): a direction two ends alone give
    // may be a chord across a corner the lines cut.
    const auto straight = [&](std::size_t k) {
      const std::size_t k0 = (k + m - 1) % m, k2 = (k + 1) % m;
      if ((k0 < lines) != (k < lines) || (k2 < lines) != (k < lines) || !own_edge[k0] || !own_edge[k] || !own_edge[k2])
        return false;
      const Eigen::Vector2d chord = outline[k2] - outline[k0];
      const double len = chord.norm();
      return len > 0.0 && std::abs(cross(chord, outline[k] - outline[k0])) / len <= end_slack[k];
    };
    for (std::size_t i = 0; i < m; ++i) {
      // The corner between outline[i] and outline[i + 1], where the edges
      // (outline[i - 2], outline[i - 1], outline[i]) and (outline[i + 1],
      // outline[i + 2], outline[i + 3]) meet.
      const std::size_t i0 = (i + m - 1) % m, i2 = (i + 1) % m, i3 = (i + 2) % m;
      const auto edge = [&](std::size_t u, std::size_t w) {  // two ends of one side, the surface's own edge
        return (u < lines) == (w < lines) && own_edge[u] && own_edge[w];
      };
      // Between two lines the chord's ends and one straight edge place the
      // corner; beyond the outermost line nothing was seen around it, so
      // both edges must be straight (a line's piece that ran on over
      // something else beside the surface makes an edge that is none).
      const bool beyond = (i < lines) != (i2 < lines);
      if (!edge(i0, i) || !edge(i2, i3) || !(beyond ? straight(i0) && straight(i3) : straight(i0) || straight(i3)))
        continue;
      const Eigen::Vector2d &a = outline[i], &b = outline[i2];
      const Eigen::Vector2d d1 = a - outline[i0], d2 = outline[i3] - b;
      // A line's end lies up to its slack short of the edge, so an edge's
      // direction is known to within the two ends' slacks over its length:
      // the edges must turn by more than that (not a straight edge whose
      // ends jitter).
      const double det = cross(d1, d2);  // a + s d1 = b - u d2
      const double uncertain = (end_slack[i0] + end_slack[i]) / d1.norm() + (end_slack[i2] + end_slack[i3]) / d2.norm();
      if (!(std::atan2(std::abs(det), d1.dot(d2)) > uncertain)) continue;
      const double s = cross(b - a, d2) / det, u = cross(d1, b - a) / det;
      if (!(s > 0.0 && s <= 1.0 && u > 0.0 && u <= 1.0)) continue;
      const Eigen::Vector2d corner = a + s * d1;
      if (cross(b - a, corner - a) * area2 >= 0.0) continue;  // not outside the outline
      const auto inside = [&](const Eigen::Vector2d& q) {
        const double c0 = cross(corner - a, q - a), c1 = cross(b - corner, q - corner), c2 = cross(a - b, q - b);
        return (c0 > 0.0 && c1 > 0.0 && c2 > 0.0) || (c0 < 0.0 && c1 < 0.0 && c2 < 0.0);
      };
      if (std::any_of(free_at.begin(), free_at.end(), inside)) continue;
      rings.assign(1, {a, corner, b});
      fillRings(pl, rings, fillRow);
    }
  };
  for (const Plane& pl : sweep.planes) {
    if (!walkable[pl.id]) continue;
    inv_nz = 1.0 / pl.fit.normal.z();
    dz = static_cast<float>(-pl.fit.normal.x() * p.resolution * inv_nz);
    if (pl.members.empty()) {  // a plane given by its outline alone (not from a sweep's lines)
      rings.clear();
      for (const auto* ring : {&pl.boundary}) {
        rings.emplace_back();
        for (const Eigen::Vector3d& v : *ring) rings.back().emplace_back(v.x(), v.y());
      }
      for (const auto& h : pl.holes) {
        rings.emplace_back();
        for (const Eigen::Vector3d& v : h) rings.back().emplace_back(v.x(), v.y());
      }
      fillRings(pl, rings, fillRow);
      continue;
    }
    // Between its scan lines: the strip between two of its segments on
    // neighbouring lines of it that overlap in beam index. Where its lines
    // saw something else (a gap in a line: the plane goes on beyond an
    // obstacle, or is seen again beyond a shadow) no strip is drawn, so a
    // cell no line saw on the plane stays unknown rather than be filled
    // from the plane's outline. Chains of segments are filled as one polygon
    // each; where a segment meets two on the next line (or chords cross),
    // strip by strip.
    mem = pl.members;
    std::sort(mem.begin(), mem.end());  // segments come line by line, in beam order
    const auto onPlane = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& origin) {
      const Eigen::Vector3d q = cornerOnPlane(x, origin, pl.fit, sweep.grouping);
      return Eigen::Vector2d(q.x(), q.y());
    };
    // Pieces: a line's segments of the plane that follow each other with at
    // most an edge point between them (the split cut a run of the surface).
    pieces.clear();
    for (std::size_t k = 0; k < mem.size(); ++k) {
      const Segment3& s = sweep.segments[mem[k]];
      if (!pieces.empty() && pieces.back().line == s.line && s.first <= pieces.back().beam_last + 2) {
        pieces.back().last = k;
        pieces.back().beam_last = s.last;
      } else {
        pieces.push_back({s.line, k, k, s.first, s.last, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), false});
      }
    }
    // The plane's outline has a corner where each of its lines enters it and
    // one where it leaves (lines in order, then back), put where the ray
    // meets the plane and carried to the creases it meets: a line's outer
    // ends are those; the ends inside a line (its gaps) are the segments'.
    std::size_t lines = 0;
    for (std::size_t k = 0; k < pieces.size(); ++k) lines += k == 0 || pieces[k].line != pieces[k - 1].line;
    const bool corners = pl.boundary.size() == 2 * lines;
    // Each piece's ends on the plane (x, y), and whether it lies beside the map.
    std::size_t line = 0;
    for (std::size_t k = 0; k < pieces.size(); ++k) {
      Piece& pc = pieces[k];
      if (k > 0 && pc.line != pieces[k - 1].line) ++line;
      const bool first = k == 0 || pc.line != pieces[k - 1].line;
      const bool last = k + 1 == pieces.size() || pc.line != pieces[k + 1].line;
      const Segment3& s = sweep.segments[mem[pc.first]];
      const Segment3& e = sweep.segments[mem[pc.last]];
      // (The outline's corners lie on the plane: their rays change nothing.)
      pc.from = onPlane(corners && first ? pl.boundary[line] : s.start, s.origin);
      pc.to = onPlane(corners && last ? pl.boundary[2 * lines - 1 - line] : e.end, e.origin);
      pc.beside = besideMap(s, p) && besideMap(e, p);
    }
    fillCutCorners(pl);
    // Where a piece's line crossed the plane at a beam inside it (the first
    // return from there on, stepping by `step`), or `end` when none is.
    const auto atBeam = [&](const Piece& pc, int beam, int step, const Eigen::Vector2d& end) {
      const std::vector<Eigen::Vector3f>& pts = sweep.lines[pc.line].points;
      const Eigen::Vector3d& origin = sweep.segments[mem[pc.first]].origin;
      for (int k = beam; k > pc.beam_first && k < pc.beam_last && k < static_cast<int>(pts.size()); k += step)
        if (pts[k].allFinite()) return onPlane(pts[k].cast<double>(), origin);
      return end;
    };
    // Whether a line's returns between two beams (exclusive) include one off
    // the plane by more than obstacle_min_height.
    const auto sawOther = [&](int li, int from, int to) {
      const std::vector<Eigen::Vector3f>& pts = sweep.lines[li].points;
      for (int k = std::max(0, from + 1); k < to && k < static_cast<int>(pts.size()); ++k)
        if (pts[k].allFinite() &&
            std::abs(pl.fit.normal.dot(pts[k].cast<double>()) - pl.fit.offset) > p.obstacle_min_height)
          return true;
      return false;
    };
    // [a, b) and [b, c): the pieces of two successive lines of the plane.
    std::size_t a = 0;
    Eigen::Vector2d x;
    chains.clear();
    chain_of.clear();
    while (a < pieces.size()) {
      std::size_t b = a;
      while (b < pieces.size() && pieces[b].line == pieces[a].line) ++b;
      std::size_t c = b;
      while (c < pieces.size() && pieces[c].line == pieces[b].line) ++c;
      chain_of.resize(b - a, -1);
      next_chain_of.assign(c - b, -1);
      partners_s.assign(b - a, 0);
      partners_t.assign(c - b, 0);
      const auto side = [&](std::size_t i, std::size_t j) {
        return !(pieces[i].beam_first > pieces[j].beam_last || pieces[j].beam_first > pieces[i].beam_last) &&
               !(pieces[i].beside && pieces[j].beside);
      };
      for (std::size_t i = a; i < b; ++i)
        for (std::size_t j = b; j < c; ++j)
          if (side(i, j)) {
            ++partners_s[i - a];
            ++partners_t[j - b];
          }
      for (std::size_t i = a; i < b; ++i)
        for (std::size_t j = b; j < c; ++j) {
          if (!side(i, j)) continue;
          const Eigen::Vector2d &a0 = pieces[i].from, &b0 = pieces[i].to, &a1 = pieces[j].from, &b1 = pieces[j].to;
          const bool crossed = chordsCross(a0, b0, a1, b1, x);
          if (partners_s[i - a] == 1 && partners_t[j - b] == 1 && !crossed) {
            int& ch = chain_of[i - a];
            if (ch < 0) {
              ch = static_cast<int>(chains.size());
              chains.push_back({{a0}, {b0}});
            }
            chains[ch].from.push_back(a1);
            chains[ch].to.push_back(b1);
            next_chain_of[j - b] = ch;
            ch = -1;
            continue;
          }
          // Two chords that cross (a spinning head's lines, where its axis
          // meets the plane): two triangles from the crossing.
          if (crossed) {
            rings = {{a0, x, a1}, {x, b0, b1}};
          } else {
            // A piece that meets two on the other line ends, towards the gap
            // between them, where that line's piece ends when the other line
            // saw something else in the gap (a box that the first line passed
            // beside): a strip drawn on to the piece's own end would cover
            // it. (A gap of points on the plane, or of no returns, is not
            // something else.)
            const auto cut = [&](std::size_t k, std::size_t lo, std::size_t hi, std::size_t g0, std::size_t g1) {
              bool partner = false;
              for (std::size_t m = lo; m < hi && !partner; ++m) partner = side(k, m);
              return partner && sawOther(pieces[g0].line, pieces[g0].beam_last, pieces[g1].beam_first);
            };
            const Piece &pi = pieces[i], &pj = pieces[j];
            rings = {{j > b && cut(i, b, j, j - 1, j) ? atBeam(pi, pj.beam_first, +1, a0) : a0,
                      j + 1 < c && cut(i, j + 1, c, j, j + 1) ? atBeam(pi, pj.beam_last, -1, b0) : b0,
                      i + 1 < b && cut(j, i + 1, b, i, i + 1) ? atBeam(pj, pi.beam_last, -1, b1) : b1,
                      i > a && cut(j, a, i, i - 1, i) ? atBeam(pj, pi.beam_first, +1, a1) : a1}};
          }
          for (const auto& r : rings) fillRings(pl, {r}, fillRow);
        }
      for (const int ch : chain_of)  // chains that end on this line
        if (ch >= 0) flushChain(pl, chains[ch]);
      chain_of.swap(next_chain_of);
      a = b;
    }
    for (const int ch : chain_of)
      if (ch >= 0) flushChain(pl, chains[ch]);
  }

  // Obstacles: points outside walkable planes that stand above the cell's
  // surface. Segments come in line and beam order: only the beams between
  // the walkable planes' segments are looked at.
  const float x_lo = static_cast<float>(p.origin_x - kMapMargin),
              x_hi = static_cast<float>(p.origin_x + p.width * p.resolution + kMapMargin);
  const float y_lo = static_cast<float>(p.origin_y - kMapMargin),
              y_hi = static_cast<float>(p.origin_y + p.height * p.resolution + kMapMargin);
  // Most points are outside the map (walls, the far floor) or no return at
  // all (NaN fails these tests too): tested inline before mark() is called.
  const auto inMap = [&](const Eigen::Vector3f& point) {
    return point.x() > x_lo && point.x() < x_hi && point.y() > y_lo && point.y() < y_hi;
  };
  // The top of each face (a steep plane that is neither walkable nor a step
  // face) along it: the highest corner of its outline over each cell's
  // width of its horizontal axis, built when a point of it is first marked.
  struct FaceTop {
    bool built = false;
    Eigen::Vector2d axis = Eigen::Vector2d::Zero();
    double u0 = 0.0;
    std::vector<float> top;  // per cell's width along axis; -inf: none
    double z_lo = 0.0, z_hi = 0.0;  // its outline's lowest and highest corner
  };
  std::vector<FaceTop> face_tops(sweep.planes.size());
  const auto faceTop = [&](const Plane& pl) -> const FaceTop& {
    FaceTop& f = face_tops[pl.id];
    if (f.built) return f;
    f.built = true;
    const Eigen::Vector2d h(-pl.fit.normal.y(), pl.fit.normal.x());
    const std::vector<Eigen::Vector3d>& b = pl.boundary;
    if (!(h.norm() > 1e-6) || b.size() < 3) return f;
    f.axis = h.normalized();
    double lo = 1e300, hi = -1e300;
    f.z_lo = 1e300;
    f.z_hi = -1e300;
    for (const Eigen::Vector3d& v : b) {
      lo = std::min(lo, f.axis.dot(v.head<2>()));
      hi = std::max(hi, f.axis.dot(v.head<2>()));
      f.z_lo = std::min(f.z_lo, v.z());
      f.z_hi = std::max(f.z_hi, v.z());
    }
    const double bins = (hi - lo) * inv_res + 1.0;
    if (!(bins < 1e5)) return f;
    f.u0 = lo;
    f.top.assign(static_cast<std::size_t>(bins), -std::numeric_limits<float>::infinity());
    const auto bin = [&](double u) {
      return std::min(f.top.size() - 1, static_cast<std::size_t>(std::max(0.0, (u - lo) * inv_res)));
    };
    for (std::size_t i = 0; i < b.size(); ++i) {  // each edge over the bins it spans
      const Eigen::Vector3d& a = b[i];
      const Eigen::Vector3d& e = b[(i + 1) % b.size()];
      const double ua = f.axis.dot(a.head<2>()), ue = f.axis.dot(e.head<2>());
      const double u_lo = std::min(ua, ue), u_hi = std::max(ua, ue);
      for (std::size_t k = bin(u_lo), k1 = bin(u_hi); k <= k1; ++k) {
        const double u = std::clamp(lo + (k + 0.5) * p.resolution, u_lo, u_hi);
        const double z = u_hi > u_lo ? a.z() + (e.z() - a.z()) * (u - ua) / (ue - ua) : std::max(a.z(), e.z());
        f.top[k] = std::max(f.top[k], static_cast<float>(z));
      }
    }
    return f;
  };
  const auto mark = [&](const Eigen::Vector3f& point, const Plane* plane) {
    // A point of a plane (a wall, a box's side) is put on its plane: range
    // noise would otherwise spill it into the cells in front. It marks the
    // cell behind the face (the normal points towards the sensor) whose
    // centre lies behind it and within the face's ends: a face that crosses
    // a cell at an angle leaves the cell to what is in front when its centre
    // is. (Where an upright face lies is judged at its centroid's height,
    // where its fit is surest, not where a tilt within the noise puts its
    // foot or its top.) The cell takes the face's top there: what a cell
    // just behind a face holds is what the face bounds (a box's top), which
    // a line that crossed the face low does not show.
    Eigen::Vector3d q = point.cast<double>();
    float z = static_cast<float>(q.z());
    if (plane) {
      const PlaneFit& f = plane->fit;
      q -= (f.normal.dot(q) - f.offset) * f.normal;
      const Eigen::Vector2d nh = f.normal.head<2>();
      if (nh.norm() > 1e-6) {
        const FaceTop& top = faceTop(*plane);
        if (!top.top.empty()) {
          const double u = (top.axis.dot(q.head<2>()) - top.u0) * inv_res;
          const float t = top.top[std::min(top.top.size() - 1, static_cast<std::size_t>(std::max(0.0, u)))];
          if (t > -std::numeric_limits<float>::infinity()) z = t;
        }
        // Upright: its whole height lies within a cell's width. One that
        // leans (a slope too steep to walk) is judged where the point is, and
        // is as high over the cell as its plane over the cell's corners,
        // below its top.
        const bool upright = p.resolution * nh.norm() >= std::abs(f.normal.z()) * (top.z_hi - top.z_lo);
        const double z_at = upright ? f.centroid.z() : q.z();
        const Eigen::Vector2d in = -0.5 * p.resolution * nh.normalized();
        const auto centre = [&] {  // of q's cell
          return Eigen::Vector2d(p.origin_x + (std::floor((q.x() - p.origin_x) * inv_res) + 0.5) * p.resolution,
                                 p.origin_y + (std::floor((q.y() - p.origin_y) * inv_res) + 0.5) * p.resolution);
        };
        bool behind = false;
        for (int k = 0; k < 2 && !behind; ++k) {
          q.head<2>() += in;
          behind = nh.dot(centre()) + f.normal.z() * z_at < f.offset;
        }
        if (!behind) return;
        if (!top.top.empty()) {  // nor one beyond its ends (past a box's corner, beside its other face)
          const double u = top.axis.dot(centre()) - top.u0;
          if (u < 0.0 || u > (top.top.size() - 1) * p.resolution) return;
        }
        if (!upright) {
          const double x0 = p.origin_x + std::floor((q.x() - p.origin_x) * inv_res) * p.resolution;
          const double y0 = p.origin_y + std::floor((q.y() - p.origin_y) * inv_res) * p.resolution;
          double over = -1e300;
          for (const double cx : {x0, x0 + p.resolution})
            for (const double cy : {y0, y0 + p.resolution})
              over = std::max(over, (f.offset - f.normal.x() * cx - f.normal.y() * cy) / f.normal.z());
          z = static_cast<float>(std::min<double>(z, over));
        }
      }
    }
    const int ix = static_cast<int>(std::floor((q.x() - p.origin_x) * inv_res));
    const int iy = static_cast<int>(std::floor((q.y() - p.origin_y) * inv_res));
    if (ix < 0 || iy < 0 || ix >= p.width || iy >= p.height) return;
    const std::size_t c = out.index(ix, iy);
    const bool known_surface = out.classes[c] == CellClass::Floor || out.classes[c] == CellClass::Step;
    if (known_surface && z < out.heights[c] + p.obstacle_min_height) return;
    if (out.classes[c] == CellClass::Obstacle && z <= out.heights[c]) return;
    if (!known_surface && out.classes[c] != CellClass::Obstacle && !std::isnan(out.floor_height) &&
        z < out.floor_height + p.obstacle_min_height)
      return;  // a stray point at floor level: not an obstacle
    out.heights[c] = z;
    inBox(ix, ix, iy);
    out.classes[c] = CellClass::Obstacle;
    out.plane_ids[c] = -1;
  };
  // The face (a plane too steep to walk) that explains a point of no plane:
  // the point lies within range noise of it along its ray (the noise model's
  // significance sigmas) and beside its outline. Such a point is the face's
  // (a riser's beams in a short piece no plane took, scattered by range noise
  // over the cells in front of it and behind it), marked as its own points are.
  const auto faceExplaining = [&](const Eigen::Vector3f& point, const Eigen::Vector3f& origin,
                                  double sigmas) -> const Plane* {
    const Eigen::Vector3d q = point.cast<double>();
    const Eigen::Vector3d ray = q - origin.cast<double>();
    const double range = ray.norm();
    if (!(range > 0.0)) return nullptr;
    const double tol = sigmas * p.noise.rangeSigma(range);
    const Plane* best = nullptr;
    double best_along = tol;
    for (const Plane& pl : sweep.planes) {
      if (pl.id < 0 || walkable[pl.id]) continue;
      const double off = pl.fit.normal.dot(q) - pl.fit.offset;
      const double cos_ray = std::abs(pl.fit.normal.dot(ray)) / range;
      // Along the ray: the range error that would put the point on the face.
      if (!(std::abs(off) <= best_along * cos_ray)) continue;
      const FaceTop& top = faceTop(pl);
      if (top.top.empty()) continue;
      const Eigen::Vector3d on = q - off * pl.fit.normal;
      const double u = top.axis.dot(on.head<2>()) - top.u0;
      if (u < 0.0 || u > (top.top.size() - 1) * p.resolution || on.z() < top.z_lo - tol || on.z() > top.z_hi + tol)
        continue;
      best = &pl;
      best_along = std::abs(off) / cos_ray;
    }
    return best;
  };
  // The points of no plane, judged against the faces once all are known:
  // each is a test, and of the thousands a sweep has, a few lie beyond the
  // significance level's sigmas of the face they are on by chance (a wall's
  // points 4 sigmas in front of it, which marked the cells there with the
  // wall's height). The tolerance is the one at which any of them is wrong
  // by chance with the significance level's tail (NoiseModel::familySigmas).
  std::vector<std::pair<int, int>> loose;  // (line, beam)
  std::size_t si = 0;
  for (std::size_t li = 0; li < sweep.lines.size(); ++li) {
    const std::vector<Eigen::Vector3f>& pts = sweep.lines[li].points;
    // Mixed pixels (the split's veil marks, in beam order) mark no obstacle.
    const auto& edges = sweep.lines[li].edges;
    std::size_t ei = 0;
    const auto markLoose = [&](int i) {  // a point of no plane; called in beam order
      if (!inMap(pts[i])) return;
      while (ei < edges.size() && edges[ei].first < i) ++ei;
      if (ei < edges.size() && edges[ei].first == i && edges[ei].second == EdgeKind::Veil) return;
      loose.emplace_back(static_cast<int>(li), i);
    };
    // Beams outside the line's returns are not looked at (no point to load).
    auto [cursor, end] = sweep.lines[li].returns();
    for (; si < sweep.segments.size() && sweep.segments[si].line == static_cast<int>(li); ++si) {
      const Segment3& s = sweep.segments[si];
      const int pid = sweep.segment_plane[si];
      for (int i = cursor; i < s.first; ++i) markLoose(i);
      if (pid < 0 || !(walkable[pid] || step_face[pid])) {
        if (besideMap(s, p)) {
          cursor = std::max(cursor, s.last + 1);
          continue;
        }
        if (pid >= 0) {
          for (int i = std::max(cursor, s.first); i <= s.last; ++i)
            if (inMap(pts[i])) mark(pts[i], &sweep.planes[pid]);
        } else {
          for (int i = std::max(cursor, s.first); i <= s.last; ++i) markLoose(i);
        }
      }
      cursor = std::max(cursor, s.last + 1);
    }
    for (int i = cursor; i < end; ++i) markLoose(i);
  }
  const double loose_sigmas = p.noise.familySigmas(loose.size());
  for (const auto& [li, i] : loose) {
    const Eigen::Vector3f& q = sweep.lines[li].points[i];
    mark(q, faceExplaining(q, sweep.lines[li].origin, loose_sigmas));
  }

  // Where a walkable plane may go on: across its outermost line, up to where
  // the next line's rays crossed its height unblocked, the surface ends
  // somewhere no line saw. A surface the map holds there beneath it was seen
  // from under it (the floor under a table's edges): the 2.5D map does not
  // know which is on top, so it says unknown. Where the next line's ray ends
  // within that band (on a riser or a box's side under the edge) the edge is
  // seen, and nothing changes; where it ends beyond the band or under the
  // plane, it passed the edge.
  // The cells of a row between xa and xb, with the plane's height at each.
  const auto rowCells = [&](const Plane& pl, int iy, double xa, double xb, const auto& visit) {
    const int ix0 = std::max(0, static_cast<int>(std::ceil((xa - p.origin_x) * inv_res - 0.5)));
    const int ix1 = std::min(p.width - 1, static_cast<int>(std::floor((xb - p.origin_x) * inv_res - 0.5)));
    const Eigen::Vector3d& n = pl.fit.normal;
    const double y = p.origin_y + (iy + 0.5) * p.resolution;
    for (int ix = ix0; ix <= ix1; ++ix)
      visit(ix, out.index(ix, iy), (pl.fit.offset - n.x() * (p.origin_x + (ix + 0.5) * p.resolution) - n.y() * y) / n.z());
  };
  const auto hideRow = [&](const Plane& pl, int iy, double xa, double xb) {
    rowCells(pl, iy, xa, xb, [&](int, std::size_t c, double z) {
      if (!(out.heights[c] < z - p.obstacle_min_height)) return;
      out.heights[c] = nan;
      out.plane_ids[c] = -1;
      out.classes[c] = CellClass::Unknown;
    });
  };
  std::vector<Eigen::Vector2d> near_side, far_side, line_side, edge_side;
  const auto flushBand = [&](const Plane& pl) {
    if (near_side.size() >= 2) {
      rings.assign(1, near_side);
      rings[0].insert(rings[0].end(), far_side.rbegin(), far_side.rend());
      fillRings(pl, rings, hideRow);
    }
    near_side.clear();
    far_side.clear();
  };
  // Where the next line's ray ended at the plane's height (within
  // obstacle_min_height: a riser's top under a landing's front edge), the
  // edge is seen there and the surface goes on to it: the strip between
  // the outermost line and those ends is the plane's (what the map held
  // there beneath it was seen from under it, through an open side).
  // Only cells that hold no surface at its height there: unknown, beneath it
  // by more than obstacle_min_height (seen from under it), or points of what
  // stands beneath its edge (a riser's top); another plane that meets it
  // (a landing beyond a ramp's last line) keeps its cells.
  const auto extendRow = [&](const Plane& pl, int iy, double xa, double xb) {
    rowCells(pl, iy, xa, xb, [&](int ix, std::size_t c, double zd) {
      const float z = static_cast<float>(zd), old = out.heights[c];
      if (!(std::isnan(old) || old < z - p.obstacle_min_height || (out.classes[c] == CellClass::Obstacle && old <= z)))
        return;
      out.heights[c] = z;
      out.plane_ids[c] = pl.id;
      out.classes[c] = std::abs(z - out.floor_height) <= p.floor_tolerance ? CellClass::Floor : CellClass::Step;
      inBox(ix, ix, iy);
    });
  };
  const NoiseModel range_noise;  // the data sheet's range noise
  const double overlap = std::sqrt(0.5) * p.resolution;  // half a cell's diagonal (the strip's, below)
  // (Each beam's reach from the line no farther than its neighbours': a lone
  // point beyond the noise's bound draws no spike.)
  std::vector<double> reach;
  const auto flushEdge = [&](const Plane& pl) {
    const std::size_t n = line_side.size();
    if (n >= 2) {
      reach.resize(n);
      for (std::size_t k = 0; k < n; ++k) reach[k] = (edge_side[k] - line_side[k]).norm();
      rings.assign(1, line_side);
      for (std::size_t k = n; k-- > 0;) {
        const double r = std::min({reach[k], reach[k > 0 ? k - 1 : k], reach[k + 1 < n ? k + 1 : k]});
        rings[0].push_back(reach[k] > 0.0 ? Eigen::Vector2d(line_side[k] + (edge_side[k] - line_side[k]) * (r / reach[k]))
                                          : line_side[k]);
      }
      fillRings(pl, rings, extendRow);
    }
    line_side.clear();
    edge_side.clear();
  };
  const int line_count = static_cast<int>(sweep.lines.size());
  for (const Plane& pl : sweep.planes) {
    if (!walkable[pl.id] || pl.members.empty()) continue;
    const PlaneFit& f = pl.fit;
    int first_line = line_count, last_line = -1;
    for (const int si : pl.members) {
      first_line = std::min(first_line, sweep.segments[si].line);
      last_line = std::max(last_line, sweep.segments[si].line);
    }
    for (const auto& [outer, next] : {std::pair<int, int>{first_line, first_line - 1}, {last_line, last_line + 1}}) {
      if (outer < 0 || outer >= line_count) continue;  // (a plane without its lines)
      const SweepLine& lo = sweep.lines[outer];
      for (const int si : pl.members) {
        const Segment3& s = sweep.segments[si];
        if (s.line != outer) continue;
        Eigen::Vector2d to;
        for (int b = s.first; b <= std::min(s.last, static_cast<int>(lo.points.size()) - 1); ++b) {
          bool open = lo.points[b].allFinite() && passed(f, next, b, to) && to.allFinite();
          Eigen::Vector2d from;
          const Eigen::Vector3f* q = next >= 0 && next < line_count &&
                                             b < static_cast<int>(sweep.lines[next].points.size())
                                         ? &sweep.lines[next].points[b]
                                         : nullptr;
          if (lo.points[b].allFinite() && q && q->allFinite() &&
              std::abs(f.normal.dot(q->cast<double>()) - f.offset) <= p.obstacle_min_height) {
            // (The ray's end is known to within the range noise along it:
            // the strip stops short of it by that noise at the one
            // significance level, towards the line. At the line the strip
            // overlaps the plane by half a cell's diagonal: a cell is filled
            // where its centre lies inside, and between the line's points
            // and the outline through the line's ends a cell's centre would
            // lie in neither, left to what was seen beneath.)
            const Eigen::Vector2d on = cornerOnPlane(lo.points[b].cast<double>(), s.origin, f, sweep.grouping).head<2>();
            const Eigen::Vector2d e = q->cast<double>().head<2>();
            const double pull = range_noise.significance * range_noise.rangeSigma((*q - sweep.lines[next].origin).norm());
            const double gap = (on - e).norm();
            line_side.push_back(gap > 0.0 ? Eigen::Vector2d(on + (on - e) * (overlap / gap)) : on);
            edge_side.push_back(gap > pull ? Eigen::Vector2d(e + (on - e) * (pull / gap)) : on);
          } else {
            flushEdge(pl);
          }
          if (open) {
            from = cornerOnPlane(lo.points[b].cast<double>(), s.origin, f, sweep.grouping).head<2>();
            const Eigen::Vector2d band = to - from;
            const double ends = (sweep.lines[next].points[b].cast<double>().head<2>() - from).dot(band);  // along the band
            open = band.squaredNorm() > 0.0 && (ends < 0.0 || ends > band.squaredNorm());
          }
          if (!open) {
            flushBand(pl);
            continue;
          }
          near_side.push_back(from);
          far_side.push_back(to);
        }
        flushBand(pl);
        flushEdge(pl);
      }
    }
  }
}

std::string FootParams::validate() const {
  if (!(length > 0.0 && length <= 1.0) || !(width > 0.0 && width <= length)) return "foot: need 0 < width <= length <= 1 m";
  if (!(max_tilt_deg >= 0.0 && max_tilt_deg < 90.0)) return "foot: max_tilt_deg must be in [0, 90)";
  if (!(max_roughness > 0.0)) return "foot: max_roughness must be > 0";
  return "";
}

void steppableCells(const HeightMapGrid& g, const std::vector<Plane>& planes, const FootParams& foot,
                    std::vector<std::uint8_t>& out) {
  const int w = g.params.width, h = g.params.height;
  out.assign(static_cast<std::size_t>(w) * h, 255);
  if (w <= 0 || h <= 0 || g.heights.size() != out.size()) return;
  // The planes a foot may stand on.
  int max_id = -1;
  for (const Plane& pl : planes) max_id = std::max(max_id, pl.id);
  std::vector<char> good(static_cast<std::size_t>(max_id + 1), 0);
  const double cos_tilt = std::cos(foot.max_tilt_deg * M_PI / 180.0);
  for (const Plane& pl : planes)
    if (pl.id >= 0) good[pl.id] = std::abs(pl.fit.normal.z()) >= cos_tilt && pl.fit.rms <= foot.max_roughness;
  const auto goodCell = [&](std::size_t c) {
    const std::int32_t id = g.plane_ids[c];
    return std::isfinite(g.heights[c]) && g.classes[c] != CellClass::Obstacle && id >= 0 && id <= max_id && good[id];
  };
  // Two good planes that meet at a shallow crease hold a foot across them as
  // one plane within its roughness: over the foot's radius the one leaves
  // the other by radius x tan(their angle), which with the step between
  // them where they meet stays within max_roughness.
  const int np = max_id + 1;
  std::vector<float> slack(static_cast<std::size_t>(np) * np, -1.0f);  // roughness left for a step; < 0: none
  for (const Plane& a : planes)
    for (const Plane& b : planes) {
      if (a.id < 0 || b.id < 0 || !good[a.id] || !good[b.id]) continue;
      const double c = std::min(1.0, std::abs(a.fit.normal.dot(b.fit.normal)));
      slack[static_cast<std::size_t>(a.id) * np + b.id] =
          static_cast<float>(foot.max_roughness - foot.radius() * std::sqrt(1.0 - c * c) / std::max(c, 1e-9));
    }
  const auto apart = [&](std::size_t c, std::size_t n) {  // a foot may not reach from cell c over to n
    const std::int32_t a = g.plane_ids[c], b = g.plane_ids[n];
    if (a == b) return false;
    if (a < 0 || b < 0 || a > max_id || b > max_id) return true;
    return !(std::abs(g.heights[c] - g.heights[n]) <= slack[static_cast<std::size_t>(a) * np + b]);
  };
  // Cells no foot may reach over: not good, or next to a cell of another
  // plane it may not rest across (one of every two cells across a boundary). Only the map's box
  // holds known cells: beyond it everything is unknown, so bad.
  // (A grid buildHeightMap did not make may keep no box: the whole map.)
  const bool boxed = g.box_x1 >= g.box_x0 && g.box_y1 >= g.box_y0;
  const int bx0 = boxed ? std::max(0, g.box_x0) : 0, by0 = boxed ? std::max(0, g.box_y0) : 0;
  const int bx1 = boxed ? std::min(w - 1, g.box_x1) : w - 1, by1 = boxed ? std::min(h - 1, g.box_y1) : h - 1;
  const int bw = bx1 - bx0 + 1, bh = by1 - by0 + 1;
  // Within the box: each cell's distance along its row to the nearest bad
  // cell (cells beyond the box are bad: D <= x + 1 and <= bw - x).
  // Rows padded to whole blocks of kBlock cells (the padding bad), for the
  // disc's test below a block at a time.
  constexpr int kBlock = 16;
  const int stride = (bw + kBlock - 1) / kBlock * kBlock;
  std::vector<std::int16_t> dist(static_cast<std::size_t>(stride) * bh, 0);
  const auto D = [&](int x, int y) -> std::int16_t& { return dist[static_cast<std::size_t>(y) * stride + x]; };
  for (int y = 0; y < bh; ++y) {
    std::int16_t last = 0;  // cells since the last bad one (the box's edge is one)
    for (int x = 0; x < bw; ++x) {
      const std::size_t c = g.index(bx0 + x, by0 + y);
      const bool bad = !goodCell(c) || (bx0 + x + 1 < w && apart(c, c + 1)) ||
                       (by0 + y + 1 < h && apart(c, c + static_cast<std::size_t>(w)));
      last = bad ? 0 : static_cast<std::int16_t>(std::min(last + 1, 30000));
      D(x, y) = last;
    }
    last = 0;  // from the right: the box's edge
    for (int x = bw - 1; x >= 0; --x) {
      last = D(x, y) == 0 ? 0 : static_cast<std::int16_t>(std::min(last + 1, 30000));
      D(x, y) = std::min(D(x, y), last);
    }
  }
  // A foot centred on (x, y) rests on good cells alone when every row dy of
  // the disc of its radius (rc cells: the cells whose centres lie within it)
  // is clear for its half-width, D(x, y + dy) > half[|dy|]; the box's edges
  // are bad, so a disc that reaches beyond the box is not clear (in x by D,
  // in y by the rows it would need). Row by row, a row of the disc at a time
  // over the whole row (without a branch, a vector at a time).
  const double rc = foot.radius() / g.params.resolution;  // in cells
  const int r = static_cast<int>(std::floor(rc));
  std::vector<std::int16_t> half(static_cast<std::size_t>(r) + 1);
  for (int dy = 0; dy <= r; ++dy)
    half[dy] = static_cast<std::int16_t>(std::floor(std::sqrt(std::max(0.0, rc * rc - dy * dy))));
  std::vector<std::int16_t> clear(static_cast<std::size_t>(stride));
  for (int y = 0; y < bh; ++y) {
    const bool inside = y >= r && y + r < bh;
    std::fill(clear.begin(), clear.end(), static_cast<std::int16_t>(inside));
    for (int dy = -r; inside && dy <= r; ++dy) {
      const std::int16_t* __restrict d = &D(0, y + dy);
      std::int16_t* __restrict k = clear.data();
      const std::int16_t lim = half[std::abs(dy)];
      for (int x0 = 0; x0 < stride; x0 += kBlock)
        for (int x = x0; x < x0 + kBlock; ++x) k[x] &= static_cast<std::int16_t>(d[x] > lim);
    }
    const std::size_t c0 = g.index(bx0, by0 + y);
    for (int x = 0; x < bw; ++x) {
      const float hx = g.heights[c0 + x];
      out[c0 + x] = hx - hx == 0.0f ? static_cast<std::uint8_t>(clear[x]) : out[c0 + x];
    }
  }
}

}  // namespace core
}  // namespace tilt_laser_perception
