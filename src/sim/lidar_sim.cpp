#include "tilt_laser_perception/sim/lidar_sim.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tilt_laser_perception {
namespace sim {

double NoiseParams::sigma(double r) const {
  switch (mode) {
    case NoiseMode::None: return 0.0;
    case NoiseMode::Datasheet: return r <= 10.0 ? 0.030 / 3.0 : 0.050 / 3.0;
    case NoiseMode::Percent: return percent / 100.0 * r / 3.0;
  }
  return 0.0;
}

bool parseNoiseMode(const std::string& name, NoiseMode& mode) {
  if (name == "datasheet") mode = NoiseMode::Datasheet;
  else if (name == "percent") mode = NoiseMode::Percent;
  else if (name == "none") mode = NoiseMode::None;
  else return false;
  return true;
}

core::ScanView SimScan::view() const {
  core::ScanView v;
  v.ranges = ranges.data();
  v.size = ranges.size();
  v.intensities = intensities.data();
  v.intensities_size = intensities.size();
  v.angle_min = model.angleMin();
  v.angle_max = model.angleMax();
  v.angle_increment = model.angle_increment;
  v.range_min = model.range_min;
  v.range_max = model.range_max;
  return v;
}

LidarSimulator::LidarSimulator(const Scene& scene, const LidarModel& model, const NoiseParams& noise,
                               std::uint64_t seed)
    : scene_(scene), model_(model), noise_(noise), rng_(seed), echo_rng_(seed ^ 0x9E3779B97F4A7C15ull) {}

template <typename Dir>
double LidarSimulator::footprintRange(const Eigen::Vector3d& o, const Dir& dirAt, double a, double w,
                                      double cos_grazing, bool& several_faces, SubReturn* returns,
                                      int& n_returns) const {
  // Sub-rays across the footprint with a Gaussian profile (its edges at 2
  // sigma); each returns power ~ reflectivity * cos(incidence) / range^2
  // (an extended target filling its share of the footprint) when it is
  // detectable at all.
  constexpr int kRays = kFootprintRays;
  double sw = 0.0, swr = 0.0;
  n_returns = 0;
  int first_face = -1;
  several_faces = false;
  for (int k = 0; k < kRays; ++k) {
    const double u = -1.0 + 2.0 * k / (kRays - 1);  // -1..1 across the footprint
    Hit h;
    if (!scene_.raycast(o, dirAt(a + u * w), model_.max_detect_range, h)) continue;
    const double refl = scene_.faces[h.face].reflectivity;
    if (h.t > model_.max_detect_range * refl || h.cos_incidence < cos_grazing) continue;
    const double weight = std::exp(-2.0 * u * u) * refl * h.cos_incidence / (h.t * h.t);
    if (first_face < 0) first_face = h.face;
    several_faces = several_faces || h.face != first_face;
    sw += weight;
    swr += weight * h.t;
    returns[n_returns++] = {h.t, weight, h.face};
  }
  return sw > 0.0 ? swr / sw : std::numeric_limits<double>::quiet_NaN();
}

void LidarSimulator::scan(double t0, const PoseFunction& pose, SimScan& out) {
  const int n = model_.beams;
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  out.stamp = t0;
  out.model = model_;
  out.ranges.assign(n, inf);
  out.intensities.assign(n, 0.0f);
  out.true_ranges.assign(n, nan);
  out.face.assign(n, -1);
  out.mixed.assign(n, 0);
  out.echoes.assign(n, BeamEchoes());
  std::normal_distribution<double> gauss(0.0, 1.0), echo_gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double cos_grazing = std::cos(noise_.grazing_limit_deg * M_PI / 180.0);
  const double half = 0.5 * model_.angle_increment;

  for (int i = 0; i < n; ++i) {
    const Eigen::Isometry3d T = pose(t0 + model_.beamTime(i));
    const Eigen::Vector3d o = T.translation();
    const Eigen::Vector3d ex = T.linear().col(0), ey = T.linear().col(1);
    const auto dirAt = [&](double a) -> Eigen::Vector3d { return std::cos(a) * ex + std::sin(a) * ey; };
    const double a = model_.angle(i);
    Hit hit;
    if (!scene_.raycast(o, dirAt(a), model_.max_detect_range, hit)) continue;
    out.face[i] = hit.face;
    out.true_ranges[i] = static_cast<float>(hit.t);
    const double refl = scene_.faces[hit.face].reflectivity;
    if (hit.t > model_.max_detect_range * refl || hit.cos_incidence < cos_grazing) continue;
    if (noise_.dropout_probability > 0.0 && uni(rng_) < noise_.dropout_probability) continue;

    double r = hit.t;
    // Later echoes before noise: range, share of the beam's power, face, several faces.
    struct Far {
      double t, share;
      int face;
      bool several;
    } far[scip::kMaxEchoes - 1];
    int n_far = 0;
    const double sep = noise_.echo_separation;
    if (noise_.footprint > model_.angle_increment) {
      // A footprint wider than the step: where its edges see other ranges
      // than its centre, the return is the power-weighted mean over it.
      const double w = 0.5 * noise_.footprint;
      Hit h1, h2;
      const bool b1 = scene_.raycast(o, dirAt(a - w), model_.max_detect_range, h1);
      const bool b2 = scene_.raycast(o, dirAt(a + w), model_.max_detect_range, h2);
      if (!b1 || !b2 || std::abs(h1.t - hit.t) > 0.02 || std::abs(h2.t - hit.t) > 0.02) {
        bool faces = false;
        SubReturn sub[kFootprintRays];
        int n_sub = 0;
        r = footprintRange(o, dirAt, a, w, cos_grazing, faces, sub, n_sub);
        if (!std::isfinite(r)) continue;
        out.mixed[i] = faces && std::abs(r - hit.t) > 0.03;  // between surfaces (not along one at grazing incidence)
        // The returns beyond the first echo by more than the pulse resolution
        // are echoes of their own: clusters split where the ranges jump by more.
        std::sort(sub, sub + n_sub, [](const SubReturn& x, const SubReturn& y) { return x.t < y.t; });
        double total = 0.0;
        for (int k = 0; k < n_sub; ++k) total += sub[k].w;
        double cw = 0.0, cwt = 0.0, last = 0.0;
        int cface = -1;
        bool several = false;
        const auto flush = [&] {
          if (cw > 0.0 && n_far < scip::kMaxEchoes - 1) far[n_far++] = {cwt / cw, cw / total, cface, several};
          cw = cwt = 0.0;
          cface = -1;
          several = false;
        };
        for (int k = 0; k < n_sub; ++k) {
          if (sub[k].t <= r + sep) continue;
          if (cw > 0.0 && sub[k].t - last > sep) flush();
          if (cface < 0) cface = sub[k].face;
          several = several || sub[k].face != cface;
          cw += sub[k].w;
          cwt += sub[k].w * sub[k].t;
          last = sub[k].t;
        }
        flush();
      }
    } else if (noise_.mixed_pixel_probability > 0.0) {
      // The beam's footprint reaches half a step either side: where it
      // straddles a depth jump the sensor may report a range in between.
      Hit h1, h2;
      const bool b1 = scene_.raycast(o, dirAt(a - half), model_.max_detect_range, h1);
      const bool b2 = scene_.raycast(o, dirAt(a + half), model_.max_detect_range, h2);
      if (b1 && b2 && std::abs(h1.t - h2.t) > 0.05 && uni(rng_) < noise_.mixed_pixel_probability) {
        r = h1.t + uni(rng_) * (h2.t - h1.t);
        out.mixed[i] = h1.face != h2.face;  // between surfaces (not along one at grazing incidence)
        const Hit& f = h1.t > h2.t ? h1 : h2;
        if (f.t > r + sep) far[n_far++] = {f.t, 0.5, f.face, false};
      }
    }
    r += noise_.sigma(r) * gauss(rng_);
    r = std::round(r * 1000.0) / 1000.0;  // the sensor reports millimetres
    if (r < model_.range_min) continue;
    out.ranges[i] = static_cast<float>(r);
    out.intensities[i] = static_cast<float>(8000.0 * refl * hit.cos_incidence / (1.0 + 0.05 * r) + 100.0);
    BeamEchoes& e = out.echoes[i];
    e.count = 1;
    e.range[0] = out.ranges[i];
    e.intensity[0] = out.intensities[i];
    e.mixed[0] = out.mixed[i];
    for (int k = 0; k < n_far; ++k) {
      // (their own generator and distribution: normal_distribution keeps the
      // second value of each pair it draws, so sharing `gauss` would shift the
      // single-echo ranges' noise)
      double t = far[k].t + noise_.sigma(far[k].t) * echo_gauss(echo_rng_);
      t = std::round(t * 1000.0) / 1000.0;
      e.range[e.count] = static_cast<float>(t);
      e.intensity[e.count] = static_cast<float>(
          8000.0 * far[k].share * scene_.faces[far[k].face].reflectivity / (1.0 + 0.05 * t) + 100.0);
      e.mixed[e.count] = far[k].several;
      ++e.count;
    }
  }
  if (noise_.rain_probability > 0.0) {
    // A drop is a weak, near first echo; the surface's echoes follow it.
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < n; ++i) {
      if (u(echo_rng_) >= noise_.rain_probability) continue;
      const float d = static_cast<float>(std::round((0.3 + 3.7 * u(echo_rng_)) * 1000.0) / 1000.0);
      BeamEchoes& e = out.echoes[i];
      if (e.count > 0 && d > e.range[0] - noise_.echo_separation) continue;  // merged into the surface's echo
      const int keep = std::min<int>(e.count, scip::kMaxEchoes - 1);
      for (int k = keep; k > 0; --k) {
        e.range[k] = e.range[k - 1];
        e.intensity[k] = e.intensity[k - 1];
        e.mixed[k] = e.mixed[k - 1];
      }
      e.count = static_cast<std::uint8_t>(keep + 1);
      e.range[0] = d;
      e.intensity[0] = static_cast<float>(150.0 + 300.0 * u(echo_rng_));
      e.mixed[0] = 0;
      out.ranges[i] = d;
      out.intensities[i] = e.intensity[0];
      out.mixed[i] = 0;
    }
  }
  out.edges = trueEdges(scene_, out.face, out.ranges, out.true_ranges);
}

void selectEcho(SimScan& scan, scip::EchoChoice choice) {
  for (std::size_t i = 0; i < scan.echoes.size(); ++i) {
    const BeamEchoes& e = scan.echoes[i];
    if (e.count == 0) continue;
    const int k = scip::chooseEcho(choice, e.count, e.intensity);
    scan.ranges[i] = e.range[k];
    scan.intensities[i] = e.intensity[k];
    scan.mixed[i] = e.mixed[k];
  }
}

std::vector<TrueEdge> trueEdges(const Scene& scene, const std::vector<int>& face, const std::vector<float>& ranges,
                                const std::vector<float>& true_ranges) {
  std::vector<TrueEdge> edges;
  const int n = static_cast<int>(face.size());
  const auto valid = [&](int i) { return std::isfinite(ranges[i]) && face[i] >= 0; };
  const auto coplanar = [&](int a, int b) {
    const Face& fa = scene.faces[a];
    const Face& fb = scene.faces[b];
    return std::abs(fa.normal.dot(fb.normal)) > 1.0 - 1e-9 && std::abs(fa.normal.dot(fb.origin - fa.origin)) < 1e-4;
  };
  if (n > 0 && valid(0)) edges.push_back({0, core::EdgeKind::Boundary});
  for (int i = 0; i + 1 < n; ++i) {
    const bool vi = valid(i), vj = valid(i + 1);
    if (vi && vj) {
      const int fi = face[i], fj = face[i + 1];
      if (fi == fj || coplanar(fi, fj)) continue;
      if (scene.creaseBetween(fi, fj)) {
        edges.push_back({i, core::EdgeKind::Crease});
      } else {
        const int near = true_ranges[i] < true_ranges[i + 1] ? i : i + 1;
        edges.push_back({near, core::EdgeKind::Jump});
      }
    } else if (vi != vj) {
      edges.push_back({vi ? i : i + 1, core::EdgeKind::Boundary});
    }
  }
  if (n > 1 && valid(n - 1)) edges.push_back({n - 1, core::EdgeKind::Boundary});
  return edges;
}

std::vector<Eigen::Vector3f> rangeImage(const Scene& scene, const Eigen::Vector3d& origin, int n, double sigma,
                                        std::uint64_t seed, std::vector<int>* faces) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  const std::size_t size = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  std::vector<Eigen::Vector3f> pts(size, Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  if (faces) faces->assign(size, -1);
  for (int r = 0; r < n; ++r) {
    const double el = (10.0 + 50.0 * r / (n - 1)) * M_PI / 180.0;
    for (int c = 0; c < n; ++c) {
      const double az = (60.0 - 120.0 * c / (n - 1)) * M_PI / 180.0;
      const Eigen::Vector3d dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), -std::sin(el));
      Hit hit;
      if (!scene.raycast(origin, dir, 30.0, hit)) continue;
      const std::size_t i = static_cast<std::size_t>(r) * n + c;
      pts[i] = (origin + (hit.t + (sigma > 0.0 ? noise(rng) : 0.0)) * dir).cast<float>();
      if (faces) (*faces)[i] = hit.face;
    }
  }
  return pts;
}

}  // namespace sim
}  // namespace tilt_laser_perception
