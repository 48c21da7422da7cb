// The BALANCE board's loop trace (docs/protocol.md section 10): one record per balance-loop iteration, framed with
// the inter-board framing as TYPE 0x20 and sent on the BALANCE USB console, between the console's text lines.
//
// Frame: [0xAA][LEN = 35][TYPE = 0x20][PAYLOAD x 35][CRC8]   (CRC-8/MAXIM over TYPE and PAYLOAD, as section 2)
// The record never travels on the inter-board UART: interboard::StreamDecoder knows no TYPE 0x20 (it counts one as
// an unknown type), and interboard's frame size stays 9 bytes.
//
// The console port carries text and records at once. The console's text is ASCII, which never holds 0xAA, so a
// 0xAA always starts a record (or is noise): ConsoleDecoder separates the two with the same StreamFramer rules as
// every other stream of the core, and hands text on as lines and records as LoopTrace values. Every input byte
// ends up in exactly one of: a record, a text byte, bytes_skipped (a rejected record candidate's start byte), or
// pending. No heap; O(1) amortised per byte (a rejected candidate of at most 39 bytes is rescanned once).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include <variant>

#include "saulproto/core/console.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/result.hpp"
#include "saulproto/core/stream_framer.hpp"

namespace saul::trace {

inline constexpr std::uint8_t kType = 0x20;
inline constexpr std::size_t kPayloadLength = 35;
inline constexpr std::size_t kFrameSize = interboard::kOverhead + kPayloadLength;  ///< 39
static_assert(!interboard::payload_length(kType), "TYPE 0x20 must stay free on the inter-board link");

/// The test signal added to the pitch setpoint (BALANCE's `excite` command).
enum class Excite : std::uint8_t { none = 0, step = 1, chirp = 2, prbs = 3 };
const char* to_string(Excite excite) noexcept;

/// One balance-loop iteration. Units as named: _x100 = 0.01 degree, _x10 = 0.1 deg/s, permille of the output range,
/// ERPM as sent in SET_RPM, mm/s. Pitch + nose up; 32767 = unknown (no IMU yet), as in STATE.
struct LoopTrace {
  static constexpr const char* kName = "loop_trace";
  std::uint32_t time_us = 0;        ///< the loop's time stamp (step(now_us), wraps after 71 minutes)
  std::uint32_t seq = 0;            ///< +1 per iteration traced (every DIVIDER-th loop): a gap shows lost records
  std::int16_t pitch_x100 = 0;      ///< filtered pitch
  std::int16_t rate_x10 = 0;        ///< pitch rate (gyro, offset removed)
  std::int16_t setpoint_x100 = 0;   ///< the PID's pitch setpoint: balance point - lean + excitation
  std::int16_t p_term = 0;          ///< permille
  std::int16_t i_term = 0;          ///< permille
  std::int16_t d_term = 0;          ///< permille
  std::int16_t output = 0;          ///< permille, after saturation (pid_out)
  std::int16_t erpm_left = 0;       ///< commanded, before inversion
  std::int16_t erpm_right = 0;
  std::int16_t wheel_mmps = 0;      ///< measured wheel speed (both VESCs' mean), or the commanded one without STATUS
  std::int16_t request_mmps = 0;    ///< the speed request (Orin 0x300 while fresh, else RC throttle)
  std::uint8_t state = 0;           ///< robot state (docs/protocol.md section 4)
  std::uint8_t faults = 0;          ///< the 0x401 fault bits
  std::uint8_t excite = 0;          ///< Excite
  std::int16_t excite_x100 = 0;     ///< the excitation's offset in the setpoint now

  template <class V> constexpr void fields(V&& v) const {
    v("time_us", time_us); v("seq", seq); v("pitch_x100", pitch_x100); v("rate_x10", rate_x10);
    v("setpoint_x100", setpoint_x100); v("p_term", p_term); v("i_term", i_term); v("d_term", d_term);
    v("output", output); v("erpm_left", erpm_left); v("erpm_right", erpm_right); v("wheel_mmps", wheel_mmps);
    v("request_mmps", request_mmps); v("state", state); v("faults", faults); v("excite", excite);
    v("excite_x100", excite_x100);
  }
  constexpr bool operator==(const LoopTrace&) const = default;
};

/// Writes the 35-byte payload (little-endian) at p.
void write_payload(const LoopTrace& record, std::uint8_t* p) noexcept;
/// Encodes one whole frame (kFrameSize bytes) into out, or buffer_too_small.
Result<std::size_t> encode(const LoopTrace& record, std::span<std::uint8_t> out) noexcept;
/// Decodes a payload (no framing): bad_length unless it is kPayloadLength bytes.
Result<LoopTrace> decode_payload(std::span<const std::uint8_t> payload) noexcept;

/// What a ConsoleDecoder has seen. bytes = records x 39 + text_bytes + bytes_skipped + pending().
struct Counters {
  std::uint32_t records = 0;        ///< valid records
  std::uint32_t crc_errors = 0;     ///< candidates whose CRC did not match
  std::uint32_t length_errors = 0;  ///< LEN not 35
  std::uint32_t unknown_types = 0;  ///< TYPE not 0x20
  std::uint32_t truncated = 0;      ///< candidates the stream ended inside (finish())
  std::uint32_t bytes_skipped = 0;  ///< rejected start bytes (0xAA that began no record)
  std::uint64_t text_bytes = 0;     ///< console text
  std::uint32_t lines = 0;          ///< text lines delivered
  std::uint32_t long_lines = 0;     ///< lines longer than kMaxLine (delivered cut)
  constexpr bool operator==(const Counters&) const = default;
};

/// Separates the BALANCE console's byte stream into text lines and LoopTrace records.
/// A Sink has: record(const LoopTrace&, std::uint64_t offset), line(std::string_view text, bool cut),
/// rejected(Reason, std::uint64_t offset). Offsets count bytes from the first byte pushed (a record's or a rejected
/// candidate's 0xAA). Events come in stream order. Not thread-safe; no allocation.
class ConsoleDecoder {
 public:
  static constexpr std::size_t kMaxLine = 256;

  template <class Sink>
  void push(std::uint8_t byte, Sink& sink) noexcept {
    rules_.events = 0;
    framer_.push(byte, rules_, [this](std::span<const std::uint8_t> f) { take_frame(f); });
    deliver(sink);
  }
  template <class Sink>
  void push(std::span<const std::uint8_t> bytes, Sink& sink) noexcept {
    for (std::uint8_t b : bytes) push(b, sink);
  }
  /// The stream ended: a partial record is given up (its bytes rescanned as text or skipped) and a last line
  /// without its newline is delivered.
  template <class Sink>
  void finish(Sink& sink) noexcept {
    while (framer_.pending() != 0) {
      rules_.events = 0;
      rules_.reject(Reason::truncated, rules_.counters.truncated);
      framer_.abandon(rules_, [this](std::span<const std::uint8_t> f) { take_frame(f); });
      deliver(sink);
    }
    if (line_length_ != 0 || line_cut_) end_line(sink);
  }

  [[nodiscard]] const Counters& counters() const noexcept { return rules_.counters; }
  [[nodiscard]] std::size_t pending() const noexcept { return framer_.pending(); }
  /// Bytes pushed so far.
  [[nodiscard]] std::uint64_t offset() const noexcept { return rules_.base + framer_.pending(); }

 private:
  struct Event {
    Reason reason;        // ok: a text byte; else a rejected candidate
    std::uint8_t byte;
    std::uint64_t offset;
  };
  struct Rules {
    Counters counters{};
    std::uint64_t base = 0;  // the stream offset of the framer's first held byte
    bool text = false;       // the byte check() just rejected was text
    Event queue[kFrameSize + 1]{};
    std::size_t events = 0;
    framing::Verdict check(std::span<const std::uint8_t> candidate) noexcept;
    void skipped(std::size_t n) noexcept;
    void reject(Reason reason, std::uint32_t& counter) noexcept;
  };

  void take_frame(std::span<const std::uint8_t> frame) noexcept;
  template <class Sink>
  void deliver(Sink& sink) noexcept {
    for (std::size_t i = 0; i < rules_.events; ++i) {
      const Event& e = rules_.queue[i];
      if (e.reason != Reason::ok) {
        sink.rejected(e.reason, e.offset);
      } else if (e.byte == '\n') {
        end_line(sink);
      } else if (line_length_ < kMaxLine) {
        line_[line_length_++] = static_cast<char>(e.byte);
      } else {
        line_cut_ = true;
      }
    }
    rules_.events = 0;
    if (found_) {
      sink.record(*found_, found_offset_);
      found_.reset();
    }
  }
  template <class Sink>
  void end_line(Sink& sink) noexcept {
    std::size_t n = line_length_;
    if (n != 0 && line_[n - 1] == '\r') --n;
    ++rules_.counters.lines;
    if (line_cut_) ++rules_.counters.long_lines;
    sink.line(std::string_view(line_, n), line_cut_);
    line_length_ = 0;
    line_cut_ = false;
  }

  framing::StreamFramer<kFrameSize> framer_;
  Rules rules_;
  std::optional<LoopTrace> found_;
  std::uint64_t found_offset_ = 0;
  char line_[kMaxLine]{};
  std::size_t line_length_ = 0;
  bool line_cut_ = false;
};

// ---- console commands (BALANCE) ---------------------------------------------------------------------------------
//
//   trace on [DIVIDER]                  stream a record every DIVIDER-th loop (1..1000, default 1)
//   trace off | trace dump | trace arm  stop streaming; send the flight recorder; re-arm the flight recorder
//   excite step AMPL DUR                a test signal on the pitch setpoint, AMPL degrees (0 < |AMPL| <= 2),
//   excite chirp AMPL F0 F1 DUR         DUR seconds (0 < DUR <= 20), F0 and F1 in Hz (0.05 .. 100)
//   excite prbs AMPL DUR
//   excite off
// The first word is matched without regard to ASCII case, like every console command; the second exactly.

inline constexpr float kMaxAmplitudeDeg = 2.0F;
inline constexpr float kMaxDurationS = 20.0F;
inline constexpr float kMinFrequencyHz = 0.05F;
inline constexpr float kMaxFrequencyHz = 100.0F;
inline constexpr std::uint16_t kMaxDivider = 1000;
/// BALANCE refuses a test signal while its speed cap (speed_limit, lowered by the Orin's 0x303 max speed) is below
/// this share of the hard maximum (%), and ends one that is running when the cap falls below it. A signal holds the
/// speed loop's lean and ends at half the cap, and the speed loop needs the other half to bring the robot back: on
/// the simulator (10 seeds, 1 and 2 deg steps both ways, a 2 deg chirp and PRBS) the robot fell at the 10 % cap
/// (every step, 8 of 10 chirps) and at 20 % (every 2 deg step); from 30 % on none fell. 50 % keeps two 10 % steps
/// of margin, and is what `tune record --sim`, the bench suites and docs/tuning.md raise the cap to.
inline constexpr std::uint8_t kExciteMinCapPct = 50;
/// ... and above this share (%): at the full cap the speed loop, given the whole of it, brings the robot back so
/// hard that it falls. On the simulator (seeds 1-20, 2 deg steps held 20 s, both signs: tests/firmware/test_plant.cpp)
/// 16 of 40 fell at 100 %, none of 40 at each of 50, 60, 70, 80 and 90 %. The cap is raised only while disarmed, so
/// a running signal never crosses this bound; a start above it is refused.
inline constexpr std::uint8_t kExciteMaxCapPct = 90;
/// How BALANCE's refusal of a test signal at a low cap begins (then the minimum, " %" and which limit holds the cap
/// down): saulctl recognises it to name its own way of raising the cap.
inline constexpr std::string_view kExciteCapRefusal = "excite needs the speed cap >= ";
/// ... and of one at a high cap (then the maximum, " %" and how to lower it).
inline constexpr std::string_view kExciteCapHighRefusal = "excite needs the speed cap <= ";

struct TraceOn {
  std::uint16_t divider = 1;
};
struct TraceOff {};
struct TraceDump {};
struct TraceArm {};
struct ExciteStart {
  Excite kind = Excite::step;
  float amplitude_deg = 0.0F;
  float f0_hz = 0.0F;  ///< chirp only
  float f1_hz = 0.0F;  ///< chirp only
  float duration_s = 0.0F;
};
struct ExciteOff {};
using Command = std::variant<TraceOn, TraceOff, TraceDump, TraceArm, ExciteStart, ExciteOff>;

struct CommandParse {
  bool matched = false;        ///< the line's first word is trace or excite (else: another console command)
  Command command{};           ///< when matched and error.reason is ok
  console::ParseError error{}; ///< when matched and refused: format with console::format_error
};
/// Parses a console line if it is a trace or excite command. O(length), no allocation.
CommandParse parse_command(std::string_view line) noexcept;
/// Writes the console line of a command (ending in '\n', NUL-terminated), which parse_command() reads back to the
/// same command: what saulctl sends. buffer_too_small when it does not fit (64 chars always do).
Result<std::size_t> format_command(const Command& command, std::span<char> out) noexcept;

/// The help lines of these commands ("usage   summary\n" each), for the console's help.
static_assert(kExciteMinCapPct == 50 && kExciteMaxCapPct == 90, "kHelp names them");
inline constexpr std::string_view kHelp =
    "trace on [N]        stream the loop trace (every Nth loop, default 1)\n"
    "trace off           stop the loop trace\n"
    "trace dump          send the flight recorder (the last 5 s before a latch)\n"
    "trace arm           re-arm the flight recorder\n"
    "excite step A D     add a step of A deg (|A| <= 2) to the setpoint for D s (<= 20), BALANCE, cap 50-90 %\n"
    "excite chirp A F0 F1 D  a chirp from F0 to F1 Hz\n"
    "excite prbs A D     a pseudo-random binary sequence (20 ms bits)\n"
    "excite off          stop the test signal\n";

}  // namespace saul::trace
