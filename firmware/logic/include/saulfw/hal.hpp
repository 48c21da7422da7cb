// The hardware the board logic sees: small interfaces, implemented by the ESP-IDF glue on the boards
// (firmware/balance/main, firmware/io/main), by fakes in the host tests (tests/firmware) and by the simulated
// robot. The logic never reads a clock, a register or a pin itself: time comes in as step(now_us), everything else
// through these interfaces.
//
// Rules, the same as libsaulproto's core: no heap, no exceptions, no RTTI, no iostreams, no ESP-IDF header.
// Interfaces have a protected non-virtual destructor: the logic never owns or deletes hardware, and no
// deleting destructor (which would pull operator delete into the firmware) is ever emitted.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/console.hpp"
#include "saulproto/core/saul_can.hpp"

namespace saul::fw {

/// Monotonic time in microseconds since an arbitrary origin (esp_timer_get_time() on the boards).
using TimeUs = std::uint64_t;

/// The monotonic clock, for glue and simulators that want to call step(clock.now_us()).
class Clock {
 public:
  virtual TimeUs now_us() = 0;

 protected:
  ~Clock() = default;
};

// ---- shared ---------------------------------------------------------------------------------------------------

/// A byte stream: a UART (inter-board link, CRSF receiver) or the USB console. Both calls never block.
class SerialPort {
 public:
  /// Copies up to out.size() received bytes into out; returns how many (0 when none are waiting).
  virtual std::size_t read(std::span<std::uint8_t> out) = 0;
  /// Queues data for sending; returns how many bytes were taken (fewer when the transmit buffer is full).
  virtual std::size_t write(std::span<const std::uint8_t> data) = 0;
  /// How many bytes write() would take now, so that a record is written whole or not at all (the loop trace).
  /// A port that cannot tell says "any number"; a short write then still counts as a dropped record.
  virtual std::size_t write_room() { return static_cast<std::size_t>(-1); }

 protected:
  ~SerialPort() = default;
};

/// The hardware watchdog (BALANCE: task watchdog at 50 ms). The logic feeds it at the end of every loop that ran,
/// sensor data or not: only a hang starves it. A missing or silent IMU is a latched FAULT, not a reboot loop.
class Watchdog {
 public:
  virtual void feed() = 0;

 protected:
  ~Watchdog() = default;
};

/// Why the chip last started. watchdog covers the task, interrupt and RTC watchdogs and a panic.
enum class ResetReason : std::uint8_t { power_on = 0, software = 1, watchdog = 2 };

/// What BALANCE keeps across a reset of its chip: the limits the Orin tightened with 0x303 (a lower tilt limit, a
/// lower speed). Without it a watchdog reset silently gave back the power-on 25 degrees and cap. The glue keeps it
/// in memory a reset does not clear (RTC_NOINIT_ATTR on the ESP32-S3; a power cycle does clear it), the simulator
/// across its restarts. The logic reads it only after a reset that was not a power-on, and only when `check`
/// matches (noise in uninitialised memory does not), and only to tighten: a kept limit never loosens a limit.
// Trivial on purpose: the glue's RTC_NOINIT object must have no constructor that would clear it at start-up.
struct RetainedLimits {
  std::uint16_t tilt_limit_x100;
  std::uint16_t orin_max_speed_mmps;
  std::uint32_t check;

  static constexpr std::uint32_t kMagic = 0x5A1D'7EE0U;
  [[nodiscard]] constexpr std::uint32_t expected() const noexcept {
    return kMagic ^ ((static_cast<std::uint32_t>(tilt_limit_x100) << 16) | orin_max_speed_mmps);
  }
};

// ---- BALANCE --------------------------------------------------------------------------------------------------

/// One QMI8658 sample in the robot's body frame (REP-103: x forward, y left, z up), rotated from the chip's own
/// axes by the glue (pin map, kImuAxes). Accelerations in g, angular rates in degrees per second, right-handed
/// about each axis (so a nose-up pitch rate is a negative gy). t_us: when the sample was taken (data-ready).
struct ImuSample {
  TimeUs t_us = 0;
  float ax = 0.0F;
  float ay = 0.0F;
  float az = 0.0F;
  float gx = 0.0F;
  float gy = 0.0F;
  float gz = 0.0F;
};

/// Samples arrive at 1 kHz (INT1 data-ready); read() hands out the oldest unread one.
class Imu {
 public:
  /// True and fills out when a sample is waiting.
  virtual bool read(ImuSample& out) = 0;

 protected:
  ~Imu() = default;
};

/// The TWAI controller (500 kbit/s classic CAN). Both calls never block.
class CanPort {
 public:
  /// True and fills out when a frame is waiting.
  virtual bool receive(CanFrame& out) = 0;
  /// Queues a frame; false when the transmit queue is full or the controller is bus-off.
  virtual bool send(const CanFrame& frame) = 0;
  /// The controller's counters, for the console's can_stats.
  virtual console::CanStats stats() = 0;

 protected:
  ~CanPort() = default;
};

/// Why BALANCE latched FAULT (the first cause since the last arming), for the console line it prints, the LCD
/// view and `status`; the 0x401 bits say the same in less detail (fault_reason_bit). none: no FAULT latched.
/// The numbers are what the LCD shows as marks (firmware/README.md).
enum class FaultReason : std::uint8_t {
  none = 0,
  imu_missing = 1,     ///< no IMU sample since power-on (imu_startup_us): the chip is missing or never started
  imu_silent = 2,      ///< the IMU stopped delivering (imu_stall_us)
  io_link_silent = 3,  ///< no RC_CMD from the IO board since power-on (io_startup_us)
  io_link_lost = 4,    ///< RC_CMD stopped while armed (io_link_timeout_us)
  rc_lost = 5,         ///< the IO board reported RC loss while armed
  motor = 6,           ///< a VESC fault or a VESC that went silent while armed
  loop_hang = 7,       ///< the control loop stood still for longer than hang_us while armed
  watchdog_reset = 8,  ///< powered on after a watchdog reset or a panic
};

/// What the round GC9A01 shows: plain data, drawn by the glue (which owns fonts, colours and the SPI bus).
struct LcdView {
  std::int16_t pitch_x100 = 0;      ///< degrees x 100, + nose up
  std::int16_t speed_mmps = 0;      ///< + forward
  std::uint8_t battery_pct = 0;     ///< 0..100; meaningless when !battery_known
  bool battery_known = false;       ///< a VESC has reported the pack voltage
  std::uint16_t battery_mv = 0;
  saulcan::RobotState state = saulcan::RobotState::off;  ///< the "error state" line
  std::uint8_t faults = 0;          ///< 0x401 fault bits
  std::uint8_t speed_limit_pct = 10;
  std::uint16_t tilt_limit_x100 = 2500;
  bool orin_active = false;         ///< driven by the Orin (else RC only)
  FaultReason fault_reason = FaultReason::none;  ///< why FAULT was latched
  constexpr bool operator==(const LcdView&) const = default;
};

class Display {
 public:
  /// Called at the display rate (10 Hz); the glue copies the view and draws it outside the control loop.
  virtual void show(const LcdView& view) = 0;

 protected:
  ~Display() = default;
};

// ---- IO -------------------------------------------------------------------------------------------------------

/// PWM outputs of the IO board, duty in permille (0..1000).
enum class PwmChannel : std::uint8_t {
  left_rpwm = 0,   ///< BTS7960 left, forward
  left_lpwm = 1,   ///< BTS7960 left, reverse
  right_rpwm = 2,  ///< BTS7960 right, forward
  right_lpwm = 3,  ///< BTS7960 right, reverse
  headlight = 4,
};
inline constexpr std::size_t kPwmChannelCount = 5;

class Pwm {
 public:
  virtual void set(PwmChannel channel, std::uint16_t permille) = 0;

 protected:
  ~Pwm() = default;
};

/// Digital outputs; on = the function is active (the glue knows each pin's polarity).
enum class OutputPin : std::uint8_t {
  left_r_en = 0,
  left_l_en = 1,
  right_r_en = 2,
  right_l_en = 3,
  fan = 4,
};
inline constexpr std::size_t kOutputPinCount = 5;

/// Digital inputs, already converted to "active" by the glue (the arming button is active-low on IO9; the kill
/// switch sense on IO10 must read active when its wire is cut).
enum class InputPin : std::uint8_t { arm_button = 0, kill_switch = 1 };

class Gpio {
 public:
  virtual void write(OutputPin pin, bool on) = 0;
  virtual bool read(InputPin pin) = 0;

 protected:
  ~Gpio() = default;
};

/// The horn / buzzer on IO14: a PWM tone, 0 Hz = silent.
class Horn {
 public:
  virtual void tone(std::uint16_t hz) = 0;

 protected:
  ~Horn() = default;
};

struct Rgb {
  std::uint8_t r = 0;
  std::uint8_t g = 0;
  std::uint8_t b = 0;
  constexpr bool operator==(const Rgb&) const = default;
};

/// The WS2812B strip on IO13.
class LedStrip {
 public:
  /// Sends one frame of pixels (first pixel first).
  virtual void show(std::span<const Rgb> pixels) = 0;

 protected:
  ~LedStrip() = default;
};

/// The I2C sensors, read at 10 Hz. A part that is missing or did not answer reports invalid.
struct SensorReadings {
  bool tof_valid = false;
  std::uint16_t tof_mm = 0;
  bool pressure_valid = false;
  std::int32_t pressure_pa = 0;  ///< absolute pressure
  bool nfc_present = false;      ///< a tag is in the field
  std::uint16_t battery_mv = 0;  ///< pack voltage if the IO board measures it, 0 = unknown
};

class Sensors {
 public:
  virtual SensorReadings read() = 0;

 protected:
  ~Sensors() = default;
};

}  // namespace saul::fw
