// The noise model's tests (core/noise_model.hpp): the chi-square limits, and
// that lines drawn from the model pass its tests at the rate its significance
// says while planes a few degrees apart, or a line a few of its sigmas off,
// do not.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tilt_laser_perception/core/noise_model.hpp"

using namespace tilt_laser_perception::core;

namespace {

/// A scan line's straight run of `n` points across y in [y0, y1] at x on the
/// plane z = x tan(slope), seen from (0, 0, h) by a head nodding about the y
/// axis: each point moved along its ray by range noise, the whole line turned
/// about the axis by its pose error dtheta.
Moments3 line(std::mt19937& rng, const NoiseModel& m, double x, double y0, double y1, double slope, double h,
              int n = 60, double extra_offset = 0.0) {
  std::normal_distribution<double> g(0.0, 1.0);
  const double dtheta = m.line_sigma * g(rng);
  const Eigen::Vector3d o(0.0, 0.0, h);
  Moments3 mo;
  for (int i = 0; i < n; ++i) {
    const double y = y0 + (y1 - y0) * i / (n - 1);
    Eigen::Vector3d p(x, y, x * std::tan(slope));
    const double r = (p - o).norm();
    const Eigen::Vector3d q = p - o;
    p += dtheta * Eigen::Vector3d(q.z(), 0.0, -q.x()) + Eigen::Vector3d(0.0, 0.0, extra_offset);
    p += (p - o).normalized() * m.rangeSigma(r) * g(rng);
    mo.add(p);
  }
  return mo;
}

double rangeOf(const Moments3& mo, double h) { return (mo.mean() - Eigen::Vector3d(0, 0, h)).norm(); }

/// The evidence of `lines` lines from x0, dx apart, on the plane of `slope`.
PlaneEvidence strip(std::mt19937& rng, const NoiseModel& m, int lines, double x0, double dx, double slope) {
  PlaneEvidence e;
  for (int k = 0; k < lines; ++k) {
    const Moments3 mo = line(rng, m, x0 + k * dx, -1.0, 1.0, slope, 1.5);
    e += PlaneEvidence::ofSegment(mo, rangeOf(mo, 1.5), m);
  }
  return e;
}

}  // namespace

TEST(NoiseModel, FamilySigmasAreTheNormalsTailOverTheTests) {
  // Any of n values of a normal beyond z sigmas: n erfc(z / sqrt 2) = the
  // significance level's tail (0.27 % at 3 sigmas).
  NoiseModel m;
  EXPECT_NEAR(m.familySigmas(1), 3.0, 1e-3);
  for (const std::size_t n : {10u, 1000u, 100000u}) {
    const double z = m.familySigmas(n);
    EXPECT_NEAR(n * std::erfc(z / std::sqrt(2.0)), std::erfc(3.0 / std::sqrt(2.0)), 1e-6) << n;
  }
  EXPECT_NEAR(m.familySigmas(1000), 4.69, 0.01);
  EXPECT_GT(m.familySigmas(100000), m.familySigmas(1000));
}

TEST(NoiseModel, Chi2LimitsAreTheNormalsTail) {
  NoiseModel m;  // 3 sigmas: a tail of 0.27 %
  EXPECT_NEAR(m.chi2Limit(1), 9.0, 1e-3);
  EXPECT_NEAR(m.chi2Limit(2), -2.0 * std::log(std::erfc(3.0 / std::sqrt(2.0))), 1e-3);  // 11.83
  EXPECT_NEAR(m.chi2Limit(3), 14.16, 0.01);
  m.significance = 2.0;
  EXPECT_NEAR(m.chi2Limit(1), 4.0, 1e-3);
  EXPECT_NEAR(chi2Quantile(3, 0.05), 7.815, 0.002);
}

TEST(NoiseModel, ValidateRejectsNonsense) {
  NoiseModel m;
  EXPECT_EQ(m.validate(), "");
  m.range_sigma = 0.0;
  EXPECT_NE(m.validate(), "");
  m = NoiseModel();
  m.line_sigma = -1.0;
  EXPECT_NE(m.validate(), "");
  m = NoiseModel();
  m.significance = std::nan("");
  EXPECT_NE(m.validate(), "");
}

TEST(NoiseModel, ASegmentsEvidenceWeighsItsCentroidByBothTerms) {
  NoiseModel m;
  m.line_sigma = 0.005;
  Moments3 mo;
  for (int i = 0; i < 100; ++i) mo.add(Eigen::Vector3d(4.0, -1.0 + 0.02 * i, 0.0));
  const PlaneEvidence e = PlaneEvidence::ofSegment(mo, 4.0, m);
  EXPECT_NEAR(1.0 / e.w, 0.01 * 0.01 / 100 + std::pow(4.0 * 0.005, 2), 1e-12);
  EXPECT_NEAR(e.chi2(Eigen::Vector3d::UnitZ(), 0.0), 0.0, 1e-9);          // the plane it lies on
  EXPECT_NEAR(e.chi2(Eigen::Vector3d::UnitZ(), 0.02), 0.02 * 0.02 * e.w, 1e-9);  // R sigma_theta = 2 cm off
  EXPECT_GT(0.02 * 0.02 * e.w, 0.99);                                     // about one sigma: the line's term rules
  EXPECT_NEAR(e.chi2(), 0.0, 1e-6);                                       // one line fixes no plane
  EXPECT_EQ(PlaneEvidence::ofSegment(Moments3(), 4.0, m).w, 0.0);
}

TEST(NoiseModel, LinesOfOnePlaneMergeAtTheSignificanceLevel) {
  // Two strips of five lines each, from the model: one plane. The union's
  // chi-square rises by a chi-square of 3 degrees of freedom, over the limit
  // about 0.27 % of the time.
  NoiseModel m;
  m.line_sigma = 0.33 * M_PI / 180.0;  // the nodding SICK scan's
  std::mt19937 rng(5);
  int split = 0;
  const int trials = 2000;
  for (int t = 0; t < trials; ++t) {
    const PlaneEvidence a = strip(rng, m, 5, 2.0, 0.03, 0.0), b = strip(rng, m, 5, 2.15, 0.03, 0.0);
    const double d = chi2Increase(a, b);
    EXPECT_NEAR(d, chi2Increase(b, a), 1e-6 * (1.0 + d));
    split += d > m.chi2Limit(3);
  }
  EXPECT_LT(split, trials * 0.01) << split << " of " << trials;
}

TEST(NoiseModel, PlanesAFewDegreesApartStayApart) {
  // A ramp of 5.7 degrees meeting a floor, 60 cm of each, with the
  // simulated head's line error (0.1 degrees): never one plane.
  NoiseModel m;
  m.line_sigma = 0.1 * M_PI / 180.0;
  std::mt19937 rng(6);
  for (int t = 0; t < 200; ++t) {
    const PlaneEvidence floor = strip(rng, m, 15, 0.7, 0.04, 0.0);
    PlaneEvidence ramp;
    for (int k = 0; k < 15; ++k) {
      Moments3 mo = line(rng, m, 1.3 + 0.04 * k, -1.0, 1.0, 0.0, 1.5);
      // the ramp rises from x = 1.32 at 5.7 degrees
      Moments3 lifted;
      lifted.n = mo.n;
      lifted.s = mo.s + Eigen::Vector3d(0, 0, mo.n * 0.04 * k * std::tan(5.7 * M_PI / 180.0));
      const Eigen::Vector3d dz(0, 0, 0.04 * k * std::tan(5.7 * M_PI / 180.0));
      lifted.ss = mo.ss + mo.s * dz.transpose() + dz * mo.s.transpose() + mo.n * dz * dz.transpose();
      ramp += PlaneEvidence::ofSegment(lifted, rangeOf(lifted, 1.5), m);
    }
    EXPECT_GT(chi2Increase(floor, ramp), m.chi2Limit(3));
  }
}

TEST(NoiseModel, ALineJoinsWithinItsSigmasAndNotBeyond) {
  NoiseModel m;
  m.line_sigma = 0.2 * M_PI / 180.0;
  std::mt19937 rng(7);
  const PlaneEvidence plane = strip(rng, m, 20, 2.0, 0.03, 0.0);
  const auto increase = [&](double off) {
    const Moments3 mo = line(rng, m, 2.6, -1.0, 1.0, 0.0, 1.5, 60, off);
    return chi2Increase(plane, PlaneEvidence::ofSegment(mo, rangeOf(mo, 1.5), m));
  };
  const double sigma = 3.0 * 0.2 * M_PI / 180.0;  // R sigma_theta at 3 m: 1 cm
  int in_at_one = 0, out_at_six = 0;
  for (int t = 0; t < 200; ++t) {
    in_at_one += increase(1.0 * sigma) < m.chi2Limit(2);
    out_at_six += increase(6.0 * sigma) > m.chi2Limit(2);
  }
  EXPECT_GT(in_at_one, 180);
  EXPECT_GT(out_at_six, 190);
}
