// The inter-board UART between the IO and BALANCE boards (460800 8N1).
//
// Frame: [0xAA][LEN][TYPE][PAYLOAD x LEN][CRC8]
//   LEN   payload length, not covered by the CRC, so it is checked against the fixed length of TYPE;
//   CRC8  CRC-8/MAXIM over TYPE and PAYLOAD.
// Payload integers are little-endian. Each TYPE has one fixed payload length (kPayloadLength).
//
// The StreamDecoder is what both boards run in their UART receive path and what saulctl runs on captures:
// one byte in at a time, no allocation, bounded work per byte, and every rejected byte is counted.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <variant>

#include "saulproto/core/result.hpp"
#include "saulproto/core/stream_framer.hpp"

namespace saul::interboard {

inline constexpr std::uint8_t kStartByte = 0xAA;

enum class Type : std::uint8_t {
  rc_cmd = 0x01,   ///< IO -> BALANCE
  sensor = 0x02,   ///< IO -> BALANCE
  fault = 0x03,    ///< IO -> BALANCE
  state = 0x10,    ///< BALANCE -> IO
  led_cmd = 0x11,  ///< BALANCE -> IO
  buzzer = 0x12,   ///< BALANCE -> IO
  speed_cap = 0x13,  ///< BALANCE -> IO (an addition to the system reference, docs/protocol.md section 2)
};

/// RC command forwarded by IO. throttle and steer in permille (-1000..+1000) after the speed cap.
struct RcCmd {
  static constexpr Type kType = Type::rc_cmd;
  static constexpr const char* kName = "rc_cmd";
  static constexpr std::uint8_t kArmed = 0x01;  ///< flags bit0
  static constexpr std::uint8_t kKill = 0x02;   ///< flags bit1
  /// flags bit2 (an addition to the reference): a receiver is live and its CH5 is at disarm (<= 1500 us)
  static constexpr std::uint8_t kDisarmSwitch = 0x04;
  static constexpr std::uint8_t kButton = 0x08;  ///< flags bit3 (an addition): the arming button is pressed now
  std::int16_t throttle = 0;
  std::int16_t steer = 0;
  std::uint8_t flags = 0;
  [[nodiscard]] constexpr bool armed() const noexcept { return (flags & kArmed) != 0; }
  [[nodiscard]] constexpr bool kill() const noexcept { return (flags & kKill) != 0; }
  [[nodiscard]] constexpr bool disarm_switch() const noexcept { return (flags & kDisarmSwitch) != 0; }
  [[nodiscard]] constexpr bool button() const noexcept { return (flags & kButton) != 0; }
  template <class V> constexpr void fields(V&& v) const {
    v("throttle", throttle); v("steer", steer); v("flags", flags);
  }
  constexpr bool operator==(const RcCmd&) const = default;
};

/// Sensor values forwarded by IO at 10 Hz.
struct Sensor {
  static constexpr Type kType = Type::sensor;
  static constexpr const char* kName = "sensor";
  std::uint16_t tof_mm = 0;
  std::int16_t baro_delta_pa = 0;
  std::uint8_t nfc_present = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("tof_mm", tof_mm); v("baro_delta_pa", baro_delta_pa); v("nfc_present", nfc_present);
  }
  constexpr bool operator==(const Sensor&) const = default;
};

/// Faults raised by IO. The three bits equal bits 0..2 of the CAN 0x401 fault byte.
struct Fault {
  static constexpr Type kType = Type::fault;
  static constexpr const char* kName = "fault";
  static constexpr std::uint8_t kRcLoss = 0x01;
  static constexpr std::uint8_t kMotorFault = 0x02;
  static constexpr std::uint8_t kEstop = 0x04;
  std::uint8_t flags = 0;
  template <class V> constexpr void fields(V&& v) const { v("flags", flags); }
  constexpr bool operator==(const Fault&) const = default;
};

/// BALANCE's state, 50 Hz. error_state carries the robot state value (docs/protocol.md, robot states).
struct State {
  static constexpr Type kType = Type::state;
  static constexpr const char* kName = "state";
  std::int16_t pitch_x100 = 0;
  std::int16_t pid_out = 0;
  std::uint8_t error_state = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("pitch_x100", pitch_x100); v("pid_out", pid_out); v("error_state", error_state);
  }
  constexpr bool operator==(const State&) const = default;
};

struct LedCmd {
  static constexpr Type kType = Type::led_cmd;
  static constexpr const char* kName = "led_cmd";
  std::uint8_t pattern = 0;
  std::uint8_t r = 0;
  std::uint8_t g = 0;
  std::uint8_t b = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("pattern", pattern); v("r", r); v("g", g); v("b", b);
  }
  constexpr bool operator==(const LedCmd&) const = default;
};

struct Buzzer {
  static constexpr Type kType = Type::buzzer;
  static constexpr const char* kName = "buzzer";
  std::uint8_t tone_id = 0;
  std::uint16_t duration_ms = 0;
  template <class V> constexpr void fields(V&& v) const { v("tone_id", tone_id); v("duration_ms", duration_ms); }
  constexpr bool operator==(const Buzzer&) const = default;
};

/// The one speed cap of both boards' motor outputs (docs/protocol.md, safety decisions): BALANCE owns it and sends
/// it with every STATE and at once when it changes; the IO board's BTS7960 duty never exceeds it.
struct SpeedCap {
  static constexpr Type kType = Type::speed_cap;
  static constexpr const char* kName = "speed_cap";
  std::uint8_t percent = 10;  ///< 10..100 in steps of 10
  template <class V> constexpr void fields(V&& v) const { v("percent", percent); }
  constexpr bool operator==(const SpeedCap&) const = default;
};

using Message = std::variant<RcCmd, Sensor, Fault, State, LedCmd, Buzzer, SpeedCap>;

/// Payload length of a known type, or nullopt for a type byte no one defined.
constexpr std::optional<std::uint8_t> payload_length(std::uint8_t type) noexcept {
  switch (static_cast<Type>(type)) {
    case Type::rc_cmd: return 5;
    case Type::sensor: return 5;
    case Type::fault: return 1;
    case Type::state: return 5;
    case Type::led_cmd: return 4;
    case Type::buzzer: return 3;
    case Type::speed_cap: return 1;
  }
  return std::nullopt;
}

inline constexpr std::size_t kOverhead = 4;              ///< start, LEN, TYPE, CRC
inline constexpr std::size_t kMaxPayload = 5;            ///< largest payload of a known type
inline constexpr std::size_t kMaxFrameSize = kOverhead + kMaxPayload;

Type type_of(const Message& message) noexcept;
const char* name_of(const Message& message) noexcept;

/// Encodes one frame into out. Returns the number of bytes written, or buffer_too_small.
/// O(frame size); out must hold kOverhead + payload length (kMaxFrameSize always suffices).
Result<std::size_t> encode(const Message& message, std::span<std::uint8_t> out) noexcept;

/// Decodes a payload of a given type (no framing, no CRC). Fails with unknown_type or bad_length.
Result<Message> decode_payload(std::uint8_t type, std::span<const std::uint8_t> payload) noexcept;

/// What the stream decoder has seen since construction or reset(). Every input byte ends up either in a
/// frame (frames x frame size), in bytes_skipped, or still pending inside the decoder.
struct Counters {
  std::uint32_t frames = 0;         ///< valid frames returned
  std::uint32_t crc_errors = 0;     ///< candidate frames whose CRC did not match
  std::uint32_t length_errors = 0;  ///< LEN not a length any type has, or not the length of its TYPE
  std::uint32_t unknown_types = 0;  ///< TYPE byte no one defined
  std::uint32_t bytes_skipped = 0;  ///< bytes that belonged to no valid frame (noise, rejected start bytes)
  constexpr bool operator==(const Counters&) const = default;
};

/// Streaming decoder. Feed bytes one at a time with push().
///
/// Resync rule (framing::StreamFramer, stream_framer.hpp): after any rejection (bad LEN, unknown TYPE, bad CRC)
/// the search for the next start byte resumes at the byte right after the rejected 0xAA, so a real frame that
/// began inside a false candidate is never lost. The rejected candidate is at most kMaxFrameSize bytes, so the
/// rescan is bounded: push() does O(kMaxFrameSize^2) work in the worst case, O(1) amortised, and never allocates.
/// Because the shortest frame is 5 bytes and a rescan covers at most 8, one push() completes at most one frame.
/// Safe to use from an ISR if the caller owns the object; not thread-safe.
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
  /// Forgets a partial frame (counted as skipped) and keeps the counters.
  void drop_partial() noexcept;
  /// Forgets everything, counters included.
  void reset() noexcept { *this = StreamDecoder{}; }

 private:
  // START, LEN, TYPE, then CRC of a whole frame; every rejection counted.
  struct Rules : framing::CountedRules<Counters> {
    framing::Verdict check(std::span<const std::uint8_t> candidate) noexcept;
  };
  framing::StreamFramer<kMaxFrameSize> framer_;
  Rules rules_;
};

}  // namespace saul::interboard
