/**
 * @file codec.hpp
 * @brief SCIP 2.0 (Hokuyo URG/UTM) encoding, decoding and response framing. ROS-free.
 *
 * Facts used (SCIP 2.0 specification): every reply is the command echo, a
 * status line ("00" + sum), data lines (each followed by its sum character)
 * and an empty line. The sum of a line is the low 6 bits of the byte sum of
 * its data, plus 0x30. Numbers are sent in 2, 3 or 4 characters of 6 bits,
 * each character = value + 0x30. Scan data is cut into lines of 64 characters.
 *
 * Multi-echo (the UTM-30LX-EW's ND, NE, HD, HE): the data of a step is its
 * first echo (range, and intensity for NE/HE, 3 characters each), then '&'
 * and the next echo's value(s) for every further echo, up to three echoes a
 * step; the '&' are part of the data stream and may fall anywhere in its
 * 64-character lines. ND/NE stream like MD/ME, HD/HE answer once like GD/GE.
 */
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace tilt_laser_perception {
namespace scip {

/// Sum character of a line: ((byte sum) & 0x3F) + 0x30.
char checksum(const char* begin, const char* end);
inline char checksum(const std::string& s) { return checksum(s.data(), s.data() + s.size()); }

/// Appends `value` encoded in `chars` characters (2, 3 or 4) of 6 bits each, most significant first.
void encode(std::uint32_t value, int chars, std::string& out);
/// Appends a range [mm] (or an error code below 23) in `chars` characters. Two
/// characters (MS, GS) hold 12 bits: a range beyond 4095 mm cannot be sent and
/// goes as error code 1 ("no object in the range", the UTM-30LX's code for a
/// return beyond what the reply can report), never modulo 4096.
void encodeRange(std::uint32_t mm, int chars, std::string& out);

/// At most this many echoes per step in a multi-echo reply.
constexpr int kMaxEchoes = 3;

/// Which echo of a step becomes its one range.
enum class EchoChoice { First, Last, Strongest };
/// "first", "last", "strongest"; false for anything else.
bool parseEchoChoice(const std::string& name, EchoChoice& out);
/// The index of the chosen echo among `count` (>= 1); `intensities` may be
/// null (then Strongest is First).
template <typename T>
int chooseEcho(EchoChoice c, int count, const T* intensities) {
  if (count <= 1 || c == EchoChoice::First) return 0;
  if (c == EchoChoice::Last || !intensities) return c == EchoChoice::Last ? count - 1 : 0;
  int best = 0;
  for (int k = 1; k < count; ++k)
    if (intensities[k] > intensities[best]) best = k;
  return best;
}
/// Decodes `chars` characters; nullopt if any character is outside 0x30..0x6F.
std::optional<std::uint32_t> decode(const char* p, int chars);

/// Appends `data` as SCIP data lines: 64 characters, sum, LF each; the last line shorter.
void appendDataLines(const std::string& data, std::string& out);
/// Appends one line: text, its sum, LF.
void appendLineWithSum(const std::string& text, std::string& out);

/// A complete reply: echo, status and the data lines (without their LFs).
struct Response {
  std::string echo;                 ///< the command as echoed
  std::string status;               ///< two characters, e.g. "00" or "99"
  bool status_sum_ok = false;       ///< the status line's sum matched
  std::vector<std::string> lines;   ///< data lines, each still ending with its sum character
  /// The command symbol: the echo's first two characters ("MD", "VV", ...).
  std::string command() const { return echo.substr(0, 2); }
};

/// Splits a byte stream into replies (each ends with an empty line). Feed bytes as they arrive.
class ResponseReader {
 public:
  /// Appends received bytes.
  void feed(const char* data, std::size_t size) { buffer_.append(data, size); }
  /// Next complete reply, if one has arrived.
  std::optional<Response> next();
  /// Bytes waiting for the rest of a reply.
  std::size_t pending() const { return buffer_.size(); }
  void clear() { buffer_.clear(); }

 private:
  std::string buffer_;
};

/// Joins data lines after checking each line's sum; nullopt (and the index of
/// the first bad line in *bad_line) if one does not match.
std::optional<std::string> joinDataLines(const std::vector<std::string>& lines, std::size_t first,
                                         std::size_t* bad_line = nullptr);

/// Parameters of MD/MS/ME/GD/GS/GE commands.
struct ScanRequest {
  std::string command;       ///< "MD", "MS", "ME", "GD", "GS", "GE"
  int start_step = 0;
  int end_step = 0;
  int cluster = 1;           ///< 0 is taken as 1
  int skip = 0;              ///< scan interval (MD/MS/ME)
  int scans = 0;             ///< number of scans; 0 = until QT (MD/MS/ME)
  std::string tag;           ///< string characters after ';'
  bool continuous() const { return command[0] == 'M' || command[0] == 'N'; }
  bool intensity() const { return command[1] == 'E'; }
  /// ND, NE, HD, HE: up to kMaxEchoes echoes per step.
  bool multiEcho() const { return command[0] == 'N' || command[0] == 'H'; }
  int encoding() const { return command[1] == 'S' ? 2 : 3; }
  /// Number of values per scan.
  int steps() const { int c = cluster < 1 ? 1 : cluster; return (end_step - start_step) / c + 1; }
  /// The command line (without LF), with `remaining` in place of the number of scans.
  std::string line(int remaining) const;
};

/// Parses a scan command (MD MS ME GD GS GE ND NE HD HE); returns its status ("00", or the error status of the
/// specification: "01" start, "02" end, "03" cluster, "04" end out of range,
/// "05" end before start, "06" skip, "07" scan count non-numeric).
std::string parseScanRequest(const std::string& line, int max_step, ScanRequest& out);

/// A decoded scan reply.
struct ScanData {
  std::uint32_t timestamp = 0;          ///< sensor time of step 0 [ms], 24 bits
  std::vector<std::uint32_t> ranges;    ///< [mm] or error codes; the first echo of a multi-echo reply
  std::vector<std::uint32_t> intensities;
  /// Multi-echo replies only: echoes per step (1..kMaxEchoes), and every echo's
  /// range and intensity at [step * kMaxEchoes + echo] (0 where a step has fewer).
  std::vector<std::uint8_t> echo_count;
  std::vector<std::uint32_t> echo_ranges, echo_intensities;
  int remaining = -1;                   ///< scans left (MD/ME echo), -1 for GD/GE
};

/// Why a scan reply could not be decoded.
enum class DecodeError { None, Status, Checksum, Truncated, BadCharacter };
const char* decodeErrorName(DecodeError e);

/// Decodes the data of a scan reply (status "99" for MD/ME, "00" for GD/GE).
DecodeError decodeScan(const Response& r, const ScanRequest& request, ScanData& out);

/// UTM-30LX range error codes (values below 23 mm) mapped to REP 117:
/// +inf no return (1), -inf too near (2, 4), NaN measurement errors (3, 5, others).
float rangeToMeters(std::uint32_t mm, std::uint32_t min_mm = 23, std::uint32_t max_mm = 60000);

/// "KEY:value" fields of a VV/PP/II reply (sums checked; bad lines skipped and counted).
std::vector<std::pair<std::string, std::string>> parseInfo(const Response& r, int* bad_lines = nullptr);

}  // namespace scip
}  // namespace tilt_laser_perception
