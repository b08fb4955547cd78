#include "tilt_laser_perception/dynamixel/protocol.hpp"

#include <algorithm>
#include <array>

namespace tilt_laser_perception {
namespace dynamixel {

std::uint8_t checksum1(const std::uint8_t* data, std::size_t size) {
  unsigned sum = 0;
  for (std::size_t i = 0; i < size; ++i) sum += data[i];
  return static_cast<std::uint8_t>(~sum & 0xFF);
}

namespace {
std::array<std::uint16_t, 256> makeCrcTable() {
  std::array<std::uint16_t, 256> t{};
  for (unsigned i = 0; i < 256; ++i) {
    std::uint16_t c = static_cast<std::uint16_t>(i << 8);
    for (int b = 0; b < 8; ++b) c = (c & 0x8000) ? static_cast<std::uint16_t>((c << 1) ^ 0x8005) : static_cast<std::uint16_t>(c << 1);
    t[i] = c;
  }
  return t;
}
}  // namespace

std::uint16_t crc16(const std::uint8_t* data, std::size_t size, std::uint16_t crc) {
  static const std::array<std::uint16_t, 256> table = makeCrcTable();
  for (std::size_t i = 0; i < size; ++i)
    crc = static_cast<std::uint16_t>((crc << 8) ^ table[((crc >> 8) ^ data[i]) & 0xFF]);
  return crc;
}

namespace {
std::vector<std::uint8_t> packet2(std::uint8_t id, const std::vector<std::uint8_t>& body) {
  // body = INST [ERR] PARAMS, stuffed: FF FF FD -> FF FF FD FD
  std::vector<std::uint8_t> stuffed;
  stuffed.reserve(body.size() + 4);
  for (std::size_t i = 0; i < body.size(); ++i) {
    stuffed.push_back(body[i]);
    if (i >= 2 && body[i] == 0xFD && body[i - 1] == 0xFF && body[i - 2] == 0xFF) stuffed.push_back(0xFD);
  }
  std::vector<std::uint8_t> p{0xFF, 0xFF, 0xFD, 0x00, id};
  putLE(p, static_cast<std::uint32_t>(stuffed.size() + 2), 2);
  p.insert(p.end(), stuffed.begin(), stuffed.end());
  const std::uint16_t crc = crc16(p.data(), p.size());
  putLE(p, crc, 2);
  return p;
}
std::vector<std::uint8_t> packet1(std::uint8_t id, std::uint8_t code, const std::vector<std::uint8_t>& params) {
  std::vector<std::uint8_t> p{0xFF, 0xFF, id, static_cast<std::uint8_t>(params.size() + 2), code};
  p.insert(p.end(), params.begin(), params.end());
  p.push_back(checksum1(p.data() + 2, p.size() - 2));
  return p;
}
}  // namespace

std::vector<std::uint8_t> instructionPacket(Protocol p, std::uint8_t id, std::uint8_t instruction,
                                            const std::vector<std::uint8_t>& params) {
  if (p == Protocol::V1) return packet1(id, instruction, params);
  std::vector<std::uint8_t> body{instruction};
  body.insert(body.end(), params.begin(), params.end());
  return packet2(id, body);
}

std::vector<std::uint8_t> statusPacket(Protocol p, std::uint8_t id, std::uint8_t error,
                                       const std::vector<std::uint8_t>& params) {
  if (p == Protocol::V1) return packet1(id, error, params);
  std::vector<std::uint8_t> body{inst::kStatus, error};
  body.insert(body.end(), params.begin(), params.end());
  return packet2(id, body);
}

bool PacketParser::next(Packet& out) {
  const bool v2 = protocol_ == Protocol::V2;
  const std::size_t header = v2 ? 4 : 2;
  for (;;) {
    // Find a header; everything before it is garbage.
    std::size_t start = 0;
    bool found = false;
    for (; start + header <= buffer_.size(); ++start) {
      if (buffer_[start] != 0xFF || buffer_[start + 1] != 0xFF) continue;
      if (v2 && (buffer_[start + 2] != 0xFD || buffer_[start + 3] != 0x00)) continue;
      if (!v2 && start + 2 < buffer_.size() && buffer_[start + 2] == 0xFF) continue;  // FF FF FF: shift by one
      found = true;
      break;
    }
    if (!found) {
      // Keep a possible partial header at the end.
      const std::size_t keep = std::min(buffer_.size(), header - 1);
      std::size_t drop = buffer_.size() - keep;
      while (drop < buffer_.size() && buffer_[drop] != 0xFF) ++drop;
      garbage_ += drop;
      buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<long>(drop));
      return false;
    }
    if (start > 0) {
      garbage_ += start;
      buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<long>(start));
    }
    if (!v2) {
      if (buffer_.size() < 4) return false;
      const std::size_t len = buffer_[3];
      if (len < 2 || buffer_[2] > 0xFE) {  // impossible: skip this header
        ++garbage_;
        buffer_.erase(buffer_.begin());
        continue;
      }
      if (buffer_.size() < len + 4) return false;
      const std::size_t total = len + 4;
      if (checksum1(buffer_.data() + 2, total - 3) != buffer_[total - 1]) {
        ++bad_checksum_;
        last_bad_id_ = buffer_[2];
        buffer_.erase(buffer_.begin(), buffer_.begin() + 2);  // resynchronise after this header
        continue;
      }
      out.id = buffer_[2];
      if (status_) {
        out.instruction = 0;
        out.error = buffer_[4];
      } else {
        out.instruction = buffer_[4];
        out.error = 0;
      }
      out.params.assign(buffer_.begin() + 5, buffer_.begin() + static_cast<long>(total - 1));
      buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<long>(total));
      return true;
    }
    if (buffer_.size() < 7) return false;
    const std::size_t len = getLE(buffer_.data() + 5, 2);
    const std::size_t min_len = status_ ? 4 : 3;
    if (len < min_len || len > 1024 || buffer_[4] > 0xFE) {
      ++garbage_;
      buffer_.erase(buffer_.begin());
      continue;
    }
    const std::size_t total = 7 + len;
    if (buffer_.size() < total) return false;
    const std::uint16_t crc = crc16(buffer_.data(), total - 2);
    if (crc != getLE(buffer_.data() + total - 2, 2)) {
      ++bad_checksum_;
      last_bad_id_ = buffer_[4];
      buffer_.erase(buffer_.begin(), buffer_.begin() + 4);
      continue;
    }
    // Unstuff INST..PARAMS.
    std::vector<std::uint8_t> body;
    body.reserve(len);
    for (std::size_t i = 7; i < total - 2; ++i) {
      body.push_back(buffer_[i]);
      const std::size_t n = body.size();
      if (n >= 3 && body[n - 1] == 0xFD && body[n - 2] == 0xFF && body[n - 3] == 0xFF && i + 1 < total - 2 &&
          buffer_[i + 1] == 0xFD)
        ++i;  // skip the stuffing byte
    }
    out.id = buffer_[4];
    out.instruction = body.empty() ? 0 : body[0];
    std::size_t p = 1;
    out.error = 0;
    if (status_ && body.size() >= 2) {
      out.error = body[1];
      p = 2;
    }
    out.params.assign(body.begin() + static_cast<long>(std::min(p, body.size())), body.end());
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<long>(total));
    if (status_ && out.instruction != inst::kStatus) continue;  // an echo of an instruction: not for us
    return true;
  }
}

std::string hardwareErrorNames(Protocol p, std::uint8_t bits) {
  static const char* const v1[8] = {"input voltage", "angle limit", "overheating", "range",
                                    "checksum",      "overload",    "instruction", "bit7"};
  static const char* const v2[8] = {"input voltage", "bit1",     "overheating", "motor encoder",
                                    "electrical shock", "overload", "bit6",        "bit7"};
  std::string s;
  for (int b = 0; b < 8; ++b) {
    if (!(bits & (1u << b))) continue;
    if (!s.empty()) s += ", ";
    s += (p == Protocol::V1 ? v1 : v2)[b];
  }
  return s;
}

const char* statusErrorName2(std::uint8_t error) {
  switch (error & 0x7F) {
    case 0: return "none";
    case 1: return "result fail";
    case 2: return "instruction error";
    case 3: return "CRC error";
    case 4: return "data range error";
    case 5: return "data length error";
    case 6: return "data limit error";
    case 7: return "access error";
  }
  return "unknown error";
}

}  // namespace dynamixel
}  // namespace tilt_laser_perception
