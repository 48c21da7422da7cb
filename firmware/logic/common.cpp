#include "saulfw/common.hpp"

#include <cmath>

namespace saul::fw {

namespace {
constexpr float kRadToDeg = 57.29577951308232F;
bool finite(float v) noexcept { return std::isfinite(v); }
}  // namespace

// ---- ComplementaryFilter ----------------------------------------------------------------------------------------

void ComplementaryFilter::reset() noexcept {
  pitch_deg_ = 0.0F;
  rate_dps_ = 0.0F;
  last_us_ = 0;
  valid_ = false;
}

bool ComplementaryFilter::update(const ImuSample& s) noexcept {
  if (!finite(s.ax) || !finite(s.ay) || !finite(s.az) || !finite(s.gx) || !finite(s.gy) || !finite(s.gz))
    return false;
  const float horizontal = std::sqrt(s.ay * s.ay + s.az * s.az);
  const float magnitude = std::sqrt(s.ax * s.ax + horizontal * horizontal);
  const bool accel_ok = magnitude >= 0.5F && magnitude <= 1.5F;
  const float accel_pitch = std::atan2(s.ax, horizontal) * kRadToDeg;
  const float rate = -s.gy;

  const bool restart = !valid_ || s.t_us < last_us_ || s.t_us - last_us_ > kMaxGapUs;
  if (restart) {
    if (!accel_ok) return false;  // cannot tell where "down" is yet
    pitch_deg_ = accel_pitch;
    rate_dps_ = rate;
    last_us_ = s.t_us;
    valid_ = true;
    return true;
  }
  if (s.t_us == last_us_) return false;  // the same sample twice
  const float dt = static_cast<float>(s.t_us - last_us_) * 1e-6F;
  float pitch = pitch_deg_ + rate * dt;
  // While the body turns quickly its own motion reaches the accelerometer (the board sits above the axle): gyro only.
  if (accel_ok && std::fabs(rate) <= kMaxAccelRateDps) {
    const float alpha = tau_s_ / (tau_s_ + dt);
    pitch = alpha * pitch + (1.0F - alpha) * accel_pitch;
  }
  if (!finite(pitch)) return false;
  pitch_deg_ = pitch;
  rate_dps_ = rate;
  last_us_ = s.t_us;
  return true;
}

// ---- BalancePid -------------------------------------------------------------------------------------------------

float BalancePid::update(float error_deg, float rate_dps, float dt_s) noexcept {
  const float p = gains_.kp * error_deg;
  const float d = -gains_.kd * rate_dps;
  p_ = p;
  d_ = d;
  const float candidate = integral_ + gains_.ki * error_deg * dt_s;
  const float unsaturated = p + integral_ + d;
  // Anti-windup: do not integrate further into a saturated output.
  const bool pushing_high = unsaturated >= kOutputLimit && error_deg > 0.0F;
  const bool pushing_low = unsaturated <= -kOutputLimit && error_deg < 0.0F;
  if (!pushing_high && !pushing_low) {
    integral_ = candidate > integral_limit_ ? integral_limit_ : (candidate < -integral_limit_ ? -integral_limit_ : candidate);
  }
  float out = p + integral_ + d;
  if (!std::isfinite(out)) {
    reset();
    return 0.0F;
  }
  if (out > kOutputLimit) out = kOutputLimit;
  if (out < -kOutputLimit) out = -kOutputLimit;
  return out;
}

// ---- LEDs and tones ---------------------------------------------------------------------------------------------

LedCommand led_for_state(saulcan::RobotState state) noexcept {
  using saulcan::RobotState;
  switch (state) {
    case RobotState::off: return {LedPattern::breathe, {0, 0, 255}};
    case RobotState::balance: return {LedPattern::solid, {0, 255, 0}};
    case RobotState::manual: return {LedPattern::solid, {0, 255, 255}};
    case RobotState::estop: return {LedPattern::blink, {255, 0, 0}};
    case RobotState::tilt_cutoff: return {LedPattern::blink, {255, 128, 0}};
    case RobotState::fault: return {LedPattern::blink, {255, 0, 255}};
  }
  return {LedPattern::blink, {255, 0, 255}};
}

namespace {
std::uint8_t scale(std::uint8_t c, std::uint32_t level_of_255) noexcept {
  return static_cast<std::uint8_t>(static_cast<std::uint32_t>(c) * level_of_255 / 255U);
}
}  // namespace

void render(LedPattern pattern, Rgb color, TimeUs now, std::span<Rgb> out) noexcept {
  const Rgb dark{};
  switch (pattern) {
    case LedPattern::off:
      for (auto& p : out) p = dark;
      return;
    case LedPattern::breathe: {
      const auto phase = static_cast<std::uint32_t>((now / 1000U) % 2000U);  // ms in a 2 s period
      const std::uint32_t ramp = phase < 1000U ? phase : 2000U - phase;     // 0..1000..0
      const std::uint32_t level = 16U + ramp * (255U - 16U) / 1000U;        // never fully dark: "powered"
      const Rgb c{scale(color.r, level), scale(color.g, level), scale(color.b, level)};
      for (auto& p : out) p = c;
      return;
    }
    case LedPattern::blink: {
      const bool on = (now / 250'000U) % 2U == 0U;
      for (auto& p : out) p = on ? color : dark;
      return;
    }
    case LedPattern::chase: {
      if (out.empty()) return;
      const std::size_t lit = static_cast<std::size_t>((now / 50'000U) % out.size());
      for (std::size_t i = 0; i < out.size(); ++i) out[i] = i == lit ? color : dark;
      return;
    }
    case LedPattern::solid:
      break;
  }
  for (auto& p : out) p = color;
}

const char* fault_reason_text(FaultReason reason) noexcept {
  switch (reason) {
    case FaultReason::none: return "";
    case FaultReason::imu_missing: return "no IMU: not one sample since power-on (missing or not started)";
    case FaultReason::imu_silent: return "IMU silent: its samples stopped";
    case FaultReason::io_link_silent: return "no IO board: not one RC_CMD since power-on";
    case FaultReason::io_link_lost: return "IO link lost: RC_CMD stopped while armed";
    case FaultReason::rc_lost: return "RC link lost while armed";
    case FaultReason::motor: return "motor fault (a VESC faulted or went silent)";
    case FaultReason::loop_hang: return "the control loop stood still (a hang)";
    case FaultReason::watchdog_reset: return "started after a watchdog reset";
  }
  return "unknown";
}

std::uint16_t tone_hz(std::uint8_t tone_id) noexcept {
  switch (static_cast<Tone>(tone_id)) {
    case Tone::none: return 0;
    case Tone::armed: return 2000;
    case Tone::disarmed: return 1000;
    case Tone::alarm: return 3000;
  }
  return 1500;
}

// ---- console ----------------------------------------------------------------------------------------------------

void write_text(SerialPort& port, std::string_view text) noexcept {
  auto bytes = std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
  while (!bytes.empty()) {
    const std::size_t n = port.write(bytes);
    if (n == 0) return;
    bytes = bytes.subspan(n < bytes.size() ? n : bytes.size());
  }
}

void write_formatted(SerialPort& port, const Result<std::size_t>& written, std::span<const char> buffer) noexcept {
  std::size_t n = 0;
  if (written.ok()) {
    n = *written;
  } else {
    while (n < buffer.size() && buffer[n] != '\0') ++n;  // truncated but NUL-terminated
  }
  write_text(port, std::string_view(buffer.data(), n));
}

void write_refusal(SerialPort& port, std::string_view message) noexcept {
  write_text(port, "error: ");
  write_text(port, message);
  write_text(port, " [not_allowed]\n");
}

namespace {
// A report's two forms, the words for people and the key=value line for scripts.
template <class Report>
void write_both(SerialPort& port, const Report& report, std::span<char> scratch) noexcept {
  write_formatted(port, console::format_human(report, scratch), scratch);
  write_formatted(port, console::format_kv(report, scratch), scratch);
}
}  // namespace

void write_ok(SerialPort& port, std::span<char> scratch) noexcept {
  write_formatted(port, console::format_ok(scratch), scratch);
}

void write_status(SerialPort& port, const console::StatusReport& status, const console::CanStats& can,
                  const console::UartStats& uart, std::span<char> scratch) noexcept {
  write_both(port, status, scratch);
  write_both(port, can, scratch);
  write_both(port, uart, scratch);
  write_ok(port, scratch);
}

void write_stats(SerialPort& port, const console::CanStats& stats, std::span<char> scratch) noexcept {
  write_both(port, stats, scratch);
  write_ok(port, scratch);
}

void write_stats(SerialPort& port, const console::UartStats& stats, std::span<char> scratch) noexcept {
  write_both(port, stats, scratch);
  write_ok(port, scratch);
}

const console::Command* read_command(SerialPort& port, std::string_view line, bool overflowed,
                                     console::ParseResult& parsed, std::span<char> scratch) noexcept {
  if (overflowed) {
    write_formatted(port, console::format_error({Reason::syntax, "line too long", 0, nullptr}, scratch), scratch);
    return nullptr;
  }
  parsed = console::parse(line);
  if (parsed) return &parsed.command;
  // A blank line is a syntax error without words: answered with nothing, as a terminal's Enter expects.
  if (parsed.error.reason != Reason::syntax) write_formatted(port, console::format_error(parsed.error, scratch), scratch);
  return nullptr;
}

}  // namespace saul::fw
