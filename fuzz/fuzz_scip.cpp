// libFuzzer: arbitrary bytes from the laser through the SCIP 2.0 reply reader,
// the scan decoder and the info parser (what UtmClient does with a socket's bytes).
#include "fuzz_input.hpp"
#include "tilt_laser_perception/scip/codec.hpp"

using namespace tilt_laser_perception::scip;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  ResponseReader reader;
  // arrive in two pieces, cut where the first byte says
  const std::size_t cut = size ? data[0] % size : 0;
  reader.feed(reinterpret_cast<const char*>(data), cut);
  reader.feed(reinterpret_cast<const char*>(data) + cut, size - cut);
  while (auto r = reader.next()) {
    ScanRequest req;
    if (parseScanRequest(r->echo, 1080, req) == "00") {
      ScanData scan;
      if (decodeScan(*r, req, scan) == DecodeError::None) {
        TLP_FUZZ_CHECK(scan.ranges.size() == static_cast<std::size_t>(req.steps()));
        TLP_FUZZ_CHECK(scan.intensities.empty() || scan.intensities.size() == scan.ranges.size());
        TLP_FUZZ_CHECK(scan.timestamp < (1u << 24));
        for (std::uint32_t mm : scan.ranges) (void)rangeToMeters(mm);
      }
    }
    int bad = 0;
    for (const auto& kv : parseInfo(*r, &bad)) TLP_FUZZ_CHECK(!kv.first.empty());
    std::size_t bad_line = 0;
    (void)joinDataLines(r->lines, 0, &bad_line);
  }
  TLP_FUZZ_CHECK(reader.pending() <= size);
  return 0;
}
