// The Pride ES motor controller's link: 38400 baud, 8 data bits, even parity, 1 stop bit (8E1), LSB first,
// 3.3 V, on ONE wire that the VCU (us) and the controller both drive. Each side sends a frame every 5 ms.
//
// What is known and what is inferred (docs/protocol.md, Pride ES):
//  - known from the manual: the headers (FE 54 from the VCU, 4A 01 from the controller), the field names and
//    ranges (SP 0x00..0x0E, FB and LR signed -100..+100, EB 0x02 ready / 0x82 error), and the checksum rule
//    (bitwise NOT of the sum of all preceding bytes as signed chars; signedness does not change the low 8 bits,
//    so a valid frame's 8-bit byte sum is 0xFF);
//  - INFERRED: the byte order of the fields and the frame length (6). The manual's frame diagrams were lost.
//    The layout lives in one table (kFormats) below; check_layout() tests it against a raw capture;
//  - UNKNOWN: the power-on procedure (the manual's section is empty), what BC and UN mean, EB values other
//    than 0x02 and 0x82. Nothing here sends anything at power-on.
//
//   VCU -> controller:   FE 54 SP FB LR CS
//   controller -> VCU:   4A 01 EB BC UN CS
//
// Everything is allocation-free and O(1) per byte, except check_layout(), which is O(n) over a capture.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <variant>

#include "saulproto/core/result.hpp"
#include "saulproto/core/stream_framer.hpp"

namespace saul::pride {

inline constexpr std::uint32_t kBaudRate = 38400;  ///< 8E1: 11 bits per byte, so ~3491 bytes/s, ~17 per 5 ms
inline constexpr std::uint32_t kFramePeriodUs = 5000;

enum class Direction : std::uint8_t {
  vcu_to_controller = 0,  ///< VcuCommand
  controller_to_vcu = 1,  ///< ControllerStatus
};

/// One row of THE layout table. The frame is header[0], header[1], payload bytes in field order, checksum.
struct FrameFormat {
  Direction direction;
  const char* name;                      ///< kName of the message struct
  std::array<std::uint8_t, 2> header;    ///< known (manual)
  std::uint8_t size;                     ///< whole frame, header and checksum included: INFERRED
  std::array<const char*, 3> fields;     ///< payload bytes in wire order: INFERRED order
};

inline constexpr std::size_t kHeaderSize = 2;
inline constexpr std::size_t kPayloadSize = 3;
inline constexpr std::size_t kFrameSize = kHeaderSize + kPayloadSize + 1;  ///< 6: INFERRED

/// THE layout. Indexed by Direction. If a capture shows a different layout, change it here (and the message
/// structs below, whose fields follow this order), and nowhere else.
inline constexpr std::array<FrameFormat, 2> kFormats{{
    {Direction::vcu_to_controller, "vcu_command", {0xFE, 0x54}, kFrameSize,
     {"speed_level", "forward_back", "left_right"}},
    {Direction::controller_to_vcu, "controller_status", {0x4A, 0x01}, kFrameSize,
     {"error_byte", "battery_charge", "unknown"}},
}};

constexpr const FrameFormat& format_of(Direction d) noexcept { return kFormats[static_cast<std::size_t>(d)]; }

/// VCU -> controller, every 5 ms. speed_level is the speed setting (0 slowest .. 0x0E fastest); forward_back
/// is + forward, - backward; left_right is + right, - left (the manual's sign convention, opposite to REP-103).
struct VcuCommand {
  static constexpr Direction kDirection = Direction::vcu_to_controller;
  static constexpr const char* kName = "vcu_command";
  static constexpr std::uint8_t kMaxSpeedLevel = 0x0E;
  static constexpr std::int8_t kMaxStick = 100;  ///< forward_back and left_right are -100..+100
  std::uint8_t speed_level = 0;
  std::int8_t forward_back = 0;
  std::int8_t left_right = 0;
  /// Whether every field is inside the manual's range.
  [[nodiscard]] constexpr bool in_range() const noexcept {
    return speed_level <= kMaxSpeedLevel && forward_back >= -kMaxStick && forward_back <= kMaxStick &&
           left_right >= -kMaxStick && left_right <= kMaxStick;
  }
  template <class V> constexpr void fields(V&& v) const {
    v("speed_level", speed_level); v("forward_back", forward_back); v("left_right", left_right);
  }
  constexpr bool operator==(const VcuCommand&) const = default;
};

/// Controller -> VCU, every 5 ms. Only 0x02 (ready) and 0x82 (error) of error_byte are documented; the VCU
/// must treat anything but ready() as "do not drive". battery_charge's scale and unknown's meaning are unknown.
struct ControllerStatus {
  static constexpr Direction kDirection = Direction::controller_to_vcu;
  static constexpr const char* kName = "controller_status";
  static constexpr std::uint8_t kReady = 0x02;
  static constexpr std::uint8_t kError = 0x82;
  std::uint8_t error_byte = 0;
  std::uint8_t battery_charge = 0;
  std::uint8_t unknown = 0;
  [[nodiscard]] constexpr bool ready() const noexcept { return error_byte == kReady; }
  [[nodiscard]] constexpr bool error() const noexcept { return error_byte == kError; }
  /// Whether error_byte is one of the two documented values.
  [[nodiscard]] constexpr bool known_error_byte() const noexcept { return ready() || error(); }
  /// All byte values are accepted: the manual gives no range for BC and UN, and undocumented EB values are
  /// reported to the caller (who must not drive on them) rather than hidden.
  [[nodiscard]] constexpr bool in_range() const noexcept { return true; }
  template <class V> constexpr void fields(V&& v) const {
    v("error_byte", error_byte); v("battery_charge", battery_charge); v("unknown", unknown);
  }
  constexpr bool operator==(const ControllerStatus&) const = default;
};

using Message = std::variant<VcuCommand, ControllerStatus>;

Direction direction_of(const Message& message) noexcept;
const char* name_of(const Message& message) noexcept;

/// Encodes one frame into out (kFrameSize bytes). Fails with out_of_range if a field is outside its range
/// (nothing is clamped) or buffer_too_small. Returns the number of bytes written. O(1).
Result<std::size_t> encode(const VcuCommand& message, std::span<std::uint8_t> out) noexcept;
Result<std::size_t> encode(const ControllerStatus& message, std::span<std::uint8_t> out) noexcept;
Result<std::size_t> encode(const Message& message, std::span<std::uint8_t> out) noexcept;

/// Decodes exactly one whole frame. Fails with bad_length (not kFrameSize bytes), unknown_type (no known
/// header), bad_crc, or out_of_range (checksum fine, a field outside the manual's range). O(1).
Result<Message> decode_frame(std::span<const std::uint8_t> frame) noexcept;

/// What the stream decoder has seen since construction or reset(). Every input byte ends up either in a
/// frame (frames x kFrameSize), in bytes_skipped, or still pending inside the decoder.
struct Counters {
  std::uint32_t frames = 0;           ///< valid frames returned (both directions)
  std::uint32_t checksum_errors = 0;  ///< candidates with a header whose checksum did not match
  std::uint32_t out_of_range = 0;     ///< candidates with a good checksum but a field outside its range
  std::uint32_t bytes_skipped = 0;    ///< bytes that belonged to no valid frame
  constexpr bool operator==(const Counters&) const = default;
};

/// Streaming decoder for both directions (a VCU hears both on the wire; a sniffer sees both too). Feed bytes
/// one at a time with push().
///
/// Resync rule (framing::StreamFramer, as the inter-board UART): after any rejection (second header byte wrong,
/// bad checksum, out-of-range field) the search for a header resumes at the byte right after the rejected header
/// start, so a real frame that began inside a false candidate is never lost. A candidate is at most kFrameSize
/// bytes, so push() does O(kFrameSize^2) work in the worst case, O(1) amortised; it never allocates, and one
/// push() completes at most one frame. 7 bytes of state besides the counters. Not thread-safe.
class StreamDecoder {
 public:
  /// Feeds one byte; returns a message when this byte completed a valid frame.
  std::optional<Message> push(std::uint8_t byte) noexcept;

  /// Feeds many bytes, calling on_message(const Message&) for each frame found. O(n).
  template <class F>
  void push(std::span<const std::uint8_t> input, F&& on_message) noexcept {
    for (std::uint8_t b : input)
      if (auto m = push(b)) on_message(*m);
  }

  [[nodiscard]] const Counters& counters() const noexcept { return rules_.counters; }
  /// Bytes held in a frame that has started but not ended.
  [[nodiscard]] std::size_t pending() const noexcept { return framer_.pending(); }
  /// Forgets a partial frame (counted as skipped) and keeps the counters. Call it when the line was idle for
  /// longer than a frame takes (~1.7 ms), since frames are sent back to back.
  void drop_partial() noexcept;
  /// Forgets everything, counters included.
  void reset() noexcept { *this = StreamDecoder{}; }

 private:
  // Either header, then checksum and ranges of a whole frame.
  struct Rules : framing::CountedRules<Counters> {
    framing::Verdict check(std::span<const std::uint8_t> candidate) noexcept;
  };
  framing::StreamFramer<kFrameSize> framer_;
  Rules rules_;
};

/// Echo filter for a VCU on the one wire: every byte it transmits comes back on its own receiver. Tell the
/// filter what was sent (sent()), pass every received byte through push(); it drops exactly the sent bytes,
/// in order, and passes everything else on.
///
/// Rule: while an echo is expected, a received byte equal to the next expected byte is dropped. A byte that
/// differs is passed on, counted as a mismatch, and the rest of the expected echo is forgotten (counted as
/// lost): on one wire each sent byte comes back at once, so a different byte means the echo was garbled by a
/// collision or is not coming, and guessing a realignment could eat the controller's bytes. Garbled echo
/// pieces that then reach the decoder fail its checksum. Call clear() if no echo arrived within a few byte
/// times after the transmission ended (hardware that does not echo).
///
/// kCapacity bytes of ring buffer (a VCU sends 6 bytes per 5 ms and the echo returns within ~2 ms); sent()
/// refuses what does not fit. O(1) per byte, no allocation.
class EchoFilter {
 public:
  static constexpr std::size_t kCapacity = 32;

  struct Counters {
    std::uint32_t echoes_dropped = 0;  ///< received bytes dropped as our own echo
    std::uint32_t mismatches = 0;      ///< received bytes that differed from the expected echo byte
    std::uint32_t lost = 0;            ///< expected echo bytes forgotten after a mismatch or clear()
    std::uint32_t overflows = 0;       ///< sent bytes refused because the buffer was full
    constexpr bool operator==(const Counters&) const = default;
  };

  /// Records bytes just transmitted. All or nothing: returns false (and counts overflows) when they do not
  /// fit next to the echo still expected.
  bool sent(std::span<const std::uint8_t> bytes) noexcept;

  /// Takes one received byte; returns it unless it was our own echo.
  std::optional<std::uint8_t> push(std::uint8_t byte) noexcept;

  /// Forgets the expected echo (counted as lost).
  void clear() noexcept;

  /// Echo bytes still expected.
  [[nodiscard]] std::size_t expected() const noexcept { return count_; }
  [[nodiscard]] const Counters& counters() const noexcept { return counters_; }

 private:
  std::uint8_t ring_[kCapacity]{};
  std::uint8_t head_ = 0;   // index of the next expected byte
  std::uint8_t count_ = 0;  // bytes expected
  Counters counters_{};
};

// ---- layout check -------------------------------------------------------------------------------------------

inline constexpr std::size_t kMinCandidateLength = 4;
inline constexpr std::size_t kMaxCandidateLength = 12;
inline constexpr std::size_t kCandidateLengths = kMaxCandidateLength - kMinCandidateLength + 1;
/// Spacings between consecutive headers up to this many bytes are tallied; longer ones only counted.
inline constexpr std::size_t kMaxTalliedSpacing = 64;

/// What a raw capture says about one header.
struct HeaderReport {
  std::array<std::uint8_t, 2> header{};
  std::uint32_t positions = 0;           ///< offsets where the two header bytes occur
  std::uint32_t spacing = 0;             ///< most common distance in bytes between consecutive positions (0: none)
  std::uint32_t spacing_count = 0;       ///< how many consecutive pairs had that distance
  std::uint32_t long_spacings = 0;       ///< distances above kMaxTalliedSpacing
  /// checksum_hits[i]: positions where the kMinCandidateLength + i bytes from the header on sum to 0xFF, i.e.
  /// a frame of that length would pass the checksum. Candidates running past the end are not counted.
  std::array<std::uint32_t, kCandidateLengths> checksum_hits{};
  std::uint8_t best_length = 0;          ///< candidate length with the most hits (0 when no hits)
  constexpr bool operator==(const HeaderReport&) const = default;
};

struct LayoutReport {
  std::uint32_t bytes = 0;                ///< capture length analysed
  std::array<HeaderReport, 2> headers{};  ///< indexed by Direction
  constexpr bool operator==(const LayoutReport&) const = default;
};

/// Checks the inferred layout against a raw byte capture of the wire (both directions, or one): for each header,
/// where it occurs, how far apart, and for every candidate length 4..12 how many candidate frames pass the
/// checksum. On the real layout, hits at the true length are close to positions; at any other length only
/// chance hits (about 1 in 256) remain. O(n x kCandidateLengths) time, ~300 bytes of stack, no allocation.
LayoutReport check_layout(std::span<const std::uint8_t> capture) noexcept;

/// Checksum hits of one candidate length (0 for a length outside kMinCandidateLength..kMaxCandidateLength).
constexpr std::uint32_t hits_at(const HeaderReport& report, std::size_t length) noexcept {
  return (length < kMinCandidateLength || length > kMaxCandidateLength)
             ? 0
             : report.checksum_hits[length - kMinCandidateLength];
}

}  // namespace saul::pride
