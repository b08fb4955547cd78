// Organized clouds (segmentOrganized): the line step, points between grouped lines.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "tilt_laser_perception/core/height_map.hpp"
#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/core/sequence.hpp"
#include "tilt_laser_perception/core/sweep.hpp"

using namespace tilt_laser_perception::core;

namespace {
/// A range image from a sensor 1 m above a floor (z = 0) before a wall at
/// x = 3 m: rows of equal elevation from -10 to -40 degrees, 0.1 degrees
/// apart, columns -20 to +20 degrees of azimuth 0.25 degrees apart; no
/// noise. `surface` per point: 0 floor, 1 wall.
struct FloorWallImage {
  static constexpr int kRows = 300, kCols = 161;
  Eigen::Vector3d origin{0.0, 0.0, 1.0};
  std::vector<Eigen::Vector3f> points;
  std::vector<int> surface;
  FloorWallImage() {
    const double deg = M_PI / 180.0;
    for (int r = 0; r < kRows; ++r)
      for (int c = 0; c < kCols; ++c) {
        const double el = (-10.0 - 0.1 * r) * deg, az = (-20.0 + 0.25 * c) * deg;
        const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
        const double t_floor = -origin.z() / d.z(), t_wall = 3.0 / d.x();
        const bool wall = t_wall < t_floor;
        points.push_back((origin + d * (wall ? t_wall : t_floor)).cast<float>());
        surface.push_back(wall ? 1 : 0);
      }
  }
  std::size_t at(int r, int c) const { return static_cast<std::size_t>(r) * kCols + c; }
};
}  // namespace

namespace {
/// A scan line in 3D (the plane z = 0, seen from the origin, beams 0.25
/// degrees apart from -20 degrees): where each beam meets the line n.x = p
/// (`offset` further beyond beam `step`), with Gaussian range noise `sigma`.
std::vector<Eigen::Vector3f> lineOfTwoFronts(int beams, int step, double offset, double sigma, std::mt19937_64& rng) {
  const double deg = M_PI / 180.0;
  const Eigen::Vector2d n(std::cos(50.0 * deg), std::sin(50.0 * deg));
  const double p = 1.85 * n.x();
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < beams; ++i) {
    const double a = (-20.0 + 0.25 * i) * deg;
    const Eigen::Vector2d u(std::cos(a), std::sin(a));
    const double r = (p + (i >= step ? offset : 0.0)) / u.dot(n) + (sigma > 0.0 ? noise(rng) : 0.0);
    pts.emplace_back(static_cast<float>(r * u.x()), static_cast<float>(r * u.y()), 0.0f);
  }
  return pts;
}
}  // namespace

// The split of a cloud's lines merges its pieces again as the 2D split does
// (test_scan_split.cpp's two tests of the merge): a noisy straight line the
// chord's test cut on noisy points is mostly one segment again, and a line
// that steps onto a surface 4 cm behind the first is two, though one line
// passes within d_T of all of their points.
TEST(PolylineSplit, PiecesAreMergedAgainUnlessTheyStepOntoAnotherSurface) {
  std::mt19937_64 rng(7);
  SplitParams merged, apart;
  apart.merge = false;
  int whole_merged = 0, whole_apart = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const std::vector<Eigen::Vector3f> pts = lineOfTwoFronts(120, 1000, 0.0, 0.015, rng);
    std::vector<Segment3> a, b;
    splitPolyline(pts, Eigen::Vector3d::Zero(), merged, 0, a);
    splitPolyline(pts, Eigen::Vector3d::Zero(), apart, 0, b);
    whole_merged += a.size() == 1u;
    whole_apart += b.size() == 1u;
  }
  // Range noise half again the split's model (d_T / 2): one segment in 162
  // of 200 lines merged, 94 without the merge.
  EXPECT_GE(whole_merged, 150);
  EXPECT_LE(whole_apart, 110);
  const std::vector<Eigen::Vector3f> two = lineOfTwoFronts(24, 16, 0.04, 0.0, rng);
  std::vector<Segment3> segs;
  splitPolyline(two, Eigen::Vector3d::Zero(), merged, 0, segs);
  ASSERT_EQ(segs.size(), 2u);
  EXPECT_EQ(segs[0].last, 15);
  EXPECT_EQ(segs[1].first, 16);
}

// The lines grouped no closer than a spacing: every k-th of an image whose
// rows are 0.1 degrees apart; every line when they are farther apart or the
// spacing is 0.
TEST(OrganizedLines, StepFromTheAngleBetweenLines) {
  const FloorWallImage img;
  const double deg = M_PI / 180.0;
  EXPECT_EQ(organizedLineStep(img.points, img.kCols, img.kRows, true, img.origin, 0.5 * deg), 5);
  EXPECT_EQ(organizedLineStep(img.points, img.kCols, img.kRows, true, img.origin, 1.0 * deg), 10);
  EXPECT_EQ(organizedLineStep(img.points, img.kCols, img.kRows, true, img.origin, 0.05 * deg), 1);
  EXPECT_EQ(organizedLineStep(img.points, img.kCols, img.kRows, true, img.origin, 0.0), 1);
  // Without 100 pairs of returns the angle is not known: every line.
  std::vector<Eigen::Vector3f> none(img.points.size(), Eigen::Vector3f::Constant(std::nanf("")));
  EXPECT_EQ(organizedLineStep(none, img.kCols, img.kRows, true, img.origin, 0.5 * deg), 1);
  // As columns, the lines are 0.25 degrees apart: 0.5 degrees is every second.
  EXPECT_EQ(organizedLineStep(img.points, img.kCols, img.kRows, false, img.origin, 0.5 * deg), 2);
}

// Every 5th row grouped: a point of the rows between joins the plane of its
// column's grouped neighbour that it lies on, the nearer at the crease, and
// nothing when it lies on neither (an object between two grouped rows) or
// has no return.
TEST(OrganizedLines, PointsBetweenGroupedLinesJoinThePlaneTheyLieOn) {
  FloorWallImage img;
  // Rows 101-104 lie between grouped rows 100 and 105: an object 0.2 m in
  // front of the floor over 40 of their columns (10 cm above it at least).
  std::vector<bool> object(img.points.size(), false);
  for (int r = 101; r <= 104; ++r)
    for (int c = 60; c < 100; ++c) {
      const std::size_t i = img.at(r, c);
      const Eigen::Vector3f d = (img.points[i] - img.origin.cast<float>()).normalized();
      img.points[i] -= 0.2f * d;
      object[i] = true;
    }
  // Points without a return between grouped rows (row 52, every other column) join nothing.
  std::vector<bool> no_return(img.points.size(), false);
  for (int c = 0; c < img.kCols; c += 2) {
    img.points[img.at(52, c)] = Eigen::Vector3f::Constant(std::nanf(""));
    no_return[img.at(52, c)] = true;
  }
  std::vector<Plane> planes;
  std::vector<std::uint32_t> labels;
  segmentOrganized(img.points, img.kCols, img.kRows, true, img.origin, SplitParams(), GroupingParams(), planes, labels,
                   5);
  ASSERT_EQ(planes.size(), 2u);
  // Which plane is which surface.
  std::uint32_t label_of[2] = {0, 0};
  for (const Plane& p : planes) label_of[std::abs(p.fit.normal.z()) > 0.9 ? 0 : 1] = static_cast<std::uint32_t>(p.id + 1);
  ASSERT_NE(label_of[0], 0u);
  ASSERT_NE(label_of[1], 0u);
  int between = 0, wrong = 0, on_object = 0, counted = 0;
  for (int r = 0; r < img.kRows; ++r)
    for (int c = 0; c < img.kCols; ++c) {
      const std::size_t i = img.at(r, c);
      counted += labels[i] != 0;
      if (r % 5 == 0 || r == img.kRows - 1) continue;
      if (object[i] || no_return[i]) {
        on_object += labels[i] != 0;
        continue;
      }
      // Within 1 cm of the corner a point is on both planes.
      if (img.points[i].z() < 0.01f && img.points[i].x() > 2.99f) continue;
      ++between;
      wrong += labels[i] != label_of[img.surface[i]];
    }
  EXPECT_GT(between, 35000);
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(on_object, 0);
  // Each plane counts every point labelled with it.
  EXPECT_EQ(planes[0].points + planes[1].points, counted);
  // The same image transposed, its columns the scan lines: the same labels.
  std::vector<Eigen::Vector3f> transposed(img.points.size());
  for (int r = 0; r < img.kRows; ++r)
    for (int c = 0; c < img.kCols; ++c) transposed[static_cast<std::size_t>(c) * img.kRows + r] = img.points[img.at(r, c)];
  std::vector<Plane> planes_t;
  std::vector<std::uint32_t> labels_t;
  segmentOrganized(transposed, img.kRows, img.kCols, false, img.origin, SplitParams(), GroupingParams(), planes_t,
                   labels_t, 5);
  ASSERT_EQ(planes_t.size(), 2u);
  int differ = 0;
  for (int r = 0; r < img.kRows; ++r)
    for (int c = 0; c < img.kCols; ++c) differ += labels_t[static_cast<std::size_t>(c) * img.kRows + r] != labels[img.at(r, c)];
  EXPECT_EQ(differ, 0);
  // With a second thread (it splits while this one groups, and takes half
  // the lines between), rows or columns: the same planes and labels.
  for (const bool rows : {true, false}) {
    const auto& pts = rows ? img.points : transposed;
    const int w = rows ? img.kCols : img.kRows, h = rows ? img.kRows : img.kCols;
    const auto& want_labels = rows ? labels : labels_t;
    const auto& want_planes = rows ? planes : planes_t;
    std::vector<Plane> planes2;
    std::vector<std::uint32_t> labels2;
    segmentOrganized(pts, w, h, rows, img.origin, SplitParams(), GroupingParams(), planes2, labels2, 5, nullptr, 2);
    ASSERT_EQ(planes2.size(), want_planes.size()) << rows;
    EXPECT_TRUE(labels2 == want_labels) << rows;
    for (std::size_t k = 0; k < planes2.size(); ++k) {
      EXPECT_EQ(planes2[k].points, want_planes[k].points) << rows;
      EXPECT_EQ(planes2[k].fit.normal, want_planes[k].fit.normal) << rows;
    }
  }
}

// The noise model's line term from an organized cloud: a floor and a wall
// whose rows (scan lines) are each turned about the sensor by their own
// error, normal with sigma 0.3 degrees: the estimate finds it, and finds
// next to nothing where the rows have no error of their own.
TEST(OrganizedLines, EachLinesOwnPoseErrorIsEstimated) {
  FloorWallImage img;
  const auto estimate = [&](double sigma_deg, double range_noise) {
    std::mt19937 rng(7);
    std::normal_distribution<double> turn(0.0, sigma_deg * M_PI / 180.0), noise(0.0, range_noise);
    std::vector<Eigen::Vector3f> pts = img.points;
    for (int r = 0; r < FloorWallImage::kRows; ++r) {
      const Eigen::AngleAxisd R(turn(rng), Eigen::Vector3d::UnitY());  // about the sensor, out of the row's own cone
      for (int c = 0; c < FloorWallImage::kCols; ++c) {
        Eigen::Vector3d d = pts[img.at(r, c)].cast<double>() - img.origin;
        d *= 1.0 + noise(rng) / d.norm();
        pts[img.at(r, c)] = (img.origin + R * d).cast<float>();
      }
    }
    // The rows 0.1 degrees apart are grouped every 5th (0.5 degrees), as segment_cloud does.
    return estimateLineSigma(pts, FloorWallImage::kCols, FloorWallImage::kRows, true, img.origin, 5) * 180.0 / M_PI;
  };
  EXPECT_NEAR(estimate(0.3, 0.0), 0.3, 0.1);
  EXPECT_NEAR(estimate(0.3, 0.002), 0.3, 0.1);
  EXPECT_LT(estimate(0.0, 0.0), 0.01);
  EXPECT_LT(estimate(0.0, 0.002), 0.05);
}

// A floor whose lines are each off by their own pose error (0.4 degrees,
// 1.4 cm at 2 m): with the noise model's line term the grouping keeps it one
// plane (98.6 %); without it, it breaks into stripes (88.5 %; 89.8 % since the
// segments of strips that fix no normal join the planes beside them).
TEST(Grouping, ALineTermForTheRigsPoseErrorKeepsAFloorOfOffsetLinesWhole) {
  FloorWallImage img;
  std::mt19937 rng(3);
  std::normal_distribution<double> turn(0.0, 0.4 * M_PI / 180.0);
  std::vector<Eigen::Vector3f> pts = img.points;
  for (int r = 0; r < FloorWallImage::kRows; ++r) {
    const Eigen::AngleAxisd R(turn(rng), Eigen::Vector3d::UnitY());
    for (int c = 0; c < FloorWallImage::kCols; ++c)
      pts[img.at(r, c)] = (img.origin + R * (pts[img.at(r, c)].cast<double>() - img.origin)).cast<float>();
  }
  const auto floorShare = [&](double line_sigma_deg) {
    GroupingParams g;
    g.line_sigma = line_sigma_deg * M_PI / 180.0;
    std::vector<Plane> planes;
    std::vector<std::uint32_t> labels;
    segmentOrganized(pts, FloorWallImage::kCols, FloorWallImage::kRows, true, img.origin, SplitParams(), g, planes,
                     labels, 5);
    std::map<std::uint32_t, int> on_floor;
    int floor = 0;
    for (std::size_t i = 0; i < pts.size(); ++i)
      if (img.surface[i] == 0) {
        ++floor;
        if (labels[i]) ++on_floor[labels[i]];
      }
    int best = 0;
    for (const auto& [l, n] : on_floor) best = std::max(best, n);
    return static_cast<double>(best) / floor;
  };
  const double without = floorShare(0.0), with = floorShare(0.4);
  std::printf("the floor's largest plane: %.1f %% without the line term, %.1f %% with it\n", 100 * without, 100 * with);
  EXPECT_GT(with, 0.95);
  EXPECT_LT(without, with - 0.05);
}
