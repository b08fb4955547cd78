// libFuzzer: sweep assembly and scan line grouping on arbitrary input: joint
// states (any time, any angle, out of order), scan lines with any ranges,
// stamps and segment/edge indices (as a malformed ScanSegments message could
// carry), polled at any time.
#include <cmath>
#include <vector>

#include "fuzz_input.hpp"
#include "tilt_laser_perception/core/sweep.hpp"

using namespace tilt_laser_perception::core;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  tlp_fuzz::Input in(data, size);
  SweepParams p;
  p.min_lines = 1 + in.below(5);
  TiltChain chain;
  chain.base_to_joint.translation() = Eigen::Vector3d(0, 0, 1.4);
  SweepAssembler a(p, chain);
  double t = 0.0;
  int events = 0;
  while (in.left() > 0 && ++events < 400) {
    const unsigned kind = in.below(4);
    t += in.below(50) * 0.001;
    if (kind == 0 || kind == 1) {  // a joint state; sometimes garbage
      const float q = kind == 0 ? 0.2f + 0.6f * std::fabs(std::sin(t)) : in.take<float>();
      const double ts = kind == 0 ? t : t - in.below(100) * 0.001;
      a.addJoint(ts, q);
    } else if (kind == 2) {  // a scan line
      LineInput line;
      const unsigned n = in.below(64);
      line.ranges.resize(n);
      for (float& r : line.ranges) r = in.below(8) == 0 ? in.take<float>() : 0.5f + 0.01f * in.below(500);
      if (in.below(4) == 0) line.intensities.resize(in.below(70), 1.0f);
      line.angle_min = -0.5;
      line.angle_increment = in.below(8) == 0 ? in.take<float>() : 0.01;
      line.range_min = 0.1;
      line.range_max = 30.0;
      line.stamp = t - 0.025 + in.below(20) * 0.001;
      line.time_increment = in.below(8) == 0 ? in.take<float>() : 0.000025;
      const unsigned segs = in.below(6);
      for (unsigned k = 0; k < segs; ++k) {
        const int first = static_cast<int>(in.below(80)) - 8, last = first + static_cast<int>(in.below(40)) - 4;
        line.segments.emplace_back(first, last);
      }
      const unsigned edges = in.below(4);
      for (unsigned k = 0; k < edges; ++k)
        line.edges.emplace_back(static_cast<int>(in.below(80)) - 8, static_cast<EdgeKind>(in.below(6)));
      a.addLine(std::move(line), t);
    }
    SweepResult r;
    while (a.poll(t, r)) {
      for (const Plane& pl : r.planes) {
        TLP_FUZZ_CHECK(std::isfinite(pl.fit.normal.norm()) && std::abs(pl.fit.normal.norm() - 1.0) < 1e-6);
        TLP_FUZZ_CHECK(pl.area >= 0.0);
      }
      TLP_FUZZ_CHECK(r.segment_plane.size() == r.segments.size());
    }
  }
  return 0;
}
