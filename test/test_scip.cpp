// SCIP 2.0 codec against examples worked by hand from the protocol's rules.
#include <gtest/gtest.h>

#include <tuple>

#include <cmath>

#include "tilt_laser_perception/scip/codec.hpp"

using namespace tilt_laser_perception::scip;

TEST(Scip, ChecksumOfStatusLines) {
  // '0'+'0' = 0x60; & 0x3F = 0x20; + 0x30 = 0x50 'P'.
  EXPECT_EQ(checksum("00"), 'P');
  // '9'+'9' = 0x72; & 0x3F = 0x32; + 0x30 = 0x62 'b'.
  EXPECT_EQ(checksum("99"), 'b');
  EXPECT_EQ(checksum("01"), 'Q');
}

TEST(Scip, EncodeAndDecode) {
  std::string s;
  encode(1234, 2, s);  // 1234 = 19*64 + 18 -> 0x43 'C', 0x42 'B'
  EXPECT_EQ(s, "CB");
  s.clear();
  encode(5432, 3, s);  // 5432 = 1*4096 + 20*64 + 56 -> '1', 'D', 'h'
  EXPECT_EQ(s, "1Dh");
  s.clear();
  encode(0xFFFFFF, 4, s);
  EXPECT_EQ(s, "oooo");
  EXPECT_EQ(decode("CB", 2).value(), 1234u);
  EXPECT_EQ(decode("1Dh", 3).value(), 5432u);
  EXPECT_EQ(decode("0000", 4).value(), 0u);
  EXPECT_FALSE(decode("1 h", 3).has_value());  // ' ' is below 0x30
  EXPECT_FALSE(decode("1p0", 3).has_value());  // 'p' is above 0x6F
}

TEST(Scip, DataLinesAre64CharactersWithSums) {
  std::string data(130, '0');
  std::string out;
  appendDataLines(data, out);
  // 64 + 64 + 2 characters: three lines of text, sum, LF.
  ASSERT_EQ(out.size(), 130u + 3 * 2);
  EXPECT_EQ(out[64], checksum(std::string(64, '0')));
  EXPECT_EQ(out[65], '\n');
  EXPECT_EQ(out.substr(132, 4), std::string("00") + checksum("00") + "\n");
}

TEST(Scip, ParsesScanRequests) {
  ScanRequest r;
  EXPECT_EQ(parseScanRequest("MD0000108001000;tag1", 1080, r), "00");
  EXPECT_EQ(r.command, "MD");
  EXPECT_EQ(r.start_step, 0);
  EXPECT_EQ(r.end_step, 1080);
  EXPECT_EQ(r.cluster, 1);
  EXPECT_EQ(r.skip, 0);
  EXPECT_EQ(r.scans, 0);
  EXPECT_EQ(r.tag, "tag1");
  EXPECT_EQ(r.steps(), 1081);
  EXPECT_EQ(r.line(0), "MD0000108001000;tag1");
  EXPECT_EQ(parseScanRequest("ME0100020003205", 1080, r), "00");
  EXPECT_TRUE(r.intensity());
  EXPECT_EQ(r.cluster, 3);
  EXPECT_EQ(r.skip, 2);
  EXPECT_EQ(r.scans, 5);
  EXPECT_EQ(r.steps(), 34);  // (200 - 100) / 3 + 1
  EXPECT_EQ(parseScanRequest("MDx000108001000", 1080, r), "01");
  EXPECT_EQ(parseScanRequest("MD0000x08001000", 1080, r), "02");
  EXPECT_EQ(parseScanRequest("MD00001080x1000", 1080, r), "03");
  EXPECT_EQ(parseScanRequest("MD0000200001000", 1080, r), "04");
  EXPECT_EQ(parseScanRequest("MD0500010001000", 1080, r), "05");
  EXPECT_EQ(parseScanRequest("MD000010800100x", 1080, r), "07");
  EXPECT_EQ(parseScanRequest("GD0000108001", 1080, r), "00");
  EXPECT_FALSE(r.continuous());
}

TEST(Scip, DecodesAReplyWorkedByHand) {
  // GD of steps 0..2: 1000 mm ("0?X"), error code 1 ("001"), 30000 mm ("7D`").
  // Data sum: 48+63+88+48+48+49+55+68+96 = 563; 563 & 63 = 51; + 48 = 99 'c'.
  // Time stamp 0 ("0000"), sum 4*48 = 192 & 63 = 0 -> '0'.
  const std::string reply = "GD0000000201\n00P\n00000\n0?X0017D`c\n\n";
  ResponseReader reader;
  reader.feed(reply.data(), 10);  // arrives in pieces
  EXPECT_FALSE(reader.next().has_value());
  reader.feed(reply.data() + 10, reply.size() - 10);
  auto r = reader.next();
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->command(), "GD");
  EXPECT_EQ(r->status, "00");
  EXPECT_TRUE(r->status_sum_ok);
  ScanRequest req;
  ASSERT_EQ(parseScanRequest(r->echo, 1080, req), "00");
  ScanData scan;
  ASSERT_EQ(decodeScan(*r, req, scan), DecodeError::None);
  ASSERT_EQ(scan.ranges.size(), 3u);
  EXPECT_EQ(scan.ranges[0], 1000u);
  EXPECT_EQ(scan.ranges[1], 1u);
  EXPECT_EQ(scan.ranges[2], 30000u);
  EXPECT_EQ(scan.timestamp, 0u);
  EXPECT_FLOAT_EQ(rangeToMeters(scan.ranges[0]), 1.0f);
  EXPECT_TRUE(std::isinf(rangeToMeters(scan.ranges[1])) && rangeToMeters(scan.ranges[1]) > 0);

  // The same reply with one sum off by one: a checksum error.
  const std::string bad = "GD0000000201\n00P\n00000\n0?X0017D`d\n\n";
  reader.feed(bad.data(), bad.size());
  r = reader.next();
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(decodeScan(*r, req, scan), DecodeError::Checksum);
  // Missing data: truncated.
  const std::string cut = "GD0000000201\n00P\n00000\n0?X0\xE0\n\n";
  reader.feed(cut.data(), cut.size());
  r = reader.next();
  ASSERT_TRUE(r.has_value());
  EXPECT_NE(decodeScan(*r, req, scan), DecodeError::None);
}

namespace {
/// A reply of `command` (an ND/NE/HD/HE line) around `data`, with time stamp 0.
std::string replyWith(const std::string& command, const std::string& data) {
  std::string r = command + "\n";
  const std::string st = command[0] == 'N' ? "99" : "00";
  r += st + checksum(st) + "\n";
  appendLineWithSum("0000", r);
  appendDataLines(data, r);
  return r + "\n";
}
}  // namespace

TEST(Scip, MultiEchoRepliesGiveEveryEchoOfEveryStep) {
  // 40 steps (ND0000003901...), step i with 1 + i % 3 echoes of 1000 + 10 i +
  // 500 k mm; every further echo after an '&', so that the 64-character lines
  // break at every place within an echo, '&' included.
  std::string data;
  for (int i = 0; i < 40; ++i)
    for (int k = 0; k <= i % 3; ++k) {
      if (k > 0) data.push_back('&');
      encode(1000 + 10 * i + 500 * k, 3, data);
    }
  ASSERT_GT(data.size(), 3u * 64u);
  for (const std::string& cmd : {std::string("ND0000003901000"), std::string("HD0000003901")}) {
    ResponseReader reader;
    const std::string reply = replyWith(cmd, data);
    reader.feed(reply.data(), reply.size());
    auto r = reader.next();
    ASSERT_TRUE(r.has_value());
    ScanRequest req;
    ASSERT_EQ(parseScanRequest(cmd, 1080, req), "00");
    EXPECT_TRUE(req.multiEcho());
    EXPECT_EQ(req.continuous(), cmd[0] == 'N');
    ScanData scan;
    ASSERT_EQ(decodeScan(*r, req, scan), DecodeError::None) << cmd;
    ASSERT_EQ(scan.ranges.size(), 40u);
    ASSERT_EQ(scan.echo_count.size(), 40u);
    for (int i = 0; i < 40; ++i) {
      ASSERT_EQ(scan.echo_count[i], 1 + i % 3) << i;
      EXPECT_EQ(scan.ranges[i], 1000u + 10 * i) << i;  // the first echo
      for (int k = 0; k < scan.echo_count[i]; ++k)
        EXPECT_EQ(scan.echo_ranges[i * kMaxEchoes + k], 1000u + 10 * i + 500 * k) << i << " " << k;
    }
  }
  // With intensities (NE): range, intensity per echo.
  std::string ne;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k <= i; ++k) {
      if (k > 0) ne.push_back('&');
      encode(2000 + 100 * k, 3, ne);
      encode(300 + k, 3, ne);
    }
  {
    ResponseReader reader;
    const std::string reply = replyWith("NE0000000201000", ne);
    reader.feed(reply.data(), reply.size());
    auto r = reader.next();
    ScanRequest req;
    ASSERT_EQ(parseScanRequest("NE0000000201000", 1080, req), "00");
    ScanData scan;
    ASSERT_EQ(decodeScan(*r, req, scan), DecodeError::None);
    EXPECT_EQ(scan.echo_count[2], 3);
    EXPECT_EQ(scan.echo_ranges[2 * kMaxEchoes + 2], 2200u);
    EXPECT_EQ(scan.echo_intensities[2 * kMaxEchoes + 2], 302u);
    EXPECT_EQ(scan.intensities[1], 300u);
  }
  // A fourth echo is no SCIP reply; neither is an echo cut short.
  std::string four;
  for (int k = 0; k < 4; ++k) {
    if (k > 0) four.push_back('&');
    encode(1000, 3, four);
  }
  std::string cut;
  encode(1000, 3, cut);
  cut += "&0";
  for (const auto& [bad, expected] : {std::make_pair(four, DecodeError::BadCharacter),
                                      std::make_pair(cut, DecodeError::Truncated)}) {
    ResponseReader reader;
    const std::string reply = replyWith("ND0000000001000", bad);
    reader.feed(reply.data(), reply.size());
    auto r = reader.next();
    ScanRequest req;
    parseScanRequest("ND0000000001000", 1080, req);
    ScanData scan;
    EXPECT_EQ(decodeScan(*r, req, scan), expected);
  }
}

TEST(Scip, TwoCharacterRangesBeyond4095AreNoObjectNotModulo) {
  // MS/GS send 12 bits: 5000 mm modulo 4096 would read as a valid 904 mm.
  for (const auto& [mm, chars, expected] : {std::make_tuple(5000u, 2, 1u), std::make_tuple(4095u, 2, 4095u),
                                            std::make_tuple(4096u, 2, 1u), std::make_tuple(5000u, 3, 5000u),
                                            std::make_tuple(3u, 2, 3u)}) {
    std::string s;
    encodeRange(mm, chars, s);
    ASSERT_EQ(s.size(), static_cast<std::size_t>(chars));
    EXPECT_EQ(*decode(s.data(), chars), expected) << mm << " in " << chars;
  }
  EXPECT_TRUE(std::isinf(rangeToMeters(1)));  // what the driver makes of it: no return
}

TEST(Scip, Rep117ErrorCodes) {
  EXPECT_TRUE(std::isinf(rangeToMeters(1)) && rangeToMeters(1) > 0);  // no object in range
  EXPECT_TRUE(std::isinf(rangeToMeters(4)) && rangeToMeters(4) < 0);  // too near
  EXPECT_TRUE(std::isinf(rangeToMeters(2)) && rangeToMeters(2) < 0);
  EXPECT_TRUE(std::isnan(rangeToMeters(3)));
  EXPECT_TRUE(std::isnan(rangeToMeters(5)));
  EXPECT_FLOAT_EQ(rangeToMeters(23), 0.023f);
  EXPECT_FLOAT_EQ(rangeToMeters(60000), 60.0f);
  EXPECT_TRUE(std::isinf(rangeToMeters(60001)));
}

TEST(Scip, ParsesInfoLines) {
  Response r;
  r.echo = "PP";
  r.status = "00";
  const auto line = [](const std::string& kv) { return kv + ";" + checksum(kv); };
  r.lines = {line("MODL:UTM-30LX"), line("AMAX:1080"), "AFRT:540;X"};
  int bad = 0;
  const auto info = parseInfo(r, &bad);
  ASSERT_EQ(info.size(), 2u);
  EXPECT_EQ(info[0].first, "MODL");
  EXPECT_EQ(info[0].second, "UTM-30LX");
  EXPECT_EQ(info[1].second, "1080");
  EXPECT_EQ(bad, 1);
}

TEST(Scip, RejectsInfoLinesWithoutAKey) {
  // found by fuzz_scip (test/fuzz/regressions/fuzz_scip): an empty key, and a
  // line whose only colon is its sum character, both with good sums
  Response r;
  const auto line = [](const std::string& kv) { return kv + ";" + checksum(kv); };
  std::string colon_sum;
  for (char c = '0'; c <= 'z'; ++c)
    if (checksum(std::string("FIRM") + c) == ':') colon_sum = std::string("FIRM") + c;
  ASSERT_EQ(checksum(colon_sum), ':');
  r.lines = {line(":1.1.1"), line(colon_sum), line("X:;")};
  int bad = 0;
  const auto info = parseInfo(r, &bad);
  ASSERT_EQ(info.size(), 1u);
  EXPECT_EQ(info[0].first, "X");
  EXPECT_EQ(info[0].second, ";");
  EXPECT_EQ(bad, 2);
}
