#include "tilt_laser_perception/scip/codec.hpp"

#include <cctype>
#include <cmath>
#include <limits>

namespace tilt_laser_perception {
namespace scip {

char checksum(const char* begin, const char* end) {
  unsigned sum = 0;
  for (const char* p = begin; p != end; ++p) sum += static_cast<unsigned char>(*p);
  return static_cast<char>((sum & 0x3F) + 0x30);
}

void encode(std::uint32_t value, int chars, std::string& out) {
  for (int i = chars - 1; i >= 0; --i) out.push_back(static_cast<char>(((value >> (6 * i)) & 0x3F) + 0x30));
}

bool parseEchoChoice(const std::string& name, EchoChoice& out) {
  if (name == "first") out = EchoChoice::First;
  else if (name == "last") out = EchoChoice::Last;
  else if (name == "strongest") out = EchoChoice::Strongest;
  else return false;
  return true;
}

void encodeRange(std::uint32_t mm, int chars, std::string& out) {
  if (chars == 2 && mm > 0xFFF) mm = 1;
  encode(mm, chars, out);
}

std::optional<std::uint32_t> decode(const char* p, int chars) {
  std::uint32_t v = 0;
  for (int i = 0; i < chars; ++i) {
    const int c = static_cast<unsigned char>(p[i]) - 0x30;
    if (c < 0 || c > 0x3F) return std::nullopt;
    v = (v << 6) | static_cast<std::uint32_t>(c);
  }
  return v;
}

void appendLineWithSum(const std::string& text, std::string& out) {
  out += text;
  out.push_back(checksum(text));
  out.push_back('\n');
}

void appendDataLines(const std::string& data, std::string& out) {
  for (std::size_t i = 0; i < data.size(); i += 64) appendLineWithSum(data.substr(i, 64), out);
}

std::optional<Response> ResponseReader::next() {
  // A reply ends with two LFs; the sensor accepts CR too, but replies with LF only.
  const std::size_t end = buffer_.find("\n\n");
  if (end == std::string::npos) return std::nullopt;
  const std::string block = buffer_.substr(0, end + 1);
  buffer_.erase(0, end + 2);
  Response r;
  std::size_t pos = 0;
  std::vector<std::string> all;
  while (pos < block.size()) {
    const std::size_t lf = block.find('\n', pos);
    all.push_back(block.substr(pos, lf - pos));
    pos = lf + 1;
  }
  r.echo = all.empty() ? std::string() : all[0];
  if (all.size() >= 2) {
    const std::string& st = all[1];
    r.status = st.substr(0, 2);
    r.status_sum_ok = st.size() == 3 && checksum(st.data(), st.data() + 2) == st[2];
    // SCIP 1.1 style status without sum is not used by SCIP 2.0 sensors.
  }
  for (std::size_t i = 2; i < all.size(); ++i) r.lines.push_back(all[i]);
  return r;
}

std::optional<std::string> joinDataLines(const std::vector<std::string>& lines, std::size_t first,
                                         std::size_t* bad_line) {
  std::string data;
  for (std::size_t i = first; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    if (l.empty() || checksum(l.data(), l.data() + l.size() - 1) != l.back()) {
      if (bad_line) *bad_line = i;
      return std::nullopt;
    }
    data.append(l, 0, l.size() - 1);
  }
  return data;
}

std::string ScanRequest::line(int remaining) const {
  char buf[64];
  if (continuous())
    std::snprintf(buf, sizeof(buf), "%s%04d%04d%02d%01d%02d", command.c_str(), start_step, end_step, cluster, skip,
                  remaining);
  else
    std::snprintf(buf, sizeof(buf), "%s%04d%04d%02d", command.c_str(), start_step, end_step, cluster);
  std::string s = buf;
  if (!tag.empty()) s += ";" + tag;
  return s;
}

namespace {
bool digits(const std::string& s, std::size_t pos, std::size_t n, int& value) {
  if (pos + n > s.size()) return false;
  value = 0;
  for (std::size_t i = pos; i < pos + n; ++i) {
    if (!std::isdigit(static_cast<unsigned char>(s[i]))) return false;
    value = value * 10 + (s[i] - '0');
  }
  return true;
}
}  // namespace

std::string parseScanRequest(const std::string& full, int max_step, ScanRequest& out) {
  std::string line = full;
  out.tag.clear();
  const std::size_t semi = line.find(';');
  if (semi != std::string::npos) {
    out.tag = line.substr(semi + 1);
    line = line.substr(0, semi);
  }
  out.command = line.substr(0, 2);
  if (!digits(line, 2, 4, out.start_step)) return "01";
  if (!digits(line, 6, 4, out.end_step)) return "02";
  if (!digits(line, 10, 2, out.cluster)) return "03";
  if (out.end_step > max_step || out.start_step > max_step) return "04";
  if (out.end_step < out.start_step) return "05";
  if (out.continuous()) {
    if (!digits(line, 12, 1, out.skip)) return "06";
    if (!digits(line, 13, 2, out.scans)) return "07";
  }
  if (out.cluster == 0) out.cluster = 1;
  return "00";
}

const char* decodeErrorName(DecodeError e) {
  switch (e) {
    case DecodeError::None: return "none";
    case DecodeError::Status: return "error status";
    case DecodeError::Checksum: return "checksum mismatch";
    case DecodeError::Truncated: return "truncated scan";
    case DecodeError::BadCharacter: return "bad character";
  }
  return "unknown";
}

DecodeError decodeScan(const Response& r, const ScanRequest& req, ScanData& out) {
  const std::string expected = req.continuous() ? "99" : "00";
  if (r.status != expected || !r.status_sum_ok) return DecodeError::Status;
  if (r.lines.empty()) return DecodeError::Truncated;
  const std::string& ts = r.lines[0];
  if (ts.size() != 5) return DecodeError::Truncated;
  if (checksum(ts.data(), ts.data() + 4) != ts[4]) return DecodeError::Checksum;
  const auto stamp = decode(ts.data(), 4);
  if (!stamp) return DecodeError::BadCharacter;
  out.timestamp = *stamp;
  out.remaining = -1;
  if (req.continuous() && r.echo.size() >= 15) {
    int rem = 0;
    if (digits(r.echo, 13, 2, rem)) out.remaining = rem;
  }
  const auto data = joinDataLines(r.lines, 1);
  if (!data) return DecodeError::Checksum;
  const int enc = req.encoding();
  const int per_step = req.intensity() ? 2 * enc : enc;
  const std::size_t n = static_cast<std::size_t>(req.steps());
  if (!req.multiEcho() && data->size() != n * static_cast<std::size_t>(per_step)) return DecodeError::Truncated;
  out.ranges.resize(n);
  out.intensities.resize(req.intensity() ? n : 0);
  const char* p = data->data();
  const char* const end = p + data->size();
  // One echo: range (and intensity), `per_step` characters.
  const auto echo = [&](std::uint32_t& range, std::uint32_t* intensity) {
    if (end - p < per_step) return DecodeError::Truncated;
    const auto v = decode(p, enc);
    if (!v) return DecodeError::BadCharacter;
    range = *v;
    p += enc;
    if (req.intensity()) {
      const auto w = decode(p, enc);
      if (!w) return DecodeError::BadCharacter;
      if (intensity) *intensity = *w;
      p += enc;
    }
    return DecodeError::None;
  };
  if (!req.multiEcho()) {
    out.echo_count.clear();
    out.echo_ranges.clear();
    out.echo_intensities.clear();
    for (std::size_t i = 0; i < n; ++i) {
      const DecodeError e = echo(out.ranges[i], req.intensity() ? &out.intensities[i] : nullptr);
      if (e != DecodeError::None) return e;
    }
    return DecodeError::None;
  }
  out.echo_count.assign(n, 0);
  out.echo_ranges.assign(n * kMaxEchoes, 0);
  out.echo_intensities.assign(req.intensity() ? n * kMaxEchoes : 0, 0);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < kMaxEchoes; ++k) {
      if (k > 0) {
        if (p == end || *p != '&') break;
        ++p;
      }
      const std::size_t at = i * kMaxEchoes + k;
      const DecodeError e = echo(out.echo_ranges[at], req.intensity() ? &out.echo_intensities[at] : nullptr);
      if (e != DecodeError::None) return e;
      out.echo_count[i] = static_cast<std::uint8_t>(k + 1);
    }
    if (p != end && *p == '&') return DecodeError::BadCharacter;  // a fourth echo: not this protocol
    out.ranges[i] = out.echo_ranges[i * kMaxEchoes];
    if (req.intensity()) out.intensities[i] = out.echo_intensities[i * kMaxEchoes];
  }
  if (p != end) return DecodeError::Truncated;  // more data than steps
  return DecodeError::None;
}

float rangeToMeters(std::uint32_t mm, std::uint32_t min_mm, std::uint32_t max_mm) {
  if (mm >= min_mm) return mm > max_mm ? std::numeric_limits<float>::infinity() : static_cast<float>(mm) * 1e-3f;
  switch (mm) {
    case 1: return std::numeric_limits<float>::infinity();     // no object in range
    case 2:                                                    // object too near (internal error)
    case 4: return -std::numeric_limits<float>::infinity();    // object out of range at the near end
    default: return std::numeric_limits<float>::quiet_NaN();   // 3 interference, 5 other errors
  }
}

std::vector<std::pair<std::string, std::string>> parseInfo(const Response& r, int* bad_lines) {
  std::vector<std::pair<std::string, std::string>> out;
  int bad = 0;
  for (const std::string& l : r.lines) {
    // "KEY:value;" + sum, the sum taken over "KEY:value".
    const std::size_t semi = l.rfind(';');
    const std::size_t colon = l.find(':');
    // (a key of at least one character before the value: found by fuzz_scip)
    if (semi == std::string::npos || colon == std::string::npos || colon == 0 || colon > semi ||
        semi + 2 != l.size() || checksum(l.data(), l.data() + semi) != l.back()) {
      ++bad;
      continue;
    }
    out.emplace_back(l.substr(0, colon), l.substr(colon + 1, semi - colon - 1));
  }
  if (bad_lines) *bad_lines = bad;
  return out;
}

}  // namespace scip
}  // namespace tilt_laser_perception
