// Small pieces both boards use: fixed-rate schedules, the balance filter and PID, LED patterns and tones, and the
// console's line assembly and reply helpers. All O(1) per call, no allocation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "saulfw/hal.hpp"
#include "saulproto/core/console.hpp"
#include "saulproto/core/pid_stager.hpp"
#include "saulproto/core/saul_can.hpp"

namespace saul::fw {

/// now - then, or 0 when then lies in the future (a clock that went backwards never makes anything "old").
constexpr TimeUs age(TimeUs now, TimeUs then) noexcept { return now >= then ? now - then : 0; }

/// A fixed-rate schedule: due() is true once per period. The first call is due at once. If the caller falls behind
/// by more than a period, the missed slots are dropped (no burst of catch-up messages).
class Every {
 public:
  constexpr explicit Every(TimeUs period_us) noexcept : period_(period_us) {}
  bool due(TimeUs now) noexcept {
    if (!started_) {
      started_ = true;
      next_ = now;
    }
    if (now < next_) return false;
    next_ += period_;
    if (next_ <= now) next_ = now + period_;
    return true;
  }
  /// Makes the next call due at once.
  void trigger() noexcept { started_ = false; }
  [[nodiscard]] TimeUs period() const noexcept { return period_; }

 private:
  TimeUs period_;
  TimeUs next_ = 0;
  bool started_ = false;
};

// ---- balance filter and controller ----------------------------------------------------------------------------

/// Complementary filter: integrates the gyro's pitch rate and pulls the result toward the accelerometer's pitch
/// with time constant tau. pitch (nose up, degrees) = atan2(ax, sqrt(ay^2 + az^2)) from the accelerometer,
/// rate = -gy (body frame, see ImuSample).
/// - A sample with a NaN or infinite value is rejected (update() returns false) and changes nothing.
/// - While |a| is outside 0.5..1.5 g (a bump, free fall), or the pitch rate is above kMaxAccelRateDps (the body's
///   own rotation reaches an accelerometer above the axle), the accelerometer is not trusted: gyro only.
/// - The first accepted sample, and the first after a gap of more than kMaxGapUs, sets the pitch from the
///   accelerometer alone (it needs |a| within 0.5..1.5 g); dt comes from the samples' own timestamps.
class ComplementaryFilter {
 public:
  static constexpr TimeUs kMaxGapUs = 20'000;
  /// Above this pitch rate (deg/s) the accelerometer is not used: the body's own rotation reaches it.
  static constexpr float kMaxAccelRateDps = 30.0F;

  explicit ComplementaryFilter(float tau_s = 0.5F) noexcept : tau_s_(tau_s) {}
  bool update(const ImuSample& sample) noexcept;
  void reset() noexcept;

  [[nodiscard]] bool valid() const noexcept { return valid_; }
  [[nodiscard]] float pitch_deg() const noexcept { return pitch_deg_; }
  [[nodiscard]] float rate_dps() const noexcept { return rate_dps_; }
  /// Timestamp of the last accepted sample.
  [[nodiscard]] TimeUs last_us() const noexcept { return last_us_; }

 private:
  float tau_s_;
  float pitch_deg_ = 0.0F;
  float rate_dps_ = 0.0F;
  TimeUs last_us_ = 0;
  bool valid_ = false;
};

/// The balance PID, in permille of full wheel command:
///   out = Kp * e + I - Kd * rate,   e = setpoint - pitch (degrees), rate = pitch rate (deg/s, nose up)
///   I  += Ki * e * dt, clamped to +-integral_limit, and frozen while the output is saturated in the direction
///         e would push it further (anti-windup);
///   out is saturated to -1000..+1000. The D term acts on the measured rate, so a setpoint change gives no kick.
/// Units: Kp permille/degree, Ki permille/(degree s), Kd permille/(degree/s). A non-finite result resets the
/// controller and gives 0.
class BalancePid {
 public:
  static constexpr float kOutputLimit = 1000.0F;

  explicit BalancePid(saulcan::PidGains gains = {}, float integral_limit = 300.0F) noexcept
      : gains_(gains), integral_limit_(integral_limit) {}
  float update(float error_deg, float rate_dps, float dt_s) noexcept;
  void reset() noexcept { integral_ = 0.0F; }
  void set_gains(const saulcan::PidGains& gains) noexcept {
    gains_ = gains;
    reset();
  }
  [[nodiscard]] const saulcan::PidGains& gains() const noexcept { return gains_; }
  [[nodiscard]] float integral() const noexcept { return integral_; }
  /// The proportional and derivative terms of the last update() (permille), for the loop trace.
  [[nodiscard]] float p_term() const noexcept { return p_; }
  [[nodiscard]] float d_term() const noexcept { return d_; }

 private:
  saulcan::PidGains gains_;
  float integral_limit_;
  float integral_ = 0.0F;
  float p_ = 0.0F;
  float d_ = 0.0F;
};

// ---- LEDs and tones -------------------------------------------------------------------------------------------

/// The pattern byte of the inter-board LED_CMD, and what the IO board draws for it.
enum class LedPattern : std::uint8_t {
  off = 0,      ///< all dark
  solid = 1,    ///< every pixel the colour
  breathe = 2,  ///< brightness ramps up and down, 2 s period (idle)
  blink = 3,    ///< 250 ms on, 250 ms off (fault)
  chase = 4,    ///< one lit pixel walking along the strip, 50 ms per pixel
};

struct LedCommand {
  LedPattern pattern = LedPattern::off;
  Rgb color{};
  constexpr bool operator==(const LedCommand&) const = default;
};

/// What BALANCE asks the strip to show for each robot state.
///   OFF breathe blue · BALANCE solid green · MANUAL solid cyan · ESTOP blink red · TILT_CUTOFF blink amber ·
///   FAULT blink magenta.
LedCommand led_for_state(saulcan::RobotState state) noexcept;

/// One frame of a pattern at time now (an unknown pattern value draws solid).
void render(LedPattern pattern, Rgb color, TimeUs now, std::span<Rgb> out) noexcept;

/// One line of text for a FaultReason ("" for none), as the console prints it and `status` shows it.
const char* fault_reason_text(FaultReason reason) noexcept;

/// BUZZER tone ids (inter-board BUZZER.tone_id) and the frequency the IO board plays for each.
enum class Tone : std::uint8_t { none = 0, armed = 1, disarmed = 2, alarm = 3 };
/// 1 -> 2000 Hz, 2 -> 1000 Hz, 3 -> 3000 Hz, any other non-zero id -> 1500 Hz, 0 -> silent.
std::uint16_t tone_hz(std::uint8_t tone_id) noexcept;

// ---- console --------------------------------------------------------------------------------------------------

/// Collects console bytes into lines. A line ends at CR or LF; empty lines are dropped (the CR LF pair gives one
/// line). A line longer than kMaxLine is reported once as overflowed and its text discarded.
class LineAssembler {
 public:
  static constexpr std::size_t kMaxLine = 120;

  /// Feeds one byte; calls on_line(std::string_view line, bool overflowed) when it ends a non-empty line.
  template <class F>
  void push(std::uint8_t byte, F&& on_line) noexcept {
    if (byte == '\r' || byte == '\n') {
      if (length_ > 0 || overflow_) on_line(std::string_view(buffer_, length_), overflow_);
      length_ = 0;
      overflow_ = false;
      return;
    }
    if (length_ < kMaxLine) {
      buffer_[length_++] = static_cast<char>(byte);
    } else {
      overflow_ = true;
    }
  }

 /// Reads what the port has (a bounded number of chunks, so a flood cannot stall the control loop) and feeds it.
  template <class Port, class F>
  void pump(Port& port, F&& on_line) noexcept {
    std::uint8_t chunk[64];
    for (int round = 0; round < 4; ++round) {
      const std::size_t n = port.read(chunk);
      if (n == 0) break;
      for (std::size_t i = 0; i < n && i < sizeof chunk; ++i) push(chunk[i], on_line);
    }
  }

 private:
  char buffer_[kMaxLine]{};
  std::size_t length_ = 0;
  bool overflow_ = false;
};

/// Writes all of text (what the port does not take is dropped: the console never blocks the control loop).
void write_text(SerialPort& port, std::string_view text) noexcept;
/// Writes the formatter's output held in buffer (also when it was truncated).
void write_formatted(SerialPort& port, const Result<std::size_t>& written, std::span<const char> buffer) noexcept;
/// "error: <message> [not_allowed]\n": a well-formed command the board refuses in its present state.
void write_refusal(SerialPort& port, std::string_view message) noexcept;
/// The reply to status: the status lines and report, then the can_stats and uart_stats ones, then "ok".
void write_status(SerialPort& port, const console::StatusReport& status, const console::CanStats& can,
                  const console::UartStats& uart, std::span<char> scratch) noexcept;
/// "ok\n": a command done.
void write_ok(SerialPort& port, std::span<char> scratch) noexcept;
/// The reply to can_stats / uart_stats: the human lines, the key=value line, then "ok".
void write_stats(SerialPort& port, const console::CanStats& stats, std::span<char> scratch) noexcept;
void write_stats(SerialPort& port, const console::UartStats& stats, std::span<char> scratch) noexcept;

/// The part of a console line both boards answer alike, so each board's switch holds only its own verbs: a line
/// too long or not understood gets its error reply here, a blank line gets nothing. Returns the command to act on,
/// held in `parsed`, or nullptr when the line has been answered. O(line length), no allocation.
const console::Command* read_command(SerialPort& port, std::string_view line, bool overflowed,
                                     console::ParseResult& parsed, std::span<char> scratch) noexcept;

}  // namespace saul::fw
