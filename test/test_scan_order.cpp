// A spinning lidar's flat cloud in scan order back into its lines
// (core/scan_order.hpp): lines of unequal lengths, points missing, a line
// cut at the start; the rows and columns must be the lines and beams.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <functional>
#include <random>
#include <set>
#include <tuple>

#include "tilt_laser_perception/core/scan_order.hpp"

using namespace tilt_laser_perception::core;

namespace {

constexpr double kDeg = M_PI / 180.0;

struct Truth {
  std::vector<Eigen::Vector3f> points;
  std::vector<std::pair<int, int>> line_beam;  // of each point
};

/// A MultiSense-like head at 1.8 m, its spin axis forward and down, its scan
/// plane containing the axis: `lines` lines 0.47 degrees of spin apart, beams
/// -135..135 degrees 0.25 apart, on the ground z = 0 and a box, cropped to 4 m.
/// `keep` decides whether a point is kept (points with no return left out).
Truth spinningScan(const Eigen::Vector3d& o, const Eigen::Vector3d& axis, int lines, double spin0,
                   const std::function<bool(int line, int beam)>& keep, double wall_x = 0.0, double noise = 0.0) {
  std::mt19937 rng(7);
  std::normal_distribution<double> range_noise(0.0, noise);
  Truth t;
  const Eigen::Vector3d a = axis.normalized(), e1 = a.unitOrthogonal(), e2 = a.cross(e1);
  for (int k = 0; k < lines; ++k) {
    const double phi = spin0 + k * 0.47 * kDeg;
    const Eigen::Vector3d u = std::cos(phi) * e1 + std::sin(phi) * e2;
    for (int j = 0; j <= 1080; ++j) {
      if (j == 540) continue;  // along the axis: the same point on every line (checked apart)
      const double b = (-135.0 + 0.25 * j) * kDeg;
      const Eigen::Vector3d d = std::cos(b) * a + std::sin(b) * u;
      if (d.z() >= -1e-3) continue;
      double s = -o.z() / d.z();
      Eigen::Vector3d p = o + s * d;
      // a box 0.3 m high over x 1.0-1.4
      if (d.z() < 0.0) {
        const double s_top = (0.3 - o.z()) / d.z();
        const Eigen::Vector3d q = o + s_top * d;
        if (q.x() >= 1.0 && q.x() <= 1.4 && std::abs(q.y()) < 0.3) p = q;
      }
      // a wall x = wall_x (when given), where it is nearer than the rest
      if (wall_x > 0.0 && d.x() > 1e-6 && (wall_x - o.x()) / d.x() < (p - o).norm()) p = o + (wall_x - o.x()) / d.x() * d;
      if (noise > 0.0) p += range_noise(rng) * d;
      if ((p - o).norm() > 4.0 || !keep(k, j)) continue;
      t.points.push_back(p.cast<float>());
      t.line_beam.emplace_back(k, j);
    }
  }
  return t;
}

/// Checks that every point went to the row of its line (the lines with
/// points numbered in order) and the column of its beam (a constant offset).
void expectLinesAndBeams(const Truth& t, const ScanLines& s) {
  std::set<int> lines;
  for (const auto& lb : t.line_beam) lines.insert(lb.first);
  ASSERT_EQ(s.height, static_cast<int>(lines.size()));
  EXPECT_NEAR(s.beam_step / kDeg, 0.25, 1e-3);
  EXPECT_EQ(s.collided, 0);
  std::map<std::tuple<float, float, float>, std::pair<int, int>> cell;
  for (int r = 0; r < s.height; ++r)
    for (int c = 0; c < s.width; ++c) {
      const Eigen::Vector3f& p = s.points[static_cast<std::size_t>(r) * s.width + c];
      if (p.allFinite()) cell[{p.x(), p.y(), p.z()}] = {r, c};
    }
  ASSERT_EQ(cell.size(), t.points.size());
  std::map<int, int> row_of_line;
  int beam_offset = 1 << 30;
  for (std::size_t i = 0; i < t.points.size(); ++i) {
    const auto [r, c] = cell.at({t.points[i].x(), t.points[i].y(), t.points[i].z()});
    const auto [line, beam] = t.line_beam[i];
    if (!row_of_line.count(line)) row_of_line[line] = r;
    EXPECT_EQ(row_of_line[line], r) << "line " << line;
    if (beam_offset == (1 << 30)) beam_offset = c - beam;
    EXPECT_EQ(c - beam, beam_offset) << "line " << line << " beam " << beam;
  }
  int expect_row = 0;
  for (const auto& [line, row] : row_of_line) EXPECT_EQ(row, expect_row++) << "line " << line;
}

const Eigen::Vector3d kOrigin(0.25, 0.01, 1.8);
const Eigen::Vector3d kAxis(0.837, 0.0198, -0.5468);

}  // namespace

TEST(ScanOrder, LinesOfUnequalLengthsBecomeRows) {
  // Cropped to 4 m, the lines hold from a few to hundreds of points.
  const Truth t = spinningScan(kOrigin, kAxis, 120, 0.0, [](int, int) { return true; });
  const ScanLines s = rebuildScanLines(t.points, kOrigin, kAxis);
  expectLinesAndBeams(t, s);
}

TEST(ScanOrder, MissingPointsKeepTheirBeams) {
  // A fifth of the returns missing at random, and whole runs of beams.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::map<std::pair<int, int>, bool> keep;
  const Truth t = spinningScan(kOrigin, kAxis, 120, 0.3, [&](int line, int beam) {
    return u(rng) > 0.2 && !(beam % 100 < 12 && line % 3 == 0);
  });
  const ScanLines s = rebuildScanLines(t.points, kOrigin, kAxis);
  expectLinesAndBeams(t, s);
}

TEST(ScanOrder, ALineCutAtTheStartIsALineOfItsOwn) {
  // The recording starts in the middle of a line: its second half is the first row.
  const Truth t = spinningScan(kOrigin, kAxis, 60, 1.0, [](int line, int beam) { return line > 0 || beam > 560; });
  ASSERT_EQ(t.line_beam.front().first, 0);
  const ScanLines s = rebuildScanLines(t.points, kOrigin, kAxis);
  expectLinesAndBeams(t, s);
}

TEST(ScanOrder, BadInputGivesNothingOrSkipsThePoint) {
  EXPECT_EQ(rebuildScanLines({}, kOrigin, kAxis).width, 0);
  const Truth t = spinningScan(kOrigin, kAxis, 10, 0.0, [](int, int) { return true; });
  EXPECT_EQ(rebuildScanLines(t.points, kOrigin, Eigen::Vector3d::Zero()).width, 0);  // no axis
  std::vector<Eigen::Vector3f> with_nan = t.points;
  with_nan.insert(with_nan.begin() + 50, Eigen::Vector3f::Constant(std::nanf("")));
  // A point on the spin axis itself is on neither side: kept, between its neighbours.
  std::size_t at = 1;
  while (at < t.points.size() && !(t.line_beam[at - 1].second < 540 && t.line_beam[at].second > 540)) ++at;
  ASSERT_LT(at, t.points.size());
  with_nan.insert(with_nan.begin() + static_cast<std::ptrdiff_t>(at + (at > 50 ? 1 : 0)),
                  (kOrigin + 2.0 * kAxis.normalized()).cast<float>());
  const ScanLines s = rebuildScanLines(with_nan, kOrigin, kAxis);
  EXPECT_EQ(s.height, 10);
  EXPECT_EQ(s.dropped, 1);
  int kept = 0;
  for (const Eigen::Vector3f& p : s.points) kept += p.allFinite();
  EXPECT_EQ(kept, static_cast<int>(t.points.size()) + 1);
}

TEST(ScanOrder, SpinGeometryFromTheLinesAlone) {
  // Ground and a wall 3 m ahead (lines over them bend at the wall's foot),
  // 5 mm of range noise: the axis within 0.05 degrees, the laser within 2 cm
  // of its place, the beams' step 0.25 degrees; the lines rebuilt from the
  // estimates are the lines. The sign of the axis: towards the points.
  const Truth t = spinningScan(kOrigin, kAxis, 200, 0.2, [](int, int) { return true; }, 3.0, 0.005);
  const SpinGeometry g = estimateSpinGeometry(t.points);
  ASSERT_TRUE(g.ok) << g.why;
  EXPECT_LT(std::acos(std::min(1.0, g.axis.dot(kAxis.normalized()))) / kDeg, 0.05);
  EXPECT_LT((g.origin - kOrigin).norm(), 0.02) << g.origin.transpose() << " step " << g.beam_step / kDeg << " n " << g.stretches << " rms " << g.plane_rms << " spread " << g.step_spread;
  EXPECT_NEAR(g.beam_step / kDeg, 0.25, 0.002);
  EXPECT_GT(g.stretches, 100);
  EXPECT_LT(g.plane_rms, 0.005);
  const ScanLines s = rebuildScanLines(t.points, g.origin, g.axis);
  expectLinesAndBeams(t, s);
  // Given the axis, the same origin; given the origin, the same axis.
  EXPECT_LT((estimateSpinGeometry(t.points, Eigen::Vector3d::Constant(std::nan("")), -kAxis).origin - kOrigin).norm(),
            0.02);
  EXPECT_LT(std::acos(std::min(1.0, estimateSpinGeometry(t.points, kOrigin).axis.dot(kAxis.normalized()))) / kDeg,
            0.05);
}

TEST(ScanOrder, SpinGeometryNeedsLinesThatBend) {
  // Lines over flat ground alone are straight: any plane through each holds
  // it, and no axis follows. Too few points, the same.
  const Truth flat = spinningScan(kOrigin, kAxis, 100, 0.0, [](int, int) { return true; });
  std::vector<Eigen::Vector3f> ground;
  for (const Eigen::Vector3f& p : flat.points)
    if (std::abs(p.z()) < 1e-4) ground.push_back(p);
  const SpinGeometry g = estimateSpinGeometry(ground);
  EXPECT_FALSE(g.ok);
  EXPECT_NE(g.why.find("flat ground"), std::string::npos) << g.why;
  EXPECT_EQ(g.stretches, 0);
  const SpinGeometry few = estimateSpinGeometry(std::vector<Eigen::Vector3f>(ground.begin(), ground.begin() + 10));
  EXPECT_FALSE(few.ok);
  EXPECT_EQ(few.why, "too few points");
}
