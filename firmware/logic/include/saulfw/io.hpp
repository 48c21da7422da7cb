// The IO board (bare ESP32-S3 devkit): RC receivers (CRSF primary on UART0, ELRS failover on UART2), ESTOP and the
// kill switch, the arming button, the BTS7960 motor drivers, I2C sensors, WS2812B strip, horn, headlight, fan, the
// inter-board link to BALANCE, CRSF telemetry back to the transmitter, and the USB console.
//
// Driven entirely by step(now_us), called by the glue in a fast loop (1 kHz). One call is one loop iteration:
//   1. ESTOP first: the kill switch and the newest CH6 of every live receiver, before anything else is looked at.
//      Active -> motor enables low and PWM 0 right there, armed flag dropped, FAULT(estop) and an RC_CMD with the
//      kill flag sent at once.
//   2. receiver bytes: each RC_CHANNELS frame is mapped (rc::map_channels, ESTOP first) and, if it carries ESTOP,
//      step 1 runs again at once, inside the receive loop; then the receiver selection (CRSF / ELRS / none)
//   3. inter-board bytes from BALANCE (STATE, LED_CMD, BUZZER)
//   4. console lines
//   5. arming: the button held for 3 s, continuously, with the ARM switch (CH5) on, the throttle stick centred
//      (CH2 within the sticks' 5 us deadband), BALANCE's |pitch| <= 5 degrees (from a STATE at most 100 ms old), RC
//      alive and no ESTOP -> the RC_CMD armed flag. The hold must begin with a new press: a button held since
//      power-on, through a failed condition, or through any disarm or latch (this board's, or BALANCE entering
//      ESTOP, TILT_CUTOFF or FAULT) must be released first.
//      The flag drops with the ARM switch, ESTOP, RC loss, a console disarm, BALANCE entering a latched state, or
//      BALANCE not reporting BALANCE/MANUAL within 250 ms of the arming (refused).
//   6. BTS7960 drivers: enabled only while armed, BALANCE reports BALANCE or MANUAL, RC alive and no ESTOP; left =
//      throttle - steer, right = throttle + steer, each within the speed cap: the sticks are scaled by the lower of
//      CH7's cap and the speed cap BALANCE owns (SPEED_CAP, 10 % until BALANCE says otherwise); else enables low
//      and PWM 0
//   7. to BALANCE: FAULT (at once on any change, then 10 Hz), RC_CMD (100 Hz, and at once when its flags change:
//      armed, kill, CH5 at disarm, button), SENSOR (10 Hz)
//   8. CRSF telemetry (attitude, flight mode, battery; one frame per 100 ms), LEDs (50 Hz), horn, headlight, fan
//   9. watchdog feed
#pragma once

#include <cstdint>
#include <string_view>

#include "saulfw/arming.hpp"
#include "saulfw/common.hpp"
#include "saulfw/hal.hpp"
#include "saulproto/core/crsf.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/rc_input.hpp"

namespace saul::fw {

struct IoConfig {
  TimeUs arm_hold_us = 3'000'000;        ///< the button hold that arms
  std::uint16_t upright_x100 = 500;      ///< |pitch| from STATE for arming
  TimeUs rc_cmd_period_us = 10'000;      ///< RC_CMD, 100 Hz
  TimeUs sensor_period_us = 100'000;     ///< SENSOR, 10 Hz
  TimeUs fault_period_us = 100'000;      ///< FAULT repeated at 10 Hz (and sent at once on a change)
  TimeUs state_timeout_us = 100'000;     ///< a STATE older than this is not trusted (BALANCE sends 50 Hz)
  TimeUs arm_confirm_us = 250'000;       ///< BALANCE must report BALANCE/MANUAL this soon after the arming
  TimeUs console_estop_us = 500'000;     ///< how long a console estop is reported (FAULT estop, RC_CMD kill)
  TimeUs led_period_us = 20'000;         ///< strip refresh, 50 Hz
  TimeUs led_cmd_timeout_us = 2'000'000; ///< a LED_CMD older than this is replaced by the pattern of STATE
  TimeUs telemetry_period_us = 100'000;  ///< one CRSF telemetry frame per period, round robin
  TimeUs output_refresh_us = 100'000;    ///< PWM and GPIO outputs are rewritten at least this often
  std::uint8_t led_count = 16;           ///< pixels on the strip, at most kMaxLeds
  std::uint8_t horn_channel = 7;         ///< CH8 (0-based 7) > 1500 us sounds the horn
  std::uint8_t headlight_channel = 2;    ///< CH3 (0-based 2) > 1500 us turns the headlight on
  std::uint16_t horn_hz = 2000;
  bool elrs_fitted = true;               ///< ELRS on UART2 (IO16/IO17); false: IO16 drives the fan
};

class IoBoard {
 public:
  static constexpr std::size_t kMaxLeds = 64;

  struct Hardware {
    SerialPort& crsf;     ///< UART0: Crossfire receiver (RX frames in, telemetry out)
    SerialPort& elrs;     ///< UART2: ELRS receiver
    SerialPort& link;     ///< UART1: inter-board link to BALANCE
    SerialPort& console;  ///< USB (JTAG serial)
    Pwm& pwm;
    Gpio& gpio;
    Horn& horn;
    LedStrip& leds;
    Sensors& sensors;
    Watchdog& watchdog;
  };

  IoBoard(const Hardware& hw, const IoConfig& config) noexcept;

  void step(TimeUs now_us) noexcept;

  // ---- observers ----
  [[nodiscard]] bool armed() const noexcept { return armed_; }
  [[nodiscard]] bool estop_active() const noexcept { return estop_level_ || console_estop_; }
  [[nodiscard]] rc::Source active_source() const noexcept { return selector_.active(); }
  [[nodiscard]] bool rc_loss() const noexcept { return selector_.rc_loss(); }
  /// The FAULT flags now (interboard::Fault bits).
  [[nodiscard]] std::uint8_t fault_flags() const noexcept;
  [[nodiscard]] bool motors_enabled() const noexcept { return motors_enabled_; }
  /// The speed cap the motor outputs obey now: the lower of BALANCE's cap and CH7's (10 % without a radio).
  [[nodiscard]] std::uint8_t speed_cap_pct() const noexcept;
  [[nodiscard]] bool holding() const noexcept { return hold_active_; }
  [[nodiscard]] bool reboot_requested() const noexcept { return reboot_requested_; }
  [[nodiscard]] const interboard::Counters& uart_counters() const noexcept { return link_rx_.counters(); }

 private:
  struct Receiver {
    crsf::StreamDecoder decoder;
    rc::Channels us{};
    rc::Command command{};
    TimeUs last_us = 0;
    bool seen = false;
  };

  void boot(TimeUs now) noexcept;
  void check_estop(TimeUs now) noexcept;
  void read_receiver(Receiver& receiver, SerialPort& port, rc::Source source, TimeUs now) noexcept;
  void read_link(TimeUs now) noexcept;
  void read_console(TimeUs now) noexcept;
  void on_console_line(std::string_view line, bool overflowed, TimeUs now) noexcept;
  void arming(TimeUs now) noexcept;
  void drive_motors(TimeUs now) noexcept;
  void to_balance(TimeUs now) noexcept;
  void telemetry(TimeUs now) noexcept;
  void outputs(TimeUs now) noexcept;

  void motors_off() noexcept;
  void set_side(PwmChannel forward, PwmChannel reverse, OutputPin r_en, OutputPin l_en, std::int16_t permille,
                bool enabled) noexcept;
  void set_pwm(PwmChannel channel, std::uint16_t permille) noexcept;
  void set_pin(OutputPin pin, bool on) noexcept;
  /// Drops the armed flag and, per the arming table's hold column, cancels a hold in progress.
  void disarm(arming::Event event) noexcept;
  void send_fault() noexcept;
  void send_rc_cmd() noexcept;
  void send_link(const interboard::Message& message) noexcept;
  [[nodiscard]] const Receiver* active_receiver() const noexcept;
  [[nodiscard]] const rc::Command* active_command() const noexcept;
  /// The sticks of the active receiver scaled by speed_cap_pct() (zero without a receiver or during ESTOP).
  [[nodiscard]] rc::Command capped_command() const noexcept;
  [[nodiscard]] std::uint8_t rc_flags() const noexcept;
  [[nodiscard]] bool state_fresh(TimeUs now) const noexcept;
  [[nodiscard]] bool balance_armed(TimeUs now) const noexcept;

  Hardware hw_;
  IoConfig config_;

  Receiver crsf_{};
  Receiver elrs_{};
  rc::ReceiverSelector selector_;
  interboard::StreamDecoder link_rx_;
  LineAssembler console_in_;

  // safety
  bool estop_level_ = false;       // kill switch or a live receiver's CH6
  bool console_estop_ = false;     // a console estop, reported for console_estop_us
  TimeUs console_estop_us_ = 0;
  std::uint8_t sent_faults_ = 0xFF;  // last FAULT flags sent (0xFF: none yet)

  // arming
  bool armed_ = false;
  TimeUs armed_us_ = 0;
  bool hold_active_ = false;
  TimeUs hold_start_us_ = 0;
  bool need_release_ = true;  // a button already down at power-on must be released first
  bool button_ = false;       // the arming button as read this iteration
  std::uint8_t sent_rc_flags_ = 0xFF;  // flags of the last RC_CMD sent (0xFF: none yet)

  // motors
  bool motors_enabled_ = false;
  std::int16_t left_permille_ = 0;
  std::int16_t right_permille_ = 0;

  // from BALANCE
  std::uint8_t balance_cap_pct_ = 10;  // BALANCE's speed cap (SPEED_CAP); 10 % until it says otherwise
  interboard::State state_{};
  TimeUs state_us_ = 0;
  bool state_seen_ = false;
  interboard::LedCmd led_cmd_{};
  TimeUs led_cmd_us_ = 0;
  bool led_cmd_seen_ = false;
  std::uint8_t buzzer_tone_ = 0;
  TimeUs buzzer_until_us_ = 0;

  // sensors
  SensorReadings readings_{};
  bool baro_reference_set_ = false;
  std::int32_t baro_reference_pa_ = 0;

  // outputs (written on change and refreshed every output_refresh_us)
  std::uint16_t pwm_out_[kPwmChannelCount]{};
  bool pin_out_[kOutputPinCount]{};
  bool outputs_known_ = false;
  std::uint16_t horn_hz_out_ = 0xFFFF;
  Rgb pixels_[kMaxLeds]{};
  std::uint8_t telemetry_slot_ = 0;

  Every rc_cmd_tx_;
  Every sensor_tx_;
  Every fault_tx_;
  Every telemetry_tx_;
  Every led_tx_;
  Every refresh_;
  bool started_ = false;
  TimeUs boot_us_ = 0;
  bool reboot_requested_ = false;

  char scratch_[console::kMaxReply]{};
};

}  // namespace saul::fw
