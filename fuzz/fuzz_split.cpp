// libFuzzer: the range-adaptive split on arbitrary scans: ranges of any float
// (NaN, inf, negative, huge), any angles and range limits, any split settings
// that validate.
#include <cmath>
#include <vector>

#include "fuzz_input.hpp"
#include "tilt_laser_perception/core/scan_split.hpp"

using namespace tilt_laser_perception::core;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  tlp_fuzz::Input in(data, size);
  SplitParams p;
  p.mode = in.take<std::uint8_t>() & 1 ? SplitMode::Fixed : SplitMode::Adaptive;
  p.zeta = in.take<float>();
  p.d_min = in.take<float>();
  p.jump_min = in.take<float>();
  p.jump_ratio = in.take<float>();
  p.min_points = static_cast<int>(in.take<std::int8_t>());
  p.merge = in.take<std::uint8_t>() & 1;
  if (!p.validate().empty()) p = SplitParams();
  ScanView v;
  v.angle_min = in.take<float>();
  v.angle_increment = in.take<float>();
  v.range_min = in.take<float>();
  v.range_max = in.take<float>();
  const bool with_intensities = in.take<std::uint8_t>() & 1;
  std::vector<float> ranges;
  while (in.left() >= sizeof(float) && ranges.size() < 4000) ranges.push_back(in.take<float>());
  std::vector<float> intensities(with_intensities ? ranges.size() : 0, 100.0f);
  v.ranges = ranges.data();
  v.size = ranges.size();
  v.intensities = intensities.empty() ? nullptr : intensities.data();
  v.intensities_size = intensities.size();
  v.angle_max = v.angle_min + (ranges.empty() ? 0.0 : (ranges.size() - 1) * v.angle_increment);
  ScanSplitter splitter(p);
  SplitResult out;
  for (int pass = 0; pass < 2; ++pass) {  // twice: the reused buffers give the same result
    const ScanError e = splitter.split(v, out);
    if (e != ScanError::None) {
      TLP_FUZZ_CHECK(checkScan(v) == e);
      return 0;
    }
    const int n = static_cast<int>(v.size);
    int prev_last = -1;
    for (const Segment& s : out.segments) {
      TLP_FUZZ_CHECK(0 <= s.first && s.first <= s.last && s.last < n);
      TLP_FUZZ_CHECK(s.first > prev_last);  // in order, not overlapping
      prev_last = s.last;
      TLP_FUZZ_CHECK(s.count >= 2 && s.count <= s.last - s.first + 1);
      TLP_FUZZ_CHECK(std::isfinite(s.start.x()) && std::isfinite(s.end.y()) && std::isfinite(s.rms));
    }
    for (const EdgePoint& ep : out.edges) TLP_FUZZ_CHECK(0 <= ep.index && ep.index < n);
    TLP_FUZZ_CHECK(out.valid_points >= 0 && out.valid_points <= n);
  }
  return 0;
}
