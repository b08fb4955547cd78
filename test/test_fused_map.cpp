// The fused, robot-centric height map: the moving grid, the fusion of a cell
// seen twice, the newest sweep winning, forgetting, persistent plane ids.
#include <gtest/gtest.h>

#include <cmath>

#include "tilt_laser_perception/core/fused_map.hpp"

using namespace tilt_laser_perception::core;

namespace {

Plane rectangle(int id, double x0, double y0, double x1, double y1, double z) {
  Plane p;
  p.id = id;
  p.fit.normal = Eigen::Vector3d::UnitZ();
  p.fit.offset = z;
  p.fit.centroid = Eigen::Vector3d(0.5 * (x0 + x1), 0.5 * (y0 + y1), z);
  p.area = (x1 - x0) * (y1 - y0);
  p.boundary = {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
  return p;
}

HeightMapParams cells() {
  HeightMapParams p;
  p.resolution = 0.02;
  return p;
}

FusedMapParams fusedParams() {
  FusedMapParams f;
  f.size = 4.0;
  f.forget_time = 10.0;
  f.sigma_pose = 0.0;  // the head pose's term apart (its own test)
  return f;
}

/// The map's cell at (x, y) in its frame.
std::size_t cellAt(const HeightMapGrid& g, double x, double y) {
  return g.index(static_cast<int>(std::floor((x - g.params.origin_x) / g.params.resolution)),
                 static_cast<int>(std::floor((y - g.params.origin_y) / g.params.resolution)));
}

}  // namespace

TEST(FusedHeightMap, AShiftKeepsEveryCellsPlaceInTheFrame) {
  FusedHeightMap m(cells(), fusedParams());
  m.recentre(0.0, 0.0);
  SweepResult s;
  s.planes = {rectangle(0, -1.0, -1.0, 1.5, 1.0, 0.0), rectangle(1, 0.5, -0.3, 1.1, 0.3, 0.15)};
  SweepLine pole;  // an obstacle: a pole's points at (-0.49, 0.71) up to 0.6 m
  for (int i = 1; i <= 6; ++i) pole.points.emplace_back(-0.49f, 0.71f, 0.1f * i);
  s.lines.push_back(pole);
  m.addSweep(s, Eigen::Vector3d(0, 0, 1.4), 1.0, 0.0);
  const HeightMapGrid before = m.grid();
  ASSERT_EQ(before.params.width, 200);
  EXPECT_DOUBLE_EQ(before.params.origin_x, -2.0);

  m.recentre(0.375, -0.205);  // the robot walked 37.5 cm forward and 20.5 cm to the right
  const HeightMapGrid& after = m.grid();
  EXPECT_NEAR(after.params.origin_x, -2.0 + 0.38, 1e-9);  // on the cell lattice: 19 cells
  EXPECT_NEAR(after.params.origin_y, -2.0 - 0.20, 1e-9);  // 10 cells
  int compared = 0, unknown_new = 0;
  for (int iy = 0; iy < after.params.height; ++iy)
    for (int ix = 0; ix < after.params.width; ++ix) {
      const double x = after.params.origin_x + (ix + 0.5) * 0.02, y = after.params.origin_y + (iy + 0.5) * 0.02;
      const float h = after.heights[after.index(ix, iy)];
      const bool was_in = x > before.params.origin_x && x < before.params.origin_x + 4.0 &&
                          y > before.params.origin_y && y < before.params.origin_y + 4.0;
      if (!was_in) {
        unknown_new += std::isnan(h);
        EXPECT_TRUE(std::isnan(h));
        continue;
      }
      const std::size_t c0 = cellAt(before, x, y);
      if (std::isnan(before.heights[c0])) {
        EXPECT_TRUE(std::isnan(h));
        continue;
      }
      EXPECT_FLOAT_EQ(h, before.heights[c0]);
      EXPECT_EQ(after.classes[after.index(ix, iy)], before.classes[c0]);
      EXPECT_EQ(after.plane_ids[after.index(ix, iy)], before.plane_ids[c0]);
      ++compared;
    }
  EXPECT_GT(compared, 12000);  // the floor's 2.5 m x 2 m
  EXPECT_EQ(unknown_new, 19 * 200 + 10 * 200 - 19 * 10);
  EXPECT_EQ(after.classes[cellAt(after, -0.49, 0.71)], CellClass::Obstacle);
  EXPECT_NEAR(after.heights[cellAt(after, -0.49, 0.71)], 0.6, 1e-6);
  EXPECT_NEAR(after.heights[cellAt(after, 0.8, 0.0)], 0.15, 1e-6);

  m.recentre(10.0, 0.0);  // farther than the grid: nothing is left
  int known = 0;
  for (float h : m.grid().heights) known += !std::isnan(h);
  EXPECT_EQ(known, 0);
}

TEST(FusedHeightMap, ACellSeenTwiceIsTheMeanByItsVariances) {
  FusedMapParams f = fusedParams();
  f.drift_per_metre = 0.0;
  FusedHeightMap m(cells(), f);
  m.recentre(0.0, 0.0);
  SweepResult a, b;
  a.planes = {rectangle(0, 0.5, -0.5, 1.5, 0.5, 0.000)};
  b.planes = {rectangle(0, 0.5, -0.5, 1.5, 0.5, 0.010)};
  // Seen first from 1 m above the cell at (1.01, 0.01), then from 3 m away.
  const Eigen::Vector3d near(1.01, 0.01, 1.0), far(1.01, 3.01, 0.0);
  m.addSweep(a, near, 1.0, 0.0);
  m.addSweep(b, far, 2.0, 0.0);
  const std::size_t c = cellAt(m.grid(), 1.01, 0.01);
  const double s1 = std::hypot(f.sigma_min, f.sigma_range * 1.0), s2 = std::hypot(f.sigma_min, f.sigma_range * std::hypot(3.0, 0.01));
  const double v1 = s1 * s1, v2 = s2 * s2;
  EXPECT_NEAR(m.grid().heights[c], (0.000 * v2 + 0.010 * v1) / (v1 + v2), 1e-5);  // 3.1 mm: nearer the close look
  EXPECT_NEAR(m.sigma(c, 0.0), std::sqrt(v1 * v2 / (v1 + v2)), 1e-5);
  EXPECT_DOUBLE_EQ(m.lastSeen(c), 2.0);
  // The plane kept its id: the second sweep's cells agreed with the first's.
  EXPECT_EQ(m.grid().plane_ids[c], 0);
  EXPECT_EQ(m.planes().size(), 1u);
  EXPECT_NEAR(m.planes().at(0).plane.fit.offset, 0.010, 1e-12);  // the newest sweep's plane
}

// The head's pose error is the same in every sweep: fusing sweeps shrinks
// the range noise's share of a cell's sigma, not the pose's (d x sigma_pose
// at the horizontal distance d the cell was seen from).
TEST(FusedHeightMap, TheHeadPosesShareOfASigmaDoesNotShrinkWithSweeps) {
  FusedMapParams f = fusedParams();
  f.drift_per_metre = 0.0;
  f.sigma_pose = 0.5 * M_PI / 180.0;
  FusedHeightMap m(cells(), f);
  m.recentre(0.0, 0.0);
  SweepResult a;
  a.planes = {rectangle(0, 1.0, -0.5, 1.9, 0.5, 0.0)};
  const Eigen::Vector3d eye(0.01, 0.01, 1.4);
  const std::size_t c = cellAt(m.grid(), 1.51, 0.01);
  const double d = 1.5, s1 = std::hypot(f.sigma_min, f.sigma_range * std::hypot(d, 1.4)), bias = d * f.sigma_pose;
  m.addSweep(a, eye, 1.0, 0.0);
  EXPECT_NEAR(m.sigma(c, 0.0), std::hypot(s1, bias), 2e-4);  // 13.1 mm of pose, 7.8 of range noise
  for (int k = 2; k <= 10; ++k) m.addSweep(a, eye, k, 0.0);
  // Ten looks: the range noise's share down to a third (the floor at half sigma_min), the pose's whole.
  EXPECT_NEAR(m.sigma(c, 0.0), std::hypot(std::max(s1 / std::sqrt(10.0), 0.5 * f.sigma_min), bias), 2e-4);
  EXPECT_GT(m.sigma(c, 0.0), bias);
  f.sigma_pose = 0.3;
  EXPECT_NE(f.validate().find("sigma_pose"), std::string::npos);
}

TEST(FusedHeightMap, TheSweepsUncertaintyLayerIsTheNoiseModelsSigmaOnKnownCellsAndNaNElsewhere) {
  // Every known cell: sqrt(variance + bias^2) of SweepNoise at its height;
  // every unknown cell NaN, also when the buffer held a larger map's layer.
  FusedMapParams f = fusedParams();
  f.sigma_pose = 0.5 * M_PI / 180.0;
  const Eigen::Vector3d eye(0.2, -0.1, 1.4);
  SweepResult wide, narrow;
  wide.planes = {rectangle(0, 0.5, -1.5, 3.5, 1.5, 0.0)};
  narrow.planes = {rectangle(0, 1.0, -0.3, 1.6, 0.2, 0.1), rectangle(1, 2.0, 0.4, 2.3, 0.6, 0.25)};
  HeightMapGrid g;
  std::vector<float> sigmas;
  buildHeightMap(wide, cells(), g);
  sweepUncertainty(g, eye, f, sigmas);
  buildHeightMap(narrow, cells(), g);
  sweepUncertainty(g, eye, f, sigmas);
  ASSERT_EQ(sigmas.size(), g.heights.size());
  const SweepNoise noise(f, g.params, eye);
  int known = 0, unknown = 0;
  for (int iy = 0; iy < g.params.height; ++iy)
    for (int ix = 0; ix < g.params.width; ++ix) {
      const std::size_t c = g.index(ix, iy);
      if (std::isnan(g.heights[c])) {
        ++unknown;
        EXPECT_TRUE(std::isnan(sigmas[c])) << ix << "," << iy;
        continue;
      }
      ++known;
      const float b = noise.bias(ix, iy);
      EXPECT_NEAR(sigmas[c], std::sqrt(noise.variance(ix, iy, g.heights[c]) + b * b), 1e-6) << ix << "," << iy;
    }
  // The two rectangles: 30 x 25 and 15 x 10 cells of 2 cm (within a cell at their sides).
  EXPECT_NEAR(known, 30 * 25 + 15 * 10, 60);
  EXPECT_GT(unknown, 0);
}

TEST(FusedHeightMap, TheNewestSweepWinsWhereTheyDisagree) {
  FusedHeightMap m(cells(), fusedParams());
  m.recentre(0.0, 0.0);
  SweepResult a, b;
  a.planes = {rectangle(0, 0.5, -0.5, 1.5, 0.5, 0.0)};
  b.planes = {rectangle(0, 0.5, -0.5, 1.5, 0.5, 0.12)};  // something was put there: 12 cm, many sigmas off
  m.addSweep(a, Eigen::Vector3d(0, 0, 1.4), 1.0, 0.0);
  m.addSweep(b, Eigen::Vector3d(0, 0, 1.4), 2.0, 0.0);
  const std::size_t c = cellAt(m.grid(), 1.0, 0.0);
  EXPECT_NEAR(m.grid().heights[c], 0.12, 1e-6);
  const double s = std::hypot(fusedParams().sigma_min, fusedParams().sigma_range * std::hypot(1.01, 0.01, 1.28));
  EXPECT_NEAR(m.sigma(c, 0.0), s, 1e-6);  // its own uncertainty, not a fused one
  EXPECT_NE(m.grid().plane_ids[c], 0);   // not the old plane: a new id
  EXPECT_EQ(m.planes().size(), 2u);      // the old one is kept until forgotten
}

TEST(FusedHeightMap, PointsUnderAKnownSurfaceTakeItBackAndSegmentsBesideTheMapAreSkipped) {
  FusedHeightMap m(cells(), fusedParams());  // 4 m: x and y in [-2, 2)
  m.recentre(0.0, 0.0);
  SweepResult a;
  a.planes = {rectangle(0, 0.5, -0.5, 1.5, 0.5, 0.0)};
  m.addSweep(a, Eigen::Vector3d(0, 0, 1.4), 1.0, 0.0);
  ASSERT_NEAR(m.grid().heights[cellAt(m.grid(), 1.02, 0.0)], 0.0, 1e-6);
  // The next sweep sees the floor elsewhere, and a line whose first five
  // points lie 30 cm under the old floor (its rays went through it), and
  // five 1.5 m beyond the map.
  SweepResult b;
  b.planes = {rectangle(0, -1.5, -1.5, -0.5, -0.5, 0.0)};
  SweepLine line;
  for (int i = 0; i < 5; ++i) line.points.emplace_back(1.0f + 0.01f * i, 0.0f, -0.3f);
  for (int i = 0; i < 5; ++i) line.points.emplace_back(3.5f + 0.01f * i, 0.0f, 0.0f);
  b.lines.push_back(line);
  const auto segment = [](int first, int last, const Eigen::Vector3d& start, const Eigen::Vector3d& end) {
    Segment3 s;
    s.first = first;
    s.last = last;
    s.start = start;
    s.end = end;
    return s;
  };
  b.segments = {segment(0, 4, {1.0, 0, -0.3}, {1.04, 0, -0.3}), segment(5, 9, {3.5, 0, 0}, {3.54, 0, 0})};
  b.segment_plane = {-1, -1};
  m.addSweep(b, Eigen::Vector3d(0, 0, 1.4), 2.0, 0.0);
  EXPECT_TRUE(std::isnan(m.grid().heights[cellAt(m.grid(), 1.02, 0.0)]));  // taken back
  EXPECT_NEAR(m.grid().heights[cellAt(m.grid(), 1.2, 0.0)], 0.0, 1e-6);     // no point there: kept
  const HeightMapParams& g = m.grid().params;
  EXPECT_FALSE(besideMap(b.segments[0], g));
  EXPECT_TRUE(besideMap(b.segments[1], g));
  EXPECT_TRUE(besideMap(segment(0, 9, {-1.5, -2.5, 0}, {1.5, -2.2, 0}), g));  // beyond y's low side
  EXPECT_FALSE(besideMap(segment(0, 9, {-1.5, -2.05, 0}, {1.5, -2.2, 0}), g));  // within its margin
  EXPECT_FALSE(besideMap(segment(0, 9, {-3.0, 1.5, 0}, {1.5, -3.0, 0}), g));   // crosses it corner to corner
}

TEST(FusedHeightMap, UncertaintyGrowsWithTheDistanceWalkedAndOldCellsAreForgotten) {
  FusedMapParams f = fusedParams();
  FusedHeightMap m(cells(), f);
  m.recentre(0.0, 0.0);
  SweepResult a, b;
  a.planes = {rectangle(0, 0.5, -0.5, 1.0, 0.5, 0.0)};   // a tread seen once, then out of view
  b.planes = {rectangle(0, 1.2, -0.5, 1.8, 0.5, 0.0)};
  m.addSweep(a, Eigen::Vector3d(0, 0, 1.4), 1.0, 0.0);
  const std::size_t c = cellAt(m.grid(), 0.7, 0.0);
  const double s0 = m.sigma(c, 0.0);
  EXPECT_NEAR(m.sigma(c, 2.0), std::hypot(s0, 2.0 * f.drift_per_metre), 1e-6);  // 2 m walked since
  m.addSweep(b, Eigen::Vector3d(0, 0, 1.4), 6.0, 1.0);
  EXPECT_FALSE(std::isnan(m.grid().heights[c]));  // 5 s old: kept
  std::vector<float> sigmas, ages;
  m.uncertainty(7.0, 1.5, sigmas, ages);  // what the message says at 7 s, 1.5 m walked
  EXPECT_NEAR(ages[c], 6.0, 1e-5);
  EXPECT_NEAR(sigmas[c], m.sigma(c, 1.5), 1e-6);
  EXPECT_NEAR(sigmas[c], std::hypot(s0, 1.5 * f.drift_per_metre), 1e-6);
  const std::size_t d = cellAt(m.grid(), 1.5, 0.0);
  EXPECT_NEAR(ages[d], 1.0, 1e-5);
  EXPECT_TRUE(std::isnan(ages[cellAt(m.grid(), -1.5, 0.0)]));  // never seen
  EXPECT_EQ(m.planes().size(), 2u);                // and its plane, for a planner, out of the laser's view
  m.addSweep(b, Eigen::Vector3d(0, 0, 1.4), 11.5, 1.0);
  EXPECT_TRUE(std::isnan(m.grid().heights[c]));  // 10.5 s old: forgotten
  EXPECT_EQ(m.grid().classes[c], CellClass::Unknown);
  EXPECT_EQ(m.planes().size(), 1u);
  EXPECT_FALSE(std::isnan(m.grid().heights[cellAt(m.grid(), 1.5, 0.0)]));
}

TEST(FusedHeightMap, ParametersAreValidatedWithTheirNames) {
  FusedMapParams f;
  EXPECT_EQ(f.validate(), "");
  f.size = 0.0;
  EXPECT_NE(f.validate().find("size"), std::string::npos);
  f = FusedMapParams();
  f.gate = -1.0;
  EXPECT_NE(f.validate().find("gate"), std::string::npos);
}

// The odometry bookkeeping the grouper leaves to core: the distance walked
// between sweeps, the grid kept on the robot (or where it was when the robot's
// place is not known), and a clock that goes back starting the map again.
TEST(FusedMapTracker, CountsTheWalkFollowsTheRobotAndStartsAgainWhenTheClockGoesBack) {
  FusedMapTracker t(cells(), fusedParams());
  SweepResult a, b;
  a.planes = {rectangle(0, 0.5, -0.5, 1.0, 0.5, 0.0)};
  b.planes = {rectangle(0, 1.2, -0.5, 1.8, 0.5, 0.1)};
  a.end = 1.0;
  const Eigen::Vector2d at0(0.0, 0.0), at1(0.3, 0.4);
  t.addSweep(a, &at0);
  EXPECT_DOUBLE_EQ(t.travelled(), 0.0);
  EXPECT_NEAR(t.map().grid().params.origin_x, -2.0, 1e-9);  // 4 m around the robot
  const std::size_t c = cellAt(t.map().grid(), 0.7, 0.0);
  EXPECT_NEAR(t.map().grid().heights[c], 0.0, 1e-6);
  b.end = 2.0;
  t.addSweep(b, &at1);
  EXPECT_NEAR(t.travelled(), 0.5, 1e-12);
  EXPECT_NEAR(t.map().grid().params.origin_x, 0.3 - 2.0, 1e-9);
  EXPECT_NEAR(t.map().grid().params.origin_y, 0.4 - 2.0, 1e-9);
  EXPECT_NEAR(t.map().grid().heights[cellAt(t.map().grid(), 0.7, 0.0)], 0.0, 1e-6);  // kept in the frame
  b.end = 3.0;
  t.addSweep(b, nullptr);  // the robot's place not known: the map stays, the walk is not counted
  EXPECT_NEAR(t.travelled(), 0.5, 1e-12);
  EXPECT_NEAR(t.map().grid().params.origin_x, 0.3 - 2.0, 1e-9);
  b.end = 0.5;  // a recording played again
  t.addSweep(b, &at0);
  EXPECT_DOUBLE_EQ(t.travelled(), 0.0);
  EXPECT_TRUE(std::isnan(t.map().grid().heights[cellAt(t.map().grid(), 0.7, 0.0)])) << "the old map was kept";
  EXPECT_NEAR(t.map().grid().heights[cellAt(t.map().grid(), 1.5, 0.0)], 0.1, 1e-6);
}
