// Dynamixel packets against hand-worked examples, the CRC against a bit-by-bit
// reference, and the parser on a noisy stream.
#include <gtest/gtest.h>

#include "tilt_laser_perception/dynamixel/mx64.hpp"

using namespace tilt_laser_perception::dynamixel;
using Bytes = std::vector<std::uint8_t>;

namespace {
// CRC-16 (poly 0x8005, init 0, no reflection) one bit at a time, as the manual describes it.
std::uint16_t crcBitwise(const Bytes& data) {
  std::uint16_t crc = 0;
  for (std::uint8_t byte : data) {
    crc ^= static_cast<std::uint16_t>(byte << 8);
    for (int i = 0; i < 8; ++i) crc = (crc & 0x8000) ? static_cast<std::uint16_t>((crc << 1) ^ 0x8005) : static_cast<std::uint16_t>(crc << 1);
  }
  return crc;
}
}  // namespace

TEST(Dynamixel, Protocol1PacketsWorkedByHand) {
  // Ping ID 1: checksum = ~(1 + 2 + 1) = ~4 = 0xFB.
  EXPECT_EQ(instructionPacket(Protocol::V1, 1, inst::kPing, {}), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB}));
  // Read 2 bytes at 36 (present position): ~(1 + 4 + 2 + 36 + 2) = ~45 = 0xD2.
  EXPECT_EQ(instructionPacket(Protocol::V1, 1, inst::kRead, {36, 2}),
            (Bytes{0xFF, 0xFF, 0x01, 0x04, 0x02, 0x24, 0x02, 0xD2}));
  // Status: no error, position 2048 (0x00 0x08): ~(1 + 4 + 0 + 0 + 8) = 0xF2.
  EXPECT_EQ(statusPacket(Protocol::V1, 1, 0, {0x00, 0x08}), (Bytes{0xFF, 0xFF, 0x01, 0x04, 0x00, 0x00, 0x08, 0xF2}));
  EXPECT_EQ(checksum1(Bytes{0x01, 0x02, 0x01}.data(), 3), 0xFB);
}

TEST(Dynamixel, Protocol2PingAndCrc) {
  // Ping ID 1: FF FF FD 00 01 03 00 01, then CRC 0x4E19 low byte first.
  const Bytes ping = instructionPacket(Protocol::V2, 1, inst::kPing, {});
  EXPECT_EQ(ping, (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E}));
  const Bytes body(ping.begin(), ping.end() - 2);
  EXPECT_EQ(crc16(body.data(), body.size()), crcBitwise(body));
  // A longer packet: read 4 bytes at 132 (present position).
  const Bytes read = instructionPacket(Protocol::V2, 1, inst::kRead, {0x84, 0x00, 0x04, 0x00});
  const Bytes rbody(read.begin(), read.end() - 2);
  EXPECT_EQ(getLE(read.data() + read.size() - 2, 2), crcBitwise(rbody));
  EXPECT_EQ(read[5], 0x07);  // length = instruction + 4 params + CRC
}

TEST(Dynamixel, Protocol2ByteStuffingRoundTrip) {
  const Bytes params{0x74, 0x00, 0xFF, 0xFF, 0xFD, 0x01};
  const Bytes pkt = instructionPacket(Protocol::V2, 3, inst::kWrite, params);
  // FF FF FD inside the parameters becomes FF FF FD FD: one byte longer.
  EXPECT_EQ(pkt.size(), 10u + params.size() + 1);
  PacketParser parser(Protocol::V2, false);
  parser.feed(pkt.data(), pkt.size());
  Packet p;
  ASSERT_TRUE(parser.next(p));
  EXPECT_EQ(p.id, 3);
  EXPECT_EQ(p.instruction, inst::kWrite);
  EXPECT_EQ(p.params, params);
}

TEST(Dynamixel, ParserSkipsGarbageAndDropsBadPackets) {
  for (Protocol proto : {Protocol::V1, Protocol::V2}) {
    PacketParser parser(proto, true);
    Bytes stream{0x00, 0x13, 0xFF, 0x42};  // garbage
    const Bytes good = statusPacket(proto, 1, 0x20, {0x10, 0x08});
    Bytes bad = statusPacket(proto, 1, 0, {0x11, 0x08});
    bad.back() ^= 0xFF;
    stream.insert(stream.end(), bad.begin(), bad.end());
    stream.insert(stream.end(), good.begin(), good.end());
    // Feed byte by byte: nothing comes out early.
    Packet p;
    int packets = 0;
    for (std::uint8_t b : stream) {
      parser.feed(&b, 1);
      while (parser.next(p)) {
        ++packets;
        EXPECT_EQ(p.id, 1);
        EXPECT_EQ(p.error, 0x20);  // the error byte comes through with the data
        EXPECT_EQ(p.params, (Bytes{0x10, 0x08}));
      }
    }
    EXPECT_EQ(packets, 1) << static_cast<int>(proto);
    EXPECT_EQ(parser.badChecksums(), 1u) << static_cast<int>(proto);
    EXPECT_GE(parser.garbageBytes(), 4u) << static_cast<int>(proto);
  }
}

TEST(Dynamixel, UnitConversions) {
  EXPECT_EQ(radToPosition(0.0), 2048);
  EXPECT_NEAR(positionToRad(3072), M_PI / 2, 1e-12);
  EXPECT_EQ(radToPosition(-M_PI / 2), 1024);
  // 1.0: 100 units = 11.4 rpm, bit 10 = CW = negative.
  EXPECT_NEAR(velocityToRadPerSec(Protocol::V1, 100), 11.4 * 2 * M_PI / 60, 1e-9);
  EXPECT_NEAR(velocityToRadPerSec(Protocol::V1, 100 | 0x400), -11.4 * 2 * M_PI / 60, 1e-9);
  // 2.0: signed 32 bit, 0.229 rpm.
  EXPECT_NEAR(velocityToRadPerSec(Protocol::V2, static_cast<std::uint32_t>(-100)), -22.9 * 2 * M_PI / 60, 1e-9);
  EXPECT_EQ(radPerSecToVelocity(Protocol::V2, 22.9 * 2 * M_PI / 60), 100u);
  EXPECT_NEAR(loadToFraction(500 | 0x400), -0.5, 1e-12);
  EXPECT_NEAR(currentToAmp(Protocol::V1, 2048 + 100), 0.45, 1e-12);
  EXPECT_NEAR(currentToAmp(Protocol::V2, static_cast<std::uint16_t>(-100)), -0.336, 1e-12);
  EXPECT_EQ(hardwareErrorNames(Protocol::V1, 0x25), "input voltage, overheating, overload");
  EXPECT_EQ(hardwareErrorNames(Protocol::V2, 0x20), "overload");
  EXPECT_EQ(mx64Table(Protocol::V2).goal_position.addr, 116);
  EXPECT_EQ(mx64Table(Protocol::V1).present_position.addr, 36);
}
