/**
 * @file protocol.hpp
 * @brief Dynamixel Protocol 1.0 and 2.0 packets: building, checksum and CRC-16,
 *        and a parser that finds packets in a byte stream (skipping garbage). ROS-free.
 *
 * Facts used (ROBOTIS protocol manuals):
 *  - 1.0: FF FF ID LEN INST|ERR PARAMS... CHK; LEN = params + 2;
 *    CHK = ~(ID + LEN + INST + PARAMS) & 0xFF.
 *  - 2.0: FF FF FD 00 ID LEN_L LEN_H INST [ERR] PARAMS... CRC_L CRC_H; LEN counts
 *    INST, ERR, PARAMS and CRC; CRC-16 with polynomial 0x8005, initial value 0,
 *    over everything before it; FF FF FD inside INST..PARAMS is stuffed to FF FF FD FD.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace tilt_laser_perception {
namespace dynamixel {

enum class Protocol : int { V1 = 1, V2 = 2 };

/// Instruction codes.
namespace inst {
constexpr std::uint8_t kPing = 0x01, kRead = 0x02, kWrite = 0x03, kRegWrite = 0x04, kAction = 0x05,
                       kFactoryReset = 0x06, kReboot = 0x08, kStatus = 0x55, kSyncRead = 0x82, kSyncWrite = 0x83,
                       kBulkRead = 0x92, kBulkWrite = 0x93;
}  // namespace inst

constexpr std::uint8_t kBroadcastId = 0xFE;

/// Protocol 1.0 checksum of ID..last parameter.
std::uint8_t checksum1(const std::uint8_t* data, std::size_t size);
/// Protocol 2.0 CRC-16 (polynomial 0x8005, not reflected), continuing from `crc`.
std::uint16_t crc16(const std::uint8_t* data, std::size_t size, std::uint16_t crc = 0);

/// An instruction packet (host to servo).
std::vector<std::uint8_t> instructionPacket(Protocol p, std::uint8_t id, std::uint8_t instruction,
                                            const std::vector<std::uint8_t>& params);
/// A status packet (servo to host); `error` is the error byte.
std::vector<std::uint8_t> statusPacket(Protocol p, std::uint8_t id, std::uint8_t error,
                                       const std::vector<std::uint8_t>& params);

/// A parsed packet.
struct Packet {
  std::uint8_t id = 0;
  std::uint8_t instruction = 0;  ///< 1.0 status packets: 0; 2.0 status packets: 0x55
  std::uint8_t error = 0;        ///< status packets only
  std::vector<std::uint8_t> params;
};

/// Finds packets in a byte stream. Bytes before a header are skipped and
/// counted; a packet whose checksum or CRC fails is dropped and counted.
class PacketParser {
 public:
  /// `status`: parse status packets (host side) rather than instruction packets (servo side).
  PacketParser(Protocol p, bool status) : protocol_(p), status_(status) {}

  void feed(const std::uint8_t* data, std::size_t size) { buffer_.insert(buffer_.end(), data, data + size); }
  /// Next complete packet with a good checksum, if there is one.
  bool next(Packet& out);
  void clear() { buffer_.clear(); }

  std::size_t garbageBytes() const { return garbage_; }
  std::size_t badChecksums() const { return bad_checksum_; }
  /// The ID of the last packet dropped for its checksum / CRC.
  int lastBadId() const { return last_bad_id_; }
  std::size_t pending() const { return buffer_.size(); }
  Protocol protocol() const { return protocol_; }

 private:
  Protocol protocol_;
  bool status_;
  std::vector<std::uint8_t> buffer_;
  std::size_t garbage_ = 0, bad_checksum_ = 0;
  int last_bad_id_ = -1;
};

/// Little-endian helpers.
inline void putLE(std::vector<std::uint8_t>& v, std::uint32_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) v.push_back(static_cast<std::uint8_t>(value >> (8 * i)));
}
inline std::uint32_t getLE(const std::uint8_t* p, int bytes) {
  std::uint32_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

/// Names of the error bits of a 1.0 status packet, or of the 2.0 hardware error
/// status register (address 70), joined with ", "; empty when none is set.
std::string hardwareErrorNames(Protocol p, std::uint8_t bits);
/// Name of a 2.0 status packet error number (the error byte without the alert bit).
const char* statusErrorName2(std::uint8_t error);

}  // namespace dynamixel
}  // namespace tilt_laser_perception
