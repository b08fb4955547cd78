// libFuzzer: arbitrary bytes from the servo's bus through the Dynamixel status
// packet parser, protocol 1.0 and 2.0 (what the bus reads back), and the
// instruction parser (what the emulated servo reads).
#include "fuzz_input.hpp"
#include "tilt_laser_perception/dynamixel/protocol.hpp"

using namespace tilt_laser_perception::dynamixel;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  for (Protocol p : {Protocol::V1, Protocol::V2})
    for (bool status : {true, false}) {
      PacketParser parser(p, status);
      const std::size_t cut = size ? data[0] % size : 0;
      parser.feed(data, cut);
      Packet pkt;
      std::size_t packets = 0;
      while (parser.next(pkt)) ++packets;
      parser.feed(data + cut, size - cut);
      while (parser.next(pkt)) {
        ++packets;
        TLP_FUZZ_CHECK(pkt.params.size() < size);
        (void)hardwareErrorNames(p, pkt.error);
        // a parsed packet, written again, parses to the same packet
        const auto again = status ? statusPacket(p, pkt.id, pkt.error, pkt.params)
                                  : instructionPacket(p, pkt.id, pkt.instruction, pkt.params);
        PacketParser check(p, status);
        check.feed(again.data(), again.size());
        Packet back;
        TLP_FUZZ_CHECK(check.next(back));
        TLP_FUZZ_CHECK(back.id == pkt.id && back.error == pkt.error && back.params == pkt.params);
      }
      TLP_FUZZ_CHECK(packets <= size);
      TLP_FUZZ_CHECK(parser.pending() <= size);
    }
  (void)statusErrorName2(size ? data[0] : 0);
  return 0;
}
