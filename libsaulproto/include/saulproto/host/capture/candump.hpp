// can-utils candump log lines, "(1700000000.000000) can0 300#E8030CFE", as `candump -L` prints, `candump -l` writes
// and canplayer reads them (syntax and choices: docs/captures.md "candump"). CAN FD lines ("##") are reported as
// unsupported: the robot's bus is classic CAN.
//
// CandumpReader is the one reader: large reads into one buffer, lines scanned in place, frames handed out in
// batches, from a file descriptor, a range of a regular file, text in memory or a stream. Memory is one buffer
// (block size + kMaxCandumpLine), whatever the file size: a longer line is reported as corrupt and skipped. A file
// can be read in ranges that start at line starts (split_candump_blocks), each by a scanner of its own.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <istream>
#include <memory>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/capture.hpp"

namespace saul::host {

struct CandumpLine {
  CanFrame frame;          ///< timestamp_ns always set
  std::string_view interface;  ///< points into the parsed line
};

/// Why a line did not parse: column (0-based) and message (the reader fills the line number).
using CandumpError = CaptureError;

/// Parses one line (without its newline). On failure returns false and fills error.
bool parse_candump_line(std::string_view line, CandumpLine& out, CandumpError& error);

/// An interface name as one candump word: "" is "can0", white space and control characters become '_' (a pcapng
/// if_name such as text2pcap's "Fake IF, text2pcap" would otherwise split the line).
std::string candump_interface(std::string_view interface);

/// One frame as a log line without newline, "(sec.usec) iface ID#DATA" (iface as candump_interface() writes it),
/// in microseconds as `candump -l` writes; a frame without a timestamp gets 0.
std::string format_candump_line(const CanFrame& frame, std::string_view interface);

/// The compact frame text alone, e.g. "300#E8030CFE", "00000344#000005DC", "123#R4".
std::string format_candump_frame(const CanFrame& frame);
/// The longest compact frame text: 8 id digits, '#' and 16 data digits.
inline constexpr std::size_t kCandumpFrameMax = 25;
/// format_candump_frame() written at `w` (room for kCandumpFrameMax chars), its end returned; `data_only`: only
/// what follows the '#' (decode's CSV data column).
char* write_candump_frame(char* w, const CanFrame& frame, bool data_only = false);

/// The longest candump line the scanner accepts (a real one is under 100 bytes).
inline constexpr std::size_t kMaxCandumpLine = 64 * 1024;

/// Takes whole candump lines before the scanner parses them (stats handles the usual lines cheaper than a CanFrame
/// each). kCandumpLineSlack bytes (of no meaning) follow `end`, so a taker may read whole words.
inline constexpr std::size_t kCandumpLineSlack = 64;
class CandumpLineTaker {
 public:
  /// Takes the whole lines at the start of [begin, end), in file order, up to the first it does not take (which the
  /// scanner then reads the usual way, as it does a last line without newline): returns how many it took, `used`
  /// the bytes they span. A call per line would cost as much as stats' own work on a line.
  virtual std::size_t take_run(const char* begin, const char* end, std::size_t& used) = 0;

 protected:
  ~CandumpLineTaker() = default;
};

/// The usual shape of a line, "(SEC.FRAC) IFACE ID#DATA" (single spaces, an 11- or 29-bit data frame), in one pass:
/// its frame and interface (a view into `line`). False for any other shape, which parse_candump_line reads; for the
/// lines it accepts both give the same frame.
bool parse_candump_usual(std::string_view line, CanFrame& frame, std::string_view& interface) noexcept;
namespace detail {
// A candump line's text read a word at a time (stats' line tables): words loaded from memory on a little-endian
// machine, the first byte the lowest, as eight_digits() below.
inline constexpr std::uint64_t kByteOnes = 0x0101010101010101ULL, kByteHighs = 0x8080808080808080ULL;
/// Where the first byte `c` is in `words`, or 8 * N.
template <std::size_t N>
std::size_t first_byte(const std::uint64_t (&words)[N], char c) noexcept {
  for (std::size_t i = 0; i < N; ++i) {
    const std::uint64_t x = words[i] ^ (kByteOnes * static_cast<unsigned char>(c));
    // a zero byte of x sets its high bit here; a byte above a zero byte may too, but never one below it
    const std::uint64_t zero = (x - kByteOnes) & ~x & kByteHighs;
    if (zero != 0) return 8 * i + static_cast<std::size_t>(std::countr_zero(zero)) / 8;
  }
  return 8 * N;
}
/// Where the first `a` and the first `b` are in the 40 bytes at `p` (40 for one not there), as first_byte() on those
/// bytes as words (40 bytes are read). stats finds a candump line's end and its '#' with it.
struct TwoPlaces {
  std::size_t a, b;
};
inline TwoPlaces first_two(const char* p, char a, char b) noexcept {
  std::uint64_t words[5];
  std::memcpy(words, p, sizeof words);
  return {first_byte(words, a), first_byte(words, b)};
}
/// The word's first `n` bytes (n <= 8), zeros after them.
inline std::uint64_t first_bytes(std::uint64_t word, std::size_t n) noexcept {
  return n >= 8 ? word : word & ((std::uint64_t{1} << (8 * n)) - 1);
}
/// Eight hex digits (either case) in a word as four bytes, the first two digits the lowest byte; false when one of
/// them is not a hex digit. Each test adds to every byte at once: the bytes are below 0x80, so no sum carries into
/// the next byte.
inline bool hex_word(std::uint64_t v, std::uint32_t& bytes) noexcept {
  if ((v & kByteHighs) != 0) return false;  // (the ranges below refuse such bytes too, but only with carries)
  auto at_least = [v](unsigned c) { return (v + kByteOnes * (0x80 - c)) & kByteHighs; };  // bytes >= c
  const std::uint64_t digit = at_least('0') & ~at_least('9' + 1);
  const std::uint64_t letter = (at_least('A') & ~at_least('F' + 1)) | (at_least('a') & ~at_least('f' + 1));
  if ((digit | letter) != kByteHighs) return false;
  const std::uint64_t nibbles = (v & (kByteOnes * 0x0F)) + (letter >> 7) * 9;  // 'A' and 'a' are 0x?1: 1 + 9
  std::uint64_t t = ((nibbles << 4) | (nibbles >> 8)) & 0x00FF00FF00FF00FFULL;  // a byte per digit pair
  t = (t | (t >> 8)) & 0x0000FFFF0000FFFFULL;
  t = (t | (t >> 16)) & 0xFFFFFFFFULL;
  bytes = static_cast<std::uint32_t>(t);
  return true;
}
/// `digits` (even, <= 16) hex digits at `p` (16 bytes may be read) as bytes, the first the lowest byte; false when
/// one is not a hex digit.
inline bool hex_bytes(const char* p, std::size_t digits, std::uint64_t& data) noexcept {
  std::uint64_t w[2];
  std::memcpy(w, p, sizeof w);
  std::uint32_t low = 0, high = 0;
  for (std::size_t i = 0; i < 2; ++i) {  // digits past the last become '0'
    const std::uint64_t keep = first_bytes(~std::uint64_t{0}, digits > 8 * i ? digits - 8 * i : 0);
    w[i] = (w[i] & keep) | (kByteOnes * '0' & ~keep);
  }
  if (!hex_word(w[0], low) || !hex_word(w[1], high)) return false;
  data = std::uint64_t{high} << 32 | low;
  return true;
}
/// Eight ASCII digits in a word read from memory on a little-endian machine (the first digit the lowest byte) as a
/// number, in a few word operations; false when one of them is not a digit.
inline bool eight_digits(std::uint64_t v, std::uint64_t& value) noexcept {
  // every byte 0x30..0x39: its high nibble is 3, and still 3 after adding 6 (a carry out of a byte only happens
  // for bytes >= 0xFA, which the first test already refuses)
  constexpr std::uint64_t kHigh = 0xF0F0F0F0F0F0F0F0ULL, kZeros = 0x3030303030303030ULL;
  if ((v & kHigh) != kZeros || ((v + 0x0606060606060606ULL) & kHigh) != kZeros) return false;
  v -= kZeros;            // bytes d0 (lowest) .. d7
  v = v * 10 + (v >> 8);  // byte 2k: 10 d(2k) + d(2k+1)
  v = (((v & 0x000000FF000000FFULL) * (100 + (1000000ULL << 32))) +
       (((v >> 16) & 0x000000FF000000FFULL) * (1 + (10000ULL << 32)))) >> 32;
  value = v;
  return true;
}
}  // namespace detail

/// Where the text after the time starts in a line of candump_fixed_time's shape.
inline constexpr std::size_t kCandumpFixedTimeLength = 20;
/// The fraction of a line of candump_fixed_time's shape, its 6 digits then ") " at line[12..19], in ns; false when
/// it is not of that shape.
inline bool candump_fixed_fraction(const char* line, std::uint64_t& ns) noexcept {
  if (line[18] != ')' || line[19] != ' ') return false;
  std::uint64_t fraction;
  std::memcpy(&fraction, line + 12, 8);  // 6 digits and ") ", which become "00": the fraction times 100
  fraction = (fraction & 0x0000FFFFFFFFFFFFULL) | 0x3030000000000000ULL;
  if (!detail::eight_digits(fraction, fraction)) return false;
  ns = fraction * 10;
  return true;
}
/// The time of candump -L's own shape, "(" 10 digits "." 6 digits ") " (so what follows starts at line[20]), in
/// ns; false for any other shape. Inline: stats reads it for every line.
inline bool candump_fixed_time(std::string_view line, std::uint64_t& ns) noexcept {
  if constexpr (std::endian::native != std::endian::little) return false;  // read digit by digit then
  const char* p = line.data();
  if (line.size() < 24 || p[11] != '.') return false;
  const unsigned d9 = static_cast<unsigned>(p[9] - '0'), d10 = static_cast<unsigned>(p[10] - '0');
  std::uint64_t high, fraction;
  std::memcpy(&high, p + 1, 8);
  if (d9 >= 10 || d10 >= 10 || !detail::eight_digits(high, high) || !candump_fixed_fraction(p, fraction)) return false;
  ns = (high * 100 + d9 * 10 + d10) * 1'000'000'000ULL + fraction;
  return true;
}
/// candump_fixed_time() of lines in file order, the seconds remembered by their text: a log's lines share them for
/// a second's worth of lines, so that most lines cost their fraction's digits alone (stats reads every line's time).
class CandumpFixedTimes {
 public:
  bool read(std::string_view line, std::uint64_t& ns) noexcept {
    if (line.size() < 24) return false;
    std::uint64_t head;   // "(" and the first 7 digits
    std::uint32_t tail;   // the last 3 digits and "."
    std::memcpy(&head, line.data(), sizeof head);
    std::memcpy(&tail, line.data() + 8, sizeof tail);
    if (head == head_ && tail == tail_) {
      std::uint64_t fraction;
      if (!candump_fixed_fraction(line.data(), fraction)) return false;
      ns = seconds_ns_ + fraction;
      return true;
    }
    if (!candump_fixed_time(line, ns)) return false;
    head_ = head;  // only a text that read as seconds: the same text again reads the same
    tail_ = tail;
    seconds_ns_ = ns - ns % 1'000'000'000ULL;
    return true;
  }

 private:
  std::uint64_t head_ = 0;  // no line's: a line starts with '('
  std::uint32_t tail_ = 0;
  std::uint64_t seconds_ns_ = 0;
};

class CandumpReader final : public CaptureReader {
 public:
  /// Reads `fd` (not owned, not closed) from its current position to its end with read(2) as its bytes come: files
  /// and pipes (a pipe from `candump -L` is decoded line by line).
  explicit CandumpReader(int fd, std::size_t block_bytes = kDefaultBlock);
  /// Reads the byte range [begin, end) of a regular file with pread(2) (begin a line start, e.g. from
  /// split_candump_blocks). Line numbers count from the range's first line.
  CandumpReader(int fd, std::uint64_t begin, std::uint64_t end, std::size_t block_bytes = kDefaultBlock);
  /// Reads `text` (kept alive by the caller; a block of lines cut from a stream, CaptureTextBlocks).
  explicit CandumpReader(std::string_view text, std::size_t block_bytes = kDefaultBlock);
  /// Reads `in` (kept alive by the caller: a compressed file's content) to its end.
  explicit CandumpReader(std::istream& in, std::size_t block_bytes = std::size_t{256} << 10);

  /// Fills `batch` (cleared first) with the lines of up to one block (at most FrameBatch::kMax frames); false
  /// (batch empty) at the end. Throws std::runtime_error when reading fails.
  bool next_batch(FrameBatch& batch) override { return next_batch(batch, nullptr); }
  /// The same with the lines `taker` takes left out; in file order with them, a batch ends at the first frame or
  /// corrupt line the taker did not take (false at the end, when the taker may have taken everything).
  bool next_batch(FrameBatch& batch, CandumpLineTaker* taker);
  /// Lines seen so far (comments and corrupt lines included).
  [[nodiscard]] std::uint64_t lines() const noexcept { return line_; }
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::candump; }
  /// Bytes read so far (from the range's start).
  [[nodiscard]] std::uint64_t bytes_read() const noexcept override { return consumed_; }
  /// The first 256 bytes of the first line that was neither blank nor a candump line (a comment), "" when none:
  /// what a file that yields no frame looks like.
  [[nodiscard]] const std::string& first_other() const noexcept { return first_other_; }

  static constexpr std::size_t kDefaultBlock = std::size_t{1} << 20;

 private:
  void line(std::string_view text, FrameBatch& batch);
  /// A corrupt record at the current line.
  void corrupt(FrameBatch& batch, std::size_t column, std::string message);
  std::size_t fill(char* dst, std::size_t n);
  void allocate(std::size_t block_bytes);

  int fd_ = -1;
  bool positional_ = false;
  std::string_view text_;  // what is left of the text read from memory (fd_ < 0, no in_)
  std::istream* in_ = nullptr;
  std::uint64_t offset_ = 0;  // next pread position
  std::uint64_t end_ = 0;
  std::unique_ptr<char[]> buf_;
  std::size_t cap_;
  std::size_t block_;
  std::size_t head_ = 0, tail_ = 0;
  bool eof_ = false;
  bool skipping_ = false;  // inside an over-long line: drop bytes up to its newline
  std::uint64_t line_ = 0;
  std::uint64_t consumed_ = 0;
  std::string first_other_;
};

/// The starts of ranges of about `block` bytes (never empty) that cut [0, size) of a regular file at line starts:
/// 0, ..., then `size`. Reads only near the cuts. Throws std::runtime_error when reading fails.
std::vector<std::uint64_t> split_candump_blocks(int fd, std::uint64_t size, std::uint64_t block);

/// Writes `candump -l` lines (format_candump_line, LF), which canplayer replays.
class CandumpWriter final : public StreamCaptureWriter {
 public:
  explicit CandumpWriter(std::ostream& out) : StreamCaptureWriter(out, "candump") {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::candump; }

 private:
  void put(const CanFrame& frame, std::string_view interface) override;
};

}  // namespace saul::host
