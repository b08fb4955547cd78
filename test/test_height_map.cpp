// The height map: polygons filled, obstacles marked, mixed pixels, a grid built again.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <tuple>

#include <Eigen/Eigenvalues>

#include "tilt_laser_perception/core/height_map.hpp"
#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/core/sequence.hpp"
#include "tilt_laser_perception/core/sweep.hpp"

using namespace tilt_laser_perception::core;

namespace {
/// A map of 1 cm cells, its cell (0, 0) at (x0, y0) [m].
HeightMapParams mapParams(double x0, double y0, int width, int height) {
  HeightMapParams p;
  p.origin_x = x0;
  p.origin_y = y0;
  p.width = width;
  p.height = height;
  return p;
}
}  // namespace

TEST(HeightMap, FillsPolygonsAndMarksObstacles) {
  SweepResult s;
  Plane floor;
  floor.id = 0;
  floor.fit.normal = Eigen::Vector3d::UnitZ();
  floor.fit.offset = 0.0;
  floor.fit.centroid = Eigen::Vector3d(1, 0, 0);
  floor.area = 4.0;
  floor.boundary = {{0, -1, 0}, {2, -1, 0}, {2, 1, 0}, {0, 1, 0}};
  floor.holes = {{{0.5, -0.25, 0}, {1.0, -0.25, 0}, {1.0, 0.25, 0}, {0.5, 0.25, 0}}};
  Plane top = floor;
  top.id = 1;
  top.fit.offset = 0.2;
  top.fit.centroid = Eigen::Vector3d(0.75, 0, 0.2);
  top.area = 0.25;
  top.boundary = {{0.5, -0.25, 0.2}, {1.0, -0.25, 0.2}, {1.0, 0.25, 0.2}, {0.5, 0.25, 0.2}};
  top.holes.clear();
  s.planes = {floor, top};
  // A pole at (1.5, 0.5): points up to 1 m, in no plane.
  SweepLine line;
  for (int i = 0; i < 10; ++i) line.points.emplace_back(1.505f, 0.505f, 0.1f * (i + 1));
  s.lines.push_back(line);
  const HeightMapParams p = mapParams(0.0, -1.0, 200, 200);
  HeightMapGrid g;
  buildHeightMap(s, p, g);
  const auto at = [&](double x, double y) { return g.index(static_cast<int>(x / 0.01), static_cast<int>((y + 1.0) / 0.01)); };
  EXPECT_NEAR(g.heights[at(0.2, 0.0)], 0.0, 1e-6);
  EXPECT_EQ(g.classes[at(0.2, 0.0)], CellClass::Floor);
  EXPECT_NEAR(g.heights[at(0.75, 0.0)], 0.2, 1e-6);  // in the floor's hole: the top
  EXPECT_EQ(g.classes[at(0.75, 0.0)], CellClass::Step);
  EXPECT_EQ(g.plane_ids[at(0.75, 0.0)], 1);
  EXPECT_NEAR(g.heights[at(1.5, 0.5)], 1.0, 1e-6);
  EXPECT_EQ(g.classes[at(1.5, 0.5)], CellClass::Obstacle);
  EXPECT_EQ(g.classes[at(1.9, 0.99)], CellClass::Floor);  // the floor's far corner (an out-of-map read here: found by ASan)
  EXPECT_EQ(g.floor_plane, 0);
}

TEST(HeightMap, AMixedPixelIsNoObstacle) {
  // One scan line from (0, 0, 1.3): a box top (z 0.3, in no plane) up to its
  // edge E, then a mixed pixel V halfway along E's ray to the floor behind,
  // then the floor from F on. V stands 0.15 m above the floor, but the split
  // marked it a veil point: not an obstacle. E is the box.
  SweepResult s;
  Plane floor;
  floor.fit.normal = Eigen::Vector3d::UnitZ();
  floor.fit.centroid = Eigen::Vector3d(1, 0, 0);
  floor.area = 4.0;
  floor.boundary = {{0, -1, 0}, {2, -1, 0}, {2, 1, 0}, {0, 1, 0}};
  s.planes = {floor};
  const Eigen::Vector3f origin(0.0f, 0.0f, 1.3f), edge(1.003f, 0.053f, 0.3f);  // off cell borders
  const Eigen::Vector3f far = origin + 1.3f * (edge - origin), veil = 0.5f * (edge + far);
  SweepLine line;
  line.origin = origin;
  for (int k = 0; k < 5; ++k) line.points.emplace_back(1.0f, 0.01f * k, 0.3f);
  line.points.push_back(edge);
  line.points.push_back(veil);
  for (int k = 0; k < 5; ++k) line.points.push_back(far + Eigen::Vector3f(0.0f, 0.013f * k, 0.0f));
  line.edges = {{5, EdgeKind::Jump}, {6, EdgeKind::Veil}, {7, EdgeKind::Occluded}};
  s.lines.push_back(line);
  const HeightMapParams p = mapParams(0.0, -1.0, 200, 200);
  const auto cell = [&](const HeightMapGrid& g, const Eigen::Vector3f& q) {
    return g.index(static_cast<int>(q.x() / 0.01), static_cast<int>((q.y() + 1.0) / 0.01));
  };
  HeightMapGrid g;
  buildHeightMap(s, p, g);
  EXPECT_EQ(g.classes[cell(g, veil)], CellClass::Floor);
  EXPECT_NEAR(g.heights[cell(g, veil)], 0.0, 1e-6);
  EXPECT_EQ(g.classes[cell(g, edge)], CellClass::Obstacle);
  EXPECT_NEAR(g.heights[cell(g, edge)], 0.3, 1e-6);
  s.lines[0].edges = {{5, EdgeKind::Jump}, {7, EdgeKind::Occluded}};  // not marked: V is an obstacle
  buildHeightMap(s, p, g);
  EXPECT_EQ(g.classes[cell(g, veil)], CellClass::Obstacle);
  EXPECT_NEAR(g.heights[cell(g, veil)], veil.z(), 1e-6);
}

namespace {
/// A sweep of one line of `points` on a face (plane 1, its `outline` 0.3 m
/// high: no step) standing on a floor (plane 0), seen from (0, 0, 1.3).
SweepResult faceSweep(const PlaneFit& fit, const std::vector<Eigen::Vector3d>& outline,
                      const std::vector<Eigen::Vector3f>& points) {
  SweepResult s;
  Plane floor;
  floor.id = 0;
  floor.fit.normal = Eigen::Vector3d::UnitZ();
  floor.area = 4.0;
  floor.boundary = {{0, -1, 0}, {2, -1, 0}, {2, 1, 0}, {0, 1, 0}};
  Plane face;
  face.id = 1;
  face.fit = fit;
  face.area = 0.06;
  face.boundary = outline;
  SweepLine line;
  line.origin = Eigen::Vector3f(0.0f, 0.0f, 1.3f);
  line.points = points;
  s.lines.push_back(line);
  Segment3 seg;
  makeSegment3(line.points, std::vector<float>(points.size(), 1.5f), 0, 0, static_cast<int>(points.size()) - 1, seg);
  face.members = {0};
  s.segments = {seg};
  s.segment_plane = {1};
  s.planes = {floor, face};
  return s;
}

/// A box's front face at x = 0.8 m (a cell border), 0.3 m high over y +-0.1
/// m, its plane fitted 1.2 mm in front of it (as range noise leaves it), and
/// a line of `points` on it.
SweepResult boxFront(const std::vector<Eigen::Vector3f>& points) {
  PlaneFit fit;
  fit.normal = -Eigen::Vector3d::UnitX();  // towards the sensor
  fit.offset = -0.7988;
  fit.centroid = Eigen::Vector3d(0.7988, 0.0, 0.15);
  return faceSweep(fit, {{0.7988, -0.1, 0.0}, {0.7988, 0.1, 0.0}, {0.7988, 0.1, 0.3}, {0.7988, -0.1, 0.3}}, points);
}
}  // namespace

TEST(HeightMap, AFacesPointsMarkTheCellsBehindItWithItsTop) {
  // boxFront seen from (0, 0, 1.3), crossed by one line 5 cm above the floor
  // (a spinning head's line crosses a face low or high, not along its top).
  // Its points mark the box's cells (x 0.80-0.81), not the floor's before it,
  // with the face's top, 0.3 m, not the line's 5 cm.
  std::vector<Eigen::Vector3f> pts;
  for (int k = 0; k < 20; ++k) pts.emplace_back(0.7988f + 0.001f * (k % 3), -0.095f + 0.01f * k, 0.05f);
  const SweepResult s = boxFront(pts);
  HeightMapGrid g;
  buildHeightMap(s, mapParams(0.0, -1.0, 200, 200), g);
  for (int k = 0; k < 20; ++k) {
    const int iy = static_cast<int>((-0.095 + 0.01 * k + 1.0) / 0.01);
    EXPECT_EQ(g.classes[g.index(80, iy)], CellClass::Obstacle) << k;  // x 0.80-0.81
    EXPECT_NEAR(g.heights[g.index(80, iy)], 0.3, 1e-4) << k;
    EXPECT_EQ(g.classes[g.index(79, iy)], CellClass::Floor) << k;  // x 0.79-0.80
  }
}

TEST(HeightMap, APointOfNoPlaneWithinRangeNoiseOfAFaceIsTheFaces) {
  // boxFront, and a second line whose points no plane took (a short piece
  // of a spinning line down the face): 10 of them 1.4 cm in front of the
  // face at z 0.1 (2.5 cm along their rays, within 3 sigma of the 1 cm range
  // noise), 10 of them 6 cm in front (11 cm along their rays: an obstacle).
  std::vector<Eigen::Vector3f> on;
  for (int k = 0; k < 20; ++k) on.emplace_back(0.7988f, -0.095f + 0.01f * k, 0.2f);
  SweepResult s = boxFront(on);
  SweepLine loose;
  loose.origin = Eigen::Vector3f(0.0f, 0.0f, 1.3f);
  for (int k = 0; k < 10; ++k) loose.points.emplace_back(0.785f, -0.095f + 0.01f * k, 0.1f);
  for (int k = 0; k < 10; ++k) loose.points.emplace_back(0.74f, 0.005f + 0.01f * k, 0.1f);
  s.lines.push_back(loose);
  HeightMapGrid g;
  buildHeightMap(s, mapParams(0.0, -1.0, 200, 200), g);
  for (int k = 0; k < 10; ++k) {
    const int iy = static_cast<int>((-0.095 + 0.01 * k + 1.0) / 0.01);
    EXPECT_EQ(g.classes[g.index(78, iy)], CellClass::Floor) << k;  // x 0.78-0.79: the point's own cell
    EXPECT_NEAR(g.heights[g.index(80, iy)], 0.3, 1e-4) << k;    // behind the face: its top
  }
  for (int k = 0; k < 10; ++k) {
    const int iy = static_cast<int>((0.005 + 0.01 * k + 1.0) / 0.01);
    EXPECT_EQ(g.classes[g.index(74, iy)], CellClass::Obstacle) << k;
    EXPECT_NEAR(g.heights[g.index(74, iy)], 0.1, 1e-4) << k;
  }
}

TEST(HeightMap, AFaceAtAnAngleMarksOnlyTheCellsWhoseCentresLieBehindIt) {
  // An upright face yawed 30 degrees (x = 0.8 + 0.577 (y + 0.1), facing the
  // sensor): it crosses cells at an angle. Its points mark cells whose
  // centres lie behind it, never one whose centre lies in front (the floor
  // there, 0.3 m below the face's top).
  const Eigen::Vector3d n = Eigen::Vector3d(-std::cos(M_PI / 6.0), std::sin(M_PI / 6.0), 0.0);
  PlaneFit fit;
  fit.normal = n;
  fit.centroid = Eigen::Vector3d(0.8 + std::tan(M_PI / 6.0) * 0.1, 0.0, 0.15);
  fit.offset = n.dot(fit.centroid);
  const auto onFace = [&](double y, double z) { return Eigen::Vector3d(0.8 + std::tan(M_PI / 6.0) * (y + 0.1), y, z); };
  std::vector<Eigen::Vector3f> pts;
  for (int k = 0; k < 40; ++k) pts.push_back(onFace(-0.095 + 0.005 * k, 0.05 + 0.005 * k).cast<float>());
  const SweepResult s =
      faceSweep(fit, {onFace(-0.1, 0.0), onFace(0.1, 0.0), onFace(0.1, 0.3), onFace(-0.1, 0.3)}, pts);
  HeightMapGrid g;
  buildHeightMap(s, mapParams(0.0, -1.0, 200, 200), g);
  int marked = 0;
  for (int iy = 0; iy < 200; ++iy)
    for (int ix = 0; ix < 200; ++ix) {
      if (g.classes[g.index(ix, iy)] != CellClass::Obstacle) continue;
      ++marked;
      const Eigen::Vector3d c(0.005 + 0.01 * ix, -1.0 + 0.005 + 0.01 * iy, 0.15);
      EXPECT_LT(n.dot(c) - fit.offset, 0.0) << ix << " " << iy;  // behind the face
      EXPECT_NEAR(g.heights[g.index(ix, iy)], 0.3, 1e-4);
    }
  EXPECT_GE(marked, 18);  // a cell along each centimetre of the 0.2 m it spans in y, about
}

TEST(HeightMap, AFacesPointBeyondItsOutlinesEndMarksNothing) {
  // boxFront ends at y = +-0.1 m (the box's corners, its sides going back from there).
  // A point of it that range noise put 4 mm past the corner would mark the
  // cell beyond, outside the box, with the box's top: it marks nothing.
  std::vector<Eigen::Vector3f> pts;
  for (int k = 0; k < 20; ++k) pts.emplace_back(0.7988f, -0.095f + 0.01f * k, 0.05f);
  pts.emplace_back(0.7988f, 0.104f, 0.05f);
  const SweepResult s = boxFront(pts);
  HeightMapGrid g;
  buildHeightMap(s, mapParams(0.0, -1.0, 200, 200), g);
  EXPECT_EQ(g.classes[g.index(80, 109)], CellClass::Obstacle);  // y 0.09-0.10: the box's
  EXPECT_EQ(g.classes[g.index(80, 110)], CellClass::Floor);     // y 0.10-0.11: beyond its corner
}

TEST(HeightMap, AFaceThatLeansIsAsHighOverACellAsItsPlane) {
  // A face too steep to walk but leaning 45 degrees (z = x - 0.8 over x
  // 0.8-1.1): a cell behind it holds the plane's height over the cell (its
  // highest corner), not the face's top 0.3 m.
  const Eigen::Vector3d n = Eigen::Vector3d(-1.0, 0.0, 1.0).normalized();
  PlaneFit fit;
  fit.normal = n;
  fit.centroid = Eigen::Vector3d(0.95, 0.0, 0.15);
  fit.offset = n.dot(fit.centroid);
  std::vector<Eigen::Vector3f> pts;
  for (int k = 0; k < 20; ++k) pts.emplace_back(0.9f, -0.095f + 0.01f * k, 0.1f);
  const SweepResult s = faceSweep(fit, {{0.8, -0.1, 0.0}, {0.8, 0.1, 0.0}, {1.1, 0.1, 0.3}, {1.1, -0.1, 0.3}}, pts);
  HeightMapGrid g;
  buildHeightMap(s, mapParams(0.0, -1.0, 200, 200), g);
  for (int k = 0; k < 20; ++k) {
    const int iy = static_cast<int>((-0.095 + 0.01 * k + 1.0) / 0.01);
    int hits = 0;
    for (int ix = 85; ix <= 95; ++ix) {
      const std::size_t c = g.index(ix, iy);
      if (g.classes[c] != CellClass::Obstacle) continue;
      ++hits;
      EXPECT_NEAR(g.heights[c], 0.01 * (ix + 1) - 0.8, 1e-4) << ix;  // the plane at the cell's far edge
    }
    EXPECT_EQ(hits, 1) << k;
  }
}

TEST(HeightMap, AGridBuiltAgainEqualsAFreshOne) {
  // buildHeightMap clears only the last map's box when it is given that map
  // again: a second, smaller sweep into the same grid must equal the grid a
  // fresh build of it gives (nothing of the first left outside the second's box).
  const auto floorSweep = [](double x0, double x1, double y0, double y1, double z) {
    SweepResult s;
    Plane pl;
    pl.fit.normal = Eigen::Vector3d::UnitZ();
    pl.fit.offset = z;
    pl.fit.centroid = Eigen::Vector3d(0.5 * (x0 + x1), 0.5 * (y0 + y1), z);
    pl.area = (x1 - x0) * (y1 - y0);
    pl.boundary = {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
    s.planes = {pl};
    SweepLine line;  // a pole: an obstacle cell
    for (int i = 0; i < 5; ++i) line.points.emplace_back(static_cast<float>(x1 - 0.05), static_cast<float>(y0 + 0.05), 0.1f * (i + 1));
    s.lines.push_back(line);
    return s;
  };
  const HeightMapParams p = mapParams(0.0, -1.0, 200, 200);
  HeightMapGrid reused, fresh;
  buildHeightMap(floorSweep(0.1, 1.9, -0.9, 0.9, 0.0), p, reused);
  const int known_first = static_cast<int>(std::count_if(reused.heights.begin(), reused.heights.end(), [](float h) { return !std::isnan(h); }));
  const SweepResult second = floorSweep(0.5, 1.0, -0.2, 0.3, 0.1);
  buildHeightMap(second, p, reused);
  buildHeightMap(second, p, fresh);
  ASSERT_EQ(reused.heights.size(), fresh.heights.size());
  int differ = 0, known = 0;
  for (std::size_t c = 0; c < fresh.heights.size(); ++c) {
    const bool same_h = (std::isnan(reused.heights[c]) && std::isnan(fresh.heights[c])) || reused.heights[c] == fresh.heights[c];
    differ += !same_h || reused.classes[c] != fresh.classes[c] || reused.plane_ids[c] != fresh.plane_ids[c];
    known += !std::isnan(fresh.heights[c]);
  }
  EXPECT_GT(known_first, 30000);
  EXPECT_GT(known, 2000);
  EXPECT_LT(known, 3000);
  EXPECT_EQ(differ, 0);
  EXPECT_EQ(reused.box_x0, fresh.box_x0);
  EXPECT_EQ(reused.box_y1, fresh.box_y1);
}

TEST(HeightMap, APlaneFillsOnlyBetweenItsLinesNotAcrossWhatTheyDidNotSee) {
  // A spinning head's lines on the floor all pass where its axis meets it,
  // here (1, 0), hidden (a box stands there): each line is two segments,
  // 0.3 to 1 m either side of it. A half turn of 19 lines 10 degrees apart.
  // The floor between neighbouring lines is known on both sides; within
  // 0.2 m of the hidden point, which no line saw, nothing is (its outline
  // would have claimed it); a cell between two lines' chords is known
  // whichever way they cross.
  SweepResult s;
  Plane floor;
  floor.id = 0;
  floor.fit.normal = Eigen::Vector3d::UnitZ();
  floor.fit.centroid = Eigen::Vector3d(1, 0, 0);
  floor.area = 3.0;
  const Eigen::Vector3d hub(1.0, 0.0, 0.0);
  for (int k = 0; k < 19; ++k) {
    const double a = k * 10.0 * M_PI / 180.0;
    const Eigen::Vector3d d(std::cos(a), std::sin(a), 0.0);
    SweepLine line;
    for (int i = 0; i <= 100; ++i) line.points.push_back((hub + (-1.0 + 0.02 * i) * d).cast<float>());
    s.lines.push_back(line);
    for (const auto& [first, last] : {std::pair<int, int>{0, 35}, {65, 100}}) {
      Segment3 seg;
      seg.line = k;
      seg.first = first;
      seg.last = last;
      seg.start = hub + (-1.0 + 0.02 * first) * d;
      seg.end = hub + (-1.0 + 0.02 * last) * d;
      floor.members.push_back(static_cast<int>(s.segments.size()));
      s.segments.push_back(seg);
      s.segment_plane.push_back(0);
    }
  }
  s.planes = {floor};
  const HeightMapParams p = mapParams(-0.5, -1.5, 300, 300);
  HeightMapGrid g;
  buildHeightMap(s, p, g);
  const auto at = [&](double x, double y) {
    return g.index(static_cast<int>((x - p.origin_x) / 0.01), static_cast<int>((y - p.origin_y) / 0.01));
  };
  int known = 0, ring = 0, inner = 0, inner_known = 0;
  for (int deg = 0; deg < 360; deg += 3) {
    const double a = deg * M_PI / 180.0;
    ++ring;
    known += std::isfinite(g.heights[at(1.0 + 0.6 * std::cos(a), 0.6 * std::sin(a))]);
    ++inner;
    inner_known += std::isfinite(g.heights[at(1.0 + 0.15 * std::cos(a), 0.15 * std::sin(a))]);
  }
  EXPECT_EQ(known, ring);  // all around, between every two lines
  EXPECT_EQ(inner_known, 0) << "of " << inner;
  EXPECT_NEAR(g.heights[at(1.6, 0.03)], 0.0, 1e-6);
  EXPECT_EQ(g.classes[at(1.6, 0.03)], CellClass::Floor);
}

namespace {
/// A nodding head at (0, 0, 1.4) over the floor and one level top at height
/// h, `length` along x and 1.2 m wide, centred on (cx, cy) and turned by
/// `yaw_deg`: a table (the top alone: the floor under it seen from the
/// front) or, not turned, a box (its front face too). Lines of beams along
/// y, steepest first, `slope_step` apart in the tangent of their depression
/// (0.015: 4-7 cm apart on a top 0.75 m up 2 m away); each line's runs on
/// the floor and on the top are segments of planes 0 and 1; the front
/// face's points are in none.
SweepResult overhangSweep(double h, double cx, double cy, double length, double yaw_deg, bool front_face,
                          double slope_step = 0.015, bool mixed = false) {
  SweepResult s;
  const Eigen::Vector3d o(0.0, 0.0, 1.4);
  const double c = std::cos(yaw_deg * M_PI / 180.0), sn = std::sin(yaw_deg * M_PI / 180.0);
  const double x0 = cx - 0.5 * length;  // the front face's (not turned)
  const auto onTop = [&](const Eigen::Vector3d& q) {
    const double u = c * (q.x() - cx) + sn * (q.y() - cy), v = -sn * (q.x() - cx) + c * (q.y() - cy);
    return std::abs(u) <= 0.5 * length && std::abs(v) <= 0.6;
  };
  Plane floor, top;
  floor.id = 0;
  floor.area = 10.0;
  top.id = 1;
  top.area = 0.5;
  top.fit.offset = h;
  top.fit.centroid = Eigen::Vector3d(cx, cy, h);
  for (double slope = 1.2; slope > 0.2; slope -= slope_step) {
    SweepLine line;
    line.origin = o.cast<float>();
    std::vector<int> surface;
    for (int b = 0; b <= 150; ++b) {
      const Eigen::Vector3d d(1.0, -0.75 + 0.01 * b, -slope);
      double t = -o.z() / d.z();
      int on = 0;
      const double t_top = (h - o.z()) / d.z(), t_face = (x0 - o.x()) / d.x();
      const Eigen::Vector3d at_face = o + t_face * d;
      if (onTop(o + t_top * d)) {
        t = t_top;
        on = 1;
      } else if (front_face && at_face.z() >= 0.0 && at_face.z() <= h && std::abs(at_face.y() - cy) <= 0.6 &&
                 t_face < t) {
        t = t_face;
        on = 2;
      }
      line.points.push_back((o + t * d).cast<float>());
      surface.push_back(on);
    }
    // mixed: the beam beside each run on the top is a mixed pixel, its range
    // 3 cm beyond the top's (its end 2-3 cm under the top's height), in no
    // segment, marked a veil as the split marks it.
    for (int b = 0; mixed && b <= 150; ++b) {
      const bool beside = surface[b] == 0 && ((b > 0 && surface[b - 1] == 1) || (b < 150 && surface[b + 1] == 1));
      if (!beside) continue;
      const Eigen::Vector3d d = (line.points[b].cast<double>() - o).normalized();
      const double t_top = (h - o.z()) / d.z();
      line.points[b] = (o + (t_top + 0.03) * d).cast<float>();
      line.edges.emplace_back(b, EdgeKind::Veil);
      surface[b] = 3;
    }
    const int li = static_cast<int>(s.lines.size());
    for (int b = 0; b <= 150;) {
      int e = b;
      while (e < 150 && surface[e + 1] == surface[b]) ++e;
      // mixed: the top's run's outer beams in no segment (the split left them
      // out: a piece too short for one)
      const int cut = mixed && surface[b] == 1 && e - b > 4 ? 1 : 0;
      if (surface[b] < 2 && e > b) {
        Segment3 seg;
        makeSegment3(line.points, std::vector<float>(line.points.size(), 2.0f), li, b + cut, e - cut, seg);
        seg.origin = o;
        (surface[b] == 0 ? floor : top).members.push_back(static_cast<int>(s.segments.size()));
        s.segments.push_back(seg);
        s.segment_plane.push_back(surface[b]);
      }
      b = e + 1;
    }
    s.lines.push_back(line);
  }
  s.planes = {floor, top};
  return s;
}
}  // namespace

TEST(HeightMap, WhatLiesBeneathWhereAnOverhangMayGoOnIsUnknown) {
  // A table top 0.75 m up over x 1.76-2.52. The floor under it is seen from
  // the front, under its edge; its lines (some 10-15 cm apart) end short of
  // its edges. Between its outermost line and where the next line's rays
  // crossed its height (passing on to the far floor) the top may go on: the
  // floor seen there from under it is not the 2.5D surface, so unknown.
  const SweepResult table = overhangSweep(0.75, 2.14, 0.0, 0.76, 0.0, false);
  const HeightMapParams p = mapParams(0.5, -1.0, 400, 200);
  HeightMapGrid g;
  buildHeightMap(table, p, g);
  const auto at = [&](double x, double y) {
    return g.index(static_cast<int>((x - p.origin_x) / 0.01), static_cast<int>((y - p.origin_y) / 0.01));
  };
  // The top's first and last lines on it (x where their beam 50 hits it).
  double first = 1e9, last = -1e9;
  for (const int si : table.planes[1].members) {
    first = std::min(first, table.segments[si].start.x());
    last = std::max(last, table.segments[si].start.x());
  }
  ASSERT_GT(first, 1.78);
  ASSERT_LT(last, 2.5);  // (both edges short of the lines: the band exists)
  int wrong = 0, cells = 0;
  for (double x = 1.765; x < 2.52; x += 0.01) {
    const float z = g.heights[at(x, 0.005)];
    ++cells;
    wrong += std::isfinite(z) && std::abs(z - 0.75f) > 0.01f;  // the floor's 0 where the top is
  }
  EXPECT_EQ(wrong, 0) << "of " << cells << " cells under the top";
  EXPECT_NEAR(g.heights[at(2.2, 0.005)], 0.75, 1e-4);
  EXPECT_NEAR(g.heights[at(1.5, 0.005)], 0.0, 1e-4);  // the floor in front, seen from above
  EXPECT_NEAR(g.heights[at(3.0, 0.005)], 0.0, 1e-4);  // and behind, beyond where the top may go
  // A box instead (the same top, its front face seen): the edge is seen, the
  // floor before it stays known up to the face.
  buildHeightMap(overhangSweep(0.2, 2.14, 0.0, 0.76, 0.0, true), p, g);
  for (double x = 1.505; x < 1.75; x += 0.01) EXPECT_NEAR(g.heights[at(x, 0.005)], 0.0, 1e-4) << x;
}

namespace {
/// The turned table top's cells (centre cx, cy, turned by yaw, 0.76 x 1.2
/// m, 0.75 m up): those more than `in` inside its edges (`under`, and of
/// them `wrong`, holding no height within 1 cm of its) and those more than
/// `out` outside them (`beyond`, and of them `invented`, `claimed(cell)`).
struct TopCells {
  int under = 0, wrong = 0, beyond = 0, invented = 0;
};
TopCells turnedTopCells(const HeightMapGrid& g, const HeightMapParams& p, double cx, double cy, double yaw, double in,
                        double out, const std::function<bool(std::size_t)>& claimed) {
  TopCells t;
  for (int iy = 0; iy < p.height; ++iy)
    for (int ix = 0; ix < p.width; ++ix) {
      const double x = p.origin_x + (ix + 0.5) * 0.01, y = p.origin_y + (iy + 0.5) * 0.01;
      const double u = std::cos(yaw) * (x - cx) + std::sin(yaw) * (y - cy);
      const double v = -std::sin(yaw) * (x - cx) + std::cos(yaw) * (y - cy);
      const double inside = std::min(0.38 - std::abs(u), 0.6 - std::abs(v));  // to the nearest edge
      const std::size_t c = g.index(ix, iy);
      const float z = g.heights[c];
      if (inside > in) {
        ++t.under;
        t.wrong += std::isfinite(z) && std::abs(z - 0.75f) > 0.01f;
      } else if (inside < -out) {
        ++t.beyond;
        t.invented += claimed(c);
      }
    }
  return t;
}
}  // namespace

TEST(HeightMap, ACornerItsLinesCutIsTheCornerOfItsEdges) {
  // The table top turned by 40 degrees, its lines 6-10 cm apart: they cross
  // its corners at an angle, and the floor seen under it filled what the
  // chords between their ends cut off (79 cells 0.75 m wrong). Its edges run
  // on straight to the corners, which no line saw; not beyond them.
  const double cx = 2.3, cy = 0.0, yaw = 40.0 * M_PI / 180.0;
  const HeightMapParams p = mapParams(0.5, -1.5, 400, 300);
  HeightMapGrid g;
  buildHeightMap(overhangSweep(0.75, cx, cy, 0.76, 40.0, false, 0.025), p, g);
  // (A line's end lies up to a beam short of the edge: 0.01 rad, 2.5 cm here.)
  const TopCells t = turnedTopCells(g, p, cx, cy, yaw, 0.025, 0.015,
                                    [&](std::size_t c) { return std::isfinite(g.heights[c]) && g.heights[c] > 0.5f; });
  EXPECT_EQ(t.wrong, 0) << "of " << t.under << " cells under the top";
  EXPECT_EQ(t.invented, 0) << "of " << t.beyond << " cells beside it";
  EXPECT_GT(t.under, 3000);
}

TEST(HeightMap, ACornerItsLinesCutIsFoundPastMixedPixelsAtItsEdges) {
  // The same turned table top, each of its lines' pieces a beam short at
  // either end (the beam on the top in no segment) and the beam beyond a mixed
  // pixel (a footprint across the edge: its end 2-3 cm under the top, a veil
  // to the split). Looked past, the beams beyond show the top's own edges,
  // and the corners are filled as without them (the beam beside the end
  // alone, or the first past the veils, told nothing: 25 cells more than
  // 5 cm inside the top held the floor seen under it, 0.75 m wrong).
  const double cx = 2.3, cy = 0.0, yaw = 40.0 * M_PI / 180.0;
  const HeightMapParams p = mapParams(0.5, -1.5, 400, 300);
  HeightMapGrid g;
  buildHeightMap(overhangSweep(0.75, cx, cy, 0.76, 40.0, false, 0.025, true), p, g);
  // (A line's end lies up to two beams short of the edge, 5 cm; a mixed
  // pixel's end up to 3 cm beyond it, marked as what it is: only the top's
  // plane carried past its edge counts.)
  const TopCells t = turnedTopCells(g, p, cx, cy, yaw, 0.05, 0.03, [&](std::size_t c) { return g.plane_ids[c] == 1; });
  EXPECT_EQ(t.wrong, 0) << "of " << t.under << " cells under the top";
  EXPECT_EQ(t.invented, 0) << "of " << t.beyond << " cells beside it";
  EXPECT_GT(t.under, 3000);
}

TEST(HeightMap, AStripStopsWhereTheNextLineSawSomethingElse) {
  // Two lines of floor 10 cm apart (x 2.0 and 2.1), beams along y 1 cm
  // apart. The first passed beside a box; the second hit its face over
  // y -0.14..0.14 (points 0.3 m up: in no segment), its floor in two pieces.
  // The strips from the first line's one piece to each of them covered the
  // box's footprint between the lines with floor (a dark box's top in the
  // clutter scene 0.5 m wrong); they stop where the second line's pieces
  // end. Where the gap holds no returns, or points on the floor, it is no
  // obstacle and the floor is drawn across it.
  const auto sweepWith = [](int gap) {  // 0: a box's face, 1: no returns, 2: loose points on the floor
    SweepResult s;
    Plane floor;
    floor.id = 0;
    floor.area = 1.0;
    floor.fit.normal = Eigen::Vector3d::UnitZ();
    floor.fit.offset = 0.0;
    floor.fit.centroid = Eigen::Vector3d(2.05, 0, 0);
    const Eigen::Vector3d o(0.0, 0.0, 1.4);
    for (const double x : {2.0, 2.1}) {
      SweepLine line;
      line.origin = o.cast<float>();
      const int li = static_cast<int>(s.lines.size());
      for (int b = 0; b <= 100; ++b) {
        const double y = -0.5 + 0.01 * b;
        const bool in_gap = li == 1 && b > 35 && b < 65;
        const float nan = std::numeric_limits<float>::quiet_NaN();
        line.points.push_back(!in_gap ? Eigen::Vector3f(x, y, 0.0f)
                              : gap == 0 ? Eigen::Vector3f(x - 0.05, y, 0.3f)
                              : gap == 1 ? Eigen::Vector3f(nan, nan, nan)
                                         : Eigen::Vector3f(x, y, 0.004f));
      }
      for (const auto& [b0, b1] : li == 0 ? std::vector<std::pair<int, int>>{{0, 100}}
                                          : std::vector<std::pair<int, int>>{{0, 35}, {65, 100}}) {
        Segment3 seg;
        makeSegment3(line.points, std::vector<float>(line.points.size(), 2.0f), li, b0, b1, seg);
        seg.origin = o;
        floor.members.push_back(static_cast<int>(s.segments.size()));
        s.segments.push_back(seg);
        s.segment_plane.push_back(0);
      }
      s.lines.push_back(line);
    }
    s.planes = {floor};
    return s;
  };
  const HeightMapParams p = mapParams(1.5, -1.0, 100, 200);
  HeightMapGrid g;
  const auto floorBetween = [&](double y0, double y1) {  // cells of floor between the lines (x 2.02-2.08)
    int n = 0;
    for (double x = 2.025; x < 2.08; x += 0.01)
      for (double y = y0 + 0.005; y < y1; y += 0.01)
        n += std::abs(g.heights[g.index(static_cast<int>((x - p.origin_x) / 0.01),
                                        static_cast<int>((y - p.origin_y) / 0.01))]) < 0.01f;
    return n;
  };
  buildHeightMap(sweepWith(0), p, g);
  EXPECT_EQ(floorBetween(-0.13, 0.13), 0);   // the box's footprint: not floor
  EXPECT_EQ(floorBetween(-0.45, -0.16), 174);  // beside it, floor (6 x 29 cells)
  EXPECT_EQ(floorBetween(0.16, 0.45), 174);
  for (const int gap : {1, 2}) {
    buildHeightMap(sweepWith(gap), p, g);
    EXPECT_EQ(floorBetween(-0.13, 0.13), 6 * 26) << "gap " << gap;
  }
}

TEST(HeightMap, ALandingGoesOnToItsEdgeWhereTheLineBeforeSawIt) {
  // A landing 0.8 m up whose first line lies at x 1.9; the line before it
  // ended on the riser's top (z 0.78, x 1.8) just under the landing's front
  // edge. The floor was seen beneath the landing (through the stairs' open
  // side) and filled x 1.7-2.0: between the riser and the landing's first
  // line the map said floor, 0.8 m below the landing. The landing goes on to
  // the edge that line saw (less the range noise at the one significance
  // level, 3 cm); the floor in front of the riser stays. Then the same with
  // the landing's outline through that line's ends 1 cm beyond the line (as
  // range noise at its two end beams may put them): the strip from the line
  // overlaps the plane by half a cell's diagonal, and the cells between the
  // line and the outline are the landing's, not the floor's.
  for (const bool outline : {false, true}) {
    SweepResult s;
    Plane floor, landing;
    floor.id = 0;
    floor.area = 1.0;
    floor.fit.normal = Eigen::Vector3d::UnitZ();
    floor.fit.offset = 0.0;
    floor.fit.centroid = Eigen::Vector3d(1.85, 0, 0);
    landing = floor;
    landing.id = 1;
    landing.fit.offset = 0.8;
    landing.fit.centroid = Eigen::Vector3d(2.0, 0, 0.8);
    if (outline)  // each line's entry in order, then each line's exit back
      landing.boundary = {{1.91, -0.5, 0.8}, {2.0, -0.5, 0.8}, {2.1, -0.5, 0.8},
                          {2.1, 0.5, 0.8},   {2.0, 0.5, 0.8},  {1.91, 0.5, 0.8}};
    const Eigen::Vector3d o(0.0, 0.0, 1.4);
    // (line x, its height, the plane it is on: -1 none)
    const std::vector<std::tuple<double, double, int>> lines = {
        {1.7, 0.0, 0}, {2.0, 0.0, 0}, {1.8, 0.78, -1}, {1.9, 0.8, 1}, {2.0, 0.8, 1}, {2.1, 0.8, 1}};
    for (const auto& [x, z, plane] : lines) {
      SweepLine line;
      line.origin = o.cast<float>();
      const int li = static_cast<int>(s.lines.size());
      for (int b = 0; b <= 100; ++b) line.points.emplace_back(x, -0.5 + 0.01 * b, z);
      if (plane >= 0) {
        Segment3 seg;
        makeSegment3(line.points, std::vector<float>(line.points.size(), 2.0f), li, 0, 100, seg);
        seg.origin = o;
        (plane == 0 ? floor : landing).members.push_back(static_cast<int>(s.segments.size()));
        s.segments.push_back(seg);
        s.segment_plane.push_back(plane);
      }
      s.lines.push_back(line);
    }
    s.planes = {floor, landing};
    const HeightMapParams p = mapParams(1.5, -1.0, 100, 200);
    HeightMapGrid g;
    buildHeightMap(s, p, g);
    for (int row = 60; row < 140; ++row) {  // y -0.4 .. 0.4
      const auto at = [&](double x) { return g.heights[g.index(static_cast<int>((x - p.origin_x) / 0.01), row)]; };
      for (double x = 1.845; x < 1.96; x += 0.01)  // the landing, not the floor under it
        EXPECT_NEAR(at(x), 0.8, 1e-3) << x << " row " << row << (outline ? " outline" : "");
      for (double x = 1.705; x < 1.79; x += 0.01)  // the floor before the riser
        EXPECT_NEAR(at(x), 0.0, 1e-3) << x << " row " << row << (outline ? " outline" : "");
    }
  }
}

TEST(HeightMap, AFootRestsAcrossAShallowCreaseNotAcrossAStepOrASteepOne) {
  // Floor (plane 0) for x < 1 m, beyond it a second plane (1) from the
  // floor's height: a ramp of 5.7 degrees (over the foot's radius of 0.139 m
  // it leaves the floor by 1.4 cm, within the foot's 2 cm of roughness), a
  // ramp of 12 degrees (3 cm), or a level plane 3 cm up (a step).
  const auto across = [](double slope_deg, float step) {
    HeightMapGrid g;
    g.params.resolution = 0.01;
    g.params.origin_x = g.params.origin_y = 0.0;
    g.params.width = g.params.height = 200;
    g.heights.assign(200 * 200, 0.0f);
    g.plane_ids.assign(200 * 200, 0);
    g.classes.assign(200 * 200, CellClass::Floor);
    const double t = std::tan(slope_deg * M_PI / 180.0);
    for (int y = 0; y < 200; ++y)
      for (int x = 100; x < 200; ++x) {
        const std::size_t c = g.index(x, y);
        g.heights[c] = step + static_cast<float>(t * ((x + 0.5) * 0.01 - 1.0));
        g.plane_ids[c] = 1;
        g.classes[c] = CellClass::Step;
      }
    Plane floor, other;
    floor.id = 0;
    other.id = 1;
    other.fit.normal = Eigen::Vector3d(-std::sin(slope_deg * M_PI / 180.0), 0.0, std::cos(slope_deg * M_PI / 180.0));
    other.fit.offset = step * other.fit.normal.z() - 1.0 * other.fit.normal.x();
    std::vector<std::uint8_t> s;
    steppableCells(g, {floor, other}, FootParams(), s);
    return s[g.index(100, 100)];  // a foot centred on the crease
  };
  EXPECT_EQ(across(5.7, 0.0f), 1);
  EXPECT_EQ(across(12.0, 0.0f), 0);
  EXPECT_EQ(across(0.0, 0.03f), 0);
  EXPECT_EQ(across(0.0, 0.0f), 1);  // two planes of one level (a floor cut in two)
}

TEST(HeightMap, SteppableIsTheDiscTestOnEveryCellOfRandomMaps) {
  // Against the definition cell by cell: a known cell is steppable when
  // every cell whose centre lies within the foot's radius is in the map's
  // box and good (known, no obstacle, on a plane, no neighbour to its right
  // or below of another plane a foot may not reach over). Two planes 0.5 m
  // apart (never reached over), holes, obstacles, a box smaller than the map.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Plane low, high;
  low.id = 0;
  high.id = 1;
  high.fit.offset = 0.5;
  const FootParams foot;
  const double rc = foot.radius() / 0.01;
  int steppable = 0, not_steppable = 0;
  for (int trial = 0; trial < 20; ++trial) {
    HeightMapGrid g;
    g.params.resolution = 0.01;
    g.params.width = 90 + trial;
    g.params.height = 70 + 2 * trial;
    const int n = g.params.width * g.params.height;
    g.heights.assign(n, std::numeric_limits<float>::quiet_NaN());
    g.plane_ids.assign(n, -1);
    g.classes.assign(n, CellClass::Unknown);
    g.box_x0 = 2 + trial % 3;
    g.box_y0 = 1;
    g.box_x1 = g.params.width - 1 - trial % 2;
    g.box_y1 = g.params.height - 3;
    // A block of the high plane, holes and obstacles at random.
    const int hx0 = static_cast<int>(u(rng) * 60), hy0 = static_cast<int>(u(rng) * 50);
    const double holes = 0.002 * (trial % 4), obstacles = 0.001 * (trial % 3);
    for (int y = g.box_y0; y <= g.box_y1; ++y)
      for (int x = g.box_x0; x <= g.box_x1; ++x) {
        const std::size_t c = g.index(x, y);
        if (u(rng) < holes) continue;
        const bool on_high = x >= hx0 && x < hx0 + 25 && y >= hy0 && y < hy0 + 20;
        g.plane_ids[c] = on_high ? 1 : 0;
        g.heights[c] = on_high ? 0.5f : 0.0f;
        g.classes[c] = u(rng) < obstacles ? CellClass::Obstacle : on_high ? CellClass::Step : CellClass::Floor;
      }
    std::vector<std::uint8_t> s;
    steppableCells(g, {low, high}, foot, s);
    ASSERT_EQ(s.size(), static_cast<std::size_t>(n));
    const auto inBox = [&](int x, int y) { return x >= g.box_x0 && x <= g.box_x1 && y >= g.box_y0 && y <= g.box_y1; };
    const auto good = [&](int x, int y) {
      const std::size_t c = g.index(x, y);
      if (!std::isfinite(g.heights[c]) || g.classes[c] == CellClass::Obstacle || g.plane_ids[c] < 0) return false;
      if (x + 1 < g.params.width && g.plane_ids[c + 1] != g.plane_ids[c]) return false;
      if (y + 1 < g.params.height && g.plane_ids[c + g.params.width] != g.plane_ids[c]) return false;
      return true;
    };
    for (int y = 0; y < g.params.height; ++y)
      for (int x = 0; x < g.params.width; ++x) {
        const std::size_t c = g.index(x, y);
        if (!std::isfinite(g.heights[c])) {
          EXPECT_EQ(s[c], 255) << x << "," << y;
          continue;
        }
        bool fits = true;
        const int r = static_cast<int>(rc) + 1;
        for (int dy = -r; dy <= r && fits; ++dy)
          for (int dx = -r; dx <= r && fits; ++dx)
            if (dx * dx + dy * dy <= rc * rc) fits = inBox(x + dx, y + dy) && good(x + dx, y + dy);
        EXPECT_EQ(s[c], fits ? 1 : 0) << "trial " << trial << " cell " << x << "," << y;
        (fits ? steppable : not_steppable)++;
      }
  }
  // Both answers are common.
  EXPECT_GT(steppable, 5000);
  EXPECT_GT(not_steppable, 5000);
}

TEST(HeightMap, AFootOfAnyYawFitsWhereItsDiscLiesOnOnePlane) {
  // 2 x 2 m of floor (plane 0), a tread 0.15 m up over x 1.0-1.3 (plane 1),
  // an obstacle cell at (0.505, 0.505), a cell nobody saw at (1.705, 1.705),
  // a steep plane (2) over x 1.9-2.0. HRP-4's foot: 0.24 x 0.14 m, a disc of
  // radius 0.139 m over all its yaws.
  HeightMapGrid g;
  g.params.resolution = 0.01;
  g.params.origin_x = g.params.origin_y = 0.0;
  g.params.width = g.params.height = 200;
  const std::size_t n = 200 * 200;
  g.heights.assign(n, 0.0f);
  g.plane_ids.assign(n, 0);
  g.classes.assign(n, CellClass::Floor);
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) {
      const std::size_t c = g.index(x, y);
      if (x >= 100 && x < 130) {
        g.heights[c] = 0.15f;
        g.plane_ids[c] = 1;
        g.classes[c] = CellClass::Step;
      }
      if (x >= 190) g.plane_ids[c] = 2;
    }
  g.classes[g.index(50, 50)] = CellClass::Obstacle;
  g.heights[g.index(50, 50)] = 0.4f;
  g.plane_ids[g.index(50, 50)] = -1;
  g.heights[g.index(170, 170)] = std::numeric_limits<float>::quiet_NaN();
  g.plane_ids[g.index(170, 170)] = -1;
  Plane floor, tread, steep;
  floor.id = 0;
  tread.id = 1;
  tread.fit.offset = 0.15;
  steep.id = 2;
  steep.fit.normal = Eigen::Vector3d(std::sin(0.5), 0.0, std::cos(0.5));  // 29 degrees
  FootParams foot;
  ASSERT_EQ(foot.validate(), "");
  EXPECT_NEAR(foot.radius(), 0.1389, 1e-4);
  std::vector<std::uint8_t> s;
  steppableCells(g, {floor, tread, steep}, foot, s);
  const auto at = [&](double x, double y) { return s[g.index(static_cast<int>(x / 0.01), static_cast<int>(y / 0.01))]; };
  EXPECT_EQ(at(0.305, 1.505), 1);
  EXPECT_EQ(at(0.905, 1.005), 0);  // 9.5 cm from the tread's edge
  EXPECT_EQ(at(0.845, 1.005), 1);  // 15.5 cm
  EXPECT_EQ(at(1.155, 1.005), 1);  // the tread's middle: 15 cm from each edge
  EXPECT_EQ(at(1.055, 1.005), 0);
  EXPECT_EQ(at(0.505, 0.625), 0);  // 12 cm from the obstacle
  EXPECT_EQ(at(0.505, 0.655), 1);  // 15 cm
  EXPECT_EQ(at(0.615, 0.615), 1);  // 15.6 cm diagonally: within the square around the disc, outside the disc
  EXPECT_EQ(at(0.595, 0.595), 0);  // 12.7 cm diagonally
  EXPECT_EQ(at(1.705, 1.705), 255);
  EXPECT_EQ(at(1.705, 1.805), 0);  // 10 cm from the cell nobody saw
  EXPECT_EQ(at(1.955, 1.005), 0);  // too steep
  EXPECT_EQ(at(0.055, 1.005), 0);  // the foot would reach beyond the map
  // Too rough a floor holds no foot.
  floor.fit.rms = 0.03;
  steppableCells(g, {floor, tread, steep}, foot, s);
  EXPECT_EQ(at(0.305, 1.505), 0);
  EXPECT_EQ(at(1.155, 1.005), 1);
  foot.width = 0.5;
  EXPECT_NE(foot.validate(), "");
}
