// The BALANCE board (Waveshare ESP32-S3 Touch LCD 1.28): IMU -> pitch -> balance PID -> VESC SET_RPM, the Orin's
// CAN commands with their 0x402 acknowledgements, telemetry, the inter-board link to the IO board, the robot state
// machine with its fault bits, the LCD view and the USB console.
//
// The board is driven entirely by step(now_us), called once per IMU data-ready interrupt (1 kHz) by the glue or a
// simulator. One call is one loop iteration, in this order:
//   1. IMU samples -> complementary filter (pitch, pitch rate)
//   2. inter-board bytes in (RC_CMD, SENSOR, FAULT): an RC kill flag or a FAULT estop bit latches ESTOP at once
//   3. CAN frames in (0x300..0x303, VESC status): mode 3 latches ESTOP at once; each 0x301 set, 0x302 and 0x303
//      gets its 0x402 in this same iteration
//   4. supervision: link timeouts, tilt, faults -> latched states (ESTOP > TILT_CUTOFF > FAULT)
//   5. an arming request from the IO board (RC_CMD armed flag going 0 -> 1), refused if any estop input was seen in
//      this iteration or is still active
//   6. console lines (a console estop latches at once; arm is checked like 5)
//   7. control: PID and wheel speeds from the state as it stands after 1..6, so an estop, a cutoff or a fault
//      seen anywhere in the iteration zeroes the wheels in this iteration; SET_RPM to both VESCs every 10 ms and
//      at once when the wheels must stop
//   8. telemetry 0x400/0x401 (10 Hz), STATE (50 Hz and on every state change), LED_CMD, BUZZER, LCD view
//   9. watchdog feed: the loop ran to its end. A missing or silent IMU (nothing for imu_startup_us after power-on,
//      or imu_stall_us after the last sample) latches FAULT (watchdog_reset, armed or not) with the wheels stopped,
//      and so does an IO board not heard from io_startup_us after power-on (io_link_loss); the board says why on
//      the console (once), in the LCD view and in 0x401, and stays alive and answering: a reset would only bring
//      it back to the same FAULT.
//
// Speed in BALANCE (docs/protocol.md section 5): the 0x300 (or RC throttle) speed request is clamped to
// speed_request_share of the speed cap; an outer PI loop turns the speed error (request - measured wheel speed)
// into a lean, limited to +-max_lean_deg, which becomes the balance PID's pitch setpoint. The request never
// reaches the wheels directly: the balance loop keeps the rest of the cap for balancing.
//
// State machine: one table, saulfw/arming.hpp (printed in docs/protocol.md section 4), applied by apply():
//   OFF -(arming)-> BALANCE <-(0x302 mode 1/2)-> MANUAL
//   any -(disarm: console disarm, 0x302 mode 0, CH5 at disarm, the IO armed flag 1 -> 0 while armed)-> OFF, except
//   ESTOP while an estop input is active (then refused). A latched state is left only to OFF: by a console disarm,
//   0x302 mode 0, or CH5 going to disarm (its edge; the level only keeps the robot disarmed).
//   any -(estop: RC_CMD kill, FAULT estop, 0x302 mode 3, console estop)-> ESTOP
//   BALANCE/MANUAL -(|pitch| > tilt limit)-> TILT_CUTOFF
//   BALANCE/MANUAL -(IO link loss, RC loss, motor fault, loop hang)-> FAULT; power-on after a watchdog
//   reset -> FAULT; any -(IMU missing or silent, IO board silent since power-on)-> FAULT
//   Every stop and every disarm, whatever state it finds, cancels a button hold in progress.
// Arming (IO flag edge, console arm): only from OFF, with a valid pitch |pitch| <= 5 degrees, the IO link alive,
// no RC loss, no motor fault, no estop input, CH5 not at disarm and the throttle stick centred (RC_CMD throttle 0);
// it clears the latched fault bits. The IO flag edge also needs the arming button seen released (RC_CMD button
// bit) since the last stop, disarm, latch or power-on: a new press (docs/protocol.md, safety
// decisions). The speed cap (console speed_limit) rises one 10 % step per command and only while disarmed; BALANCE
// sends it to the IO board (SPEED_CAP) with every STATE and at once when it changes.
#pragma once

#include <cstdint>
#include <string_view>

#include "saulfw/arming.hpp"
#include "saulfw/common.hpp"
#include "saulfw/hal.hpp"
#include "saulfw/trace.hpp"
#include "saulproto/core/console.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/pid_stager.hpp"
#include "saulproto/core/saul_can.hpp"

namespace saul::fw {

struct BalanceConfig {
  // control
  saulcan::PidGains gains{25.0F, 0.0F, 0.5F};  ///< power-on gains (permille/deg, permille/(deg s), permille/(deg/s))
  float integral_limit = 300.0F;               ///< permille
  float filter_tau_s = 0.5F;                   ///< complementary filter time constant
  /// The gyro's zero-rate offset about the pitch axis is learnt while disarmed (motors off) from the samples that
  /// look still (|rate| below gyro_still_dps), with this time constant, and taken out of every sample. 0: off.
  float gyro_bias_tau_s = 2.0F;
  float gyro_still_dps = 10.0F;
  float pitch_setpoint_deg = 0.0F;             ///< the balance point
  /// The VESCs' speed loop as a first-order lag (s) and their acceleration limit: the base's acceleration is
  /// estimated from the wheel speed last sent to them (SET_RPM, held until the next) through them and taken out
  /// of the accelerometer before the filter, which would otherwise read a steadily accelerating base as tilt (the
  /// drift into the speed cap). 0: off.
  float drive_tau_s = 0.05F;
  float drive_max_accel_mps2 = 6.0F;
  // the speed loop in BALANCE (speed request -> lean; see the file comment)
  float speed_kp_deg_per_mps = 12.0F;  ///< lean per m/s of speed error
  float speed_ki_deg_per_m = 8.0F;     ///< lean per metre of accumulated speed error (finds the balance point)
  float speed_filter_tau_s = 0.3F;     ///< low-pass on the measured speed: the balance loop's own quick moves stay out
  float max_lean_deg = 4.0F;           ///< the most lean the speed loop may ask for
  float speed_request_share = 0.4F;    ///< a speed request is clamped to this share of the speed cap
  TimeUs speed_settle_us = 1'500'000;  ///< after entering BALANCE, stand still this long (find the balance point)
  float speed_ramp_mps2 = 0.3F;        ///< and followed at most this quickly (the lean a step would need is kept small)
  float speed_guard_share = 0.2F;      ///< the target waits while the wheels lag it by more than this share of the cap
  // limits
  std::uint16_t tilt_limit_x100 = 2500;        ///< power-on tilt cutoff, 5.00..25.00 degrees
  std::uint16_t upright_x100 = 500;            ///< |pitch| for arming
  std::uint16_t hard_max_speed_mmps = 2000;    ///< 100 % of the speed cap; pid_out 1000 = this wheel speed
  std::uint16_t max_steer_mrad = 600;          ///< steering angle at full RC stick, and the clamp for 0x300
  // drive train
  std::uint16_t wheel_circumference_mm = 628;  ///< 200 mm wheels
  std::uint8_t pole_pairs = 7;                 ///< ERPM = mechanical RPM x pole pairs
  std::uint16_t track_mm = 460;                ///< distance between the left and right wheels
  std::uint16_t wheelbase_mm = 700;            ///< for the steering angle -> wheel speed difference
  bool invert_left = false;                    ///< a motor mounted mirrored turns the other way for "forward"
  bool invert_right = false;
  // battery (from the VESCs' STATUS_5 input voltage)
  std::uint16_t battery_empty_mv = 33000;
  std::uint16_t battery_full_mv = 42000;
  std::uint16_t low_battery_mv = 34000;
  // timing
  TimeUs motor_period_us = 10'000;        ///< SET_RPM to both VESCs, 100 Hz
  TimeUs telemetry_period_us = 100'000;   ///< 0x400 and 0x401, 10 Hz
  TimeUs state_period_us = 20'000;        ///< STATE to IO, 50 Hz
  TimeUs led_period_us = 1'000'000;       ///< LED_CMD refresh (also sent on every state change)
  TimeUs display_period_us = 100'000;     ///< LCD view, 10 Hz
  TimeUs io_link_timeout_us = 100'000;    ///< no valid RC_CMD for longer: io_link_loss
  TimeUs orin_timeout_us = 500'000;       ///< no 0x300 for longer: orin_timeout, RC only
  TimeUs imu_stall_us = 10'000;           ///< no IMU sample for longer: FAULT (watchdog_reset), motors zero
  TimeUs imu_startup_us = 500'000;        ///< the same before the first sample after power-on
  TimeUs io_startup_us = 1'000'000;       ///< no RC_CMD this long after power-on: FAULT (io_link_loss)
  TimeUs hang_us = 50'000;                ///< a gap between two step() calls longer than this: the loop hung
  TimeUs vesc_status_timeout_us = 500'000;  ///< a VESC that sent STATUS and then stopped: motor_fault
};

class BalanceBoard {
 public:
  struct Hardware {
    Imu& imu;
    CanPort& can;
    SerialPort& link;     ///< inter-board UART to the IO board
    SerialPort& console;  ///< USB console
    Watchdog& watchdog;
    Display& display;
    RetainedLimits& retained;  ///< survives a reset (see hal.hpp)
  };

  BalanceBoard(const Hardware& hw, const BalanceConfig& config, ResetReason reset) noexcept;

  /// One loop iteration at time now_us (monotonic). See the file comment for what it does.
  void step(TimeUs now_us) noexcept;

  // ---- observers (glue, simulator, tests) ----
  [[nodiscard]] saulcan::RobotState state() const noexcept { return state_; }
  /// The 0x401 fault bits: live conditions and the causes latched since the last arming.
  [[nodiscard]] std::uint8_t faults() const noexcept { return live_faults_ | latched_faults_; }
  [[nodiscard]] bool pitch_valid() const noexcept { return filter_.valid(); }
  [[nodiscard]] float pitch_deg() const noexcept { return filter_.pitch_deg(); }
  [[nodiscard]] std::int16_t pitch_x100() const noexcept;
  [[nodiscard]] std::int16_t pid_out() const noexcept { return pid_out_; }
  [[nodiscard]] const saulcan::PidGains& gains() const noexcept { return pid_.gains(); }
  [[nodiscard]] std::uint16_t tilt_limit_x100() const noexcept { return tilt_limit_x100_; }
  [[nodiscard]] std::uint8_t speed_limit_pct() const noexcept { return speed_limit_pct_; }
  /// The wheel speed limit now: the speed_limit percentage of hard_max_speed_mmps, lowered by 0x303.
  [[nodiscard]] std::uint16_t speed_cap_mmps() const noexcept;
  /// ERPM of a wheel speed, as sent in SET_RPM (before inversion); truncated toward zero.
  [[nodiscard]] std::int32_t erpm_of(std::int32_t mmps) const noexcept;
  [[nodiscard]] bool orin_active() const noexcept { return (live_faults_ & saulcan::fault::kOrinTimeout) == 0; }
  [[nodiscard]] bool reboot_requested() const noexcept { return reboot_requested_; }
  [[nodiscard]] LcdView view() const noexcept;
  [[nodiscard]] FaultReason fault_reason() const noexcept { return fault_reason_; }
  /// The lean the speed loop asks for now (degrees, + = forward, nose down).
  [[nodiscard]] float lean_deg() const noexcept { return lean_deg_; }
  /// The speed the speed loop aims for now (m/s): the request within its share of the cap, ramped.
  [[nodiscard]] float speed_target_mps() const noexcept { return speed_target_mps_; }
  /// The wheels' speed (m/s) as the drive model expects it: the last SET_RPM through drive_tau_s and
  /// drive_max_accel_mps2. Its acceleration is taken out of the accelerometer.
  [[nodiscard]] float drive_model_mps() const noexcept { return base_speed_model_mps_; }
  /// The gyro offset learnt so far (gy, deg/s).
  [[nodiscard]] float gyro_bias_dps() const noexcept { return gyro_bias_dps_; }
  [[nodiscard]] const interboard::Counters& uart_counters() const noexcept { return link_rx_.counters(); }
  // the loop trace (balance_trace.cpp, docs/protocol.md section 10)
  /// The test signal on the pitch setpoint now (none unless BALANCE) and its offset (degrees).
  [[nodiscard]] trace::Excite excitation() const noexcept { return excite_.kind(); }
  [[nodiscard]] float excitation_deg() const noexcept { return excite_.offset_deg(); }
  [[nodiscard]] const FlightRecorder& recorder() const noexcept { return recorder_; }
  [[nodiscard]] std::uint32_t trace_sent() const noexcept { return trace_sent_; }
  [[nodiscard]] std::uint32_t trace_dropped() const noexcept { return trace_dropped_; }
  /// The record of the last loop iteration (what the trace and the flight recorder got).
  [[nodiscard]] const trace::LoopTrace& last_trace() const noexcept { return last_trace_; }

 private:
  enum class Tri : std::uint8_t { unknown, no, yes };

  void boot(TimeUs now) noexcept;
  void read_imu(TimeUs now) noexcept;
  void read_link(TimeUs now) noexcept;
  void on_link_message(const interboard::Message& message, TimeUs now) noexcept;
  void read_can(TimeUs now) noexcept;
  void on_can_frame(const CanFrame& frame, TimeUs now) noexcept;
  void on_mode(saulcan::Mode mode) noexcept;
  void on_config(const saulcan::ConfigCmd& config) noexcept;
  void on_stager(const saulcan::StagerOutcome& outcome) noexcept;
  void update_live(TimeUs now) noexcept;
  void supervise(TimeUs now) noexcept;
  void read_console(TimeUs now) noexcept;
  void on_console_line(std::string_view line, bool overflowed, TimeUs now) noexcept;
  void control(TimeUs now) noexcept;
  void publish(TimeUs now) noexcept;

  /// Applies one event of the arming table (saulfw/arming.hpp): the cause bits, the hold cancel, the next state.
  /// Returns nullptr when done, else why it was refused (a short text for the console; the state stays).
  const char* apply(arming::Event event, std::uint8_t cause = 0) noexcept;
  void estop() noexcept;
  /// Writes the tilt limit and the 0x303 speed into the block a reset keeps (RetainedLimits, hal.hpp).
  void remember_limits() noexcept;
  /// Latches FAULT for a reason: the cause bits, the first reason kept, one console line.
  void fault(std::uint8_t cause, FaultReason reason) noexcept;
  /// The wheels' speed measured by both VESCs (mm/s, + forward); false when either is not fresh.
  bool measured_speed(TimeUs now, std::int64_t& mmps) const noexcept;
  /// The balance output (permille) in BALANCE: the speed loop's lean, then the balance PID.
  float balance_output(float request_mmps, std::int32_t cap, TimeUs now, float dt) noexcept;
  /// The table's arm event, then the arming checks: nullptr when armed, else why not. by_button: the IO flag's edge.
  const char* try_arm(bool by_button) noexcept;
  [[nodiscard]] bool armed() const noexcept;
  [[nodiscard]] bool latched() const noexcept;
  [[nodiscard]] bool estop_input() const noexcept;

  // the loop trace, the flight recorder and the excitation (balance_trace.cpp)
  void trace_loop(TimeUs now) noexcept;
  /// Stops the excitation at once unless the state is BALANCE, the speed request is within the dead band and the
  /// speed cap is within trace::kExciteMinCapPct..kExciteMaxCapPct.
  void excite_check() noexcept;
  /// The speed cap now is outside trace::kExciteMinCapPct..kExciteMaxCapPct of hard_max_speed_mmps: no test signal
  /// may run.
  [[nodiscard]] bool excite_cap_outside() const noexcept;
  /// A trace or excite console line: handled (true), or another command (false).
  bool on_trace_line(std::string_view line, TimeUs now) noexcept;
  void send_trace(const trace::LoopTrace& record) noexcept;
  void pump_dump() noexcept;
  void write_trace_status() noexcept;

  void send_ack(std::uint8_t command, std::uint8_t sequence, saulcan::AckResult result) noexcept;
  void send_link(const interboard::Message& message) noexcept;
  void send_wheels(std::int32_t left_erpm, std::int32_t right_erpm) noexcept;
  void send_state() noexcept;
  void send_led() noexcept;

  Hardware hw_;
  BalanceConfig config_;
  ResetReason reset_;

  ComplementaryFilter filter_;
  BalancePid pid_;
  BalancePid speed_pid_;  // the speed loop: output in permille of max_lean_deg
  saulcan::PidStager stager_;
  interboard::StreamDecoder link_rx_;
  LineAssembler console_in_;

  // state machine
  saulcan::RobotState state_ = saulcan::RobotState::off;
  std::uint8_t latched_faults_ = 0;
  std::uint8_t live_faults_ = saulcan::fault::kIoLinkLoss | saulcan::fault::kOrinTimeout;
  bool button_released_ = false;  // the arming button seen released (RC_CMD) since the last stop, disarm or power-on
  FaultReason fault_reason_ = FaultReason::none;
  bool imu_fault_seen_ = false;  // the present IMU stall has latched its FAULT (once per stall)
  bool io_silent_seen_ = false;  // the silent IO board at power-on has latched its FAULT
  bool estop_this_iteration_ = false;
  bool reboot_requested_ = false;

  // IO board
  interboard::RcCmd rc_{};
  TimeUs rc_us_ = 0;
  bool rc_seen_ = false;
  Tri io_armed_ = Tri::unknown;
  Tri disarm_switch_ = Tri::unknown;  // RC_CMD disarm_switch (CH5 at disarm): its edge leaves a latch for OFF
  bool io_arm_request_ = false;
  std::uint8_t io_faults_ = 0;
  interboard::Sensor sensor_{};

  // Orin
  saulcan::VelocityCmd velocity_{};
  TimeUs velocity_us_ = 0;
  bool velocity_seen_ = false;
  std::uint16_t tilt_limit_x100_;
  std::uint8_t speed_limit_pct_ = 10;
  std::uint16_t orin_max_speed_mmps_ = 0xFFFF;

  // VESCs
  struct Vesc {
    std::int32_t erpm = 0;
    TimeUs status_us = 0;
    bool status_seen = false;
  };
  Vesc left_{};
  Vesc right_{};
  /// A VESC's mechanical RPM from its last STATUS (0 before any), + forward.
  [[nodiscard]] std::int64_t mech_rpm(const Vesc& v, bool invert) const noexcept;
  std::uint16_t battery_mv_ = 0;

  // IMU and control
  TimeUs imu_ok_us_ = 0;
  bool imu_ever_ = false;
  bool imu_stalled_ = false;
  float gyro_bias_dps_ = 0.0F;  // the learnt zero-rate offset of gy
  TimeUs bias_us_ = 0;          // the last sample it learnt from
  std::int16_t pid_out_ = 0;
  TimeUs control_us_ = 0;
  float sent_mps_ = 0.0F;              // the wheel speed of the last SET_RPM (mean of both, m/s)
  float base_speed_model_mps_ = 0.0F;  // the wheels' speed as the drive_tau_s model expects it
  float base_accel_g_ = 0.0F;          // and their acceleration, in g, subtracted from the accelerometer's x
  float lean_deg_ = 0.0F;
  float speed_filtered_mps_ = 0.0F;    // the measured speed through speed_filter_tau_s
  float speed_target_mps_ = 0.0F;      // the request through speed_ramp_mps2
  TimeUs balance_since_us_ = 0;        // when BALANCE was entered (the speed loop's settling time counts from it)
  bool balancing_ = false;
  std::int32_t wheel_left_mmps_ = 0;
  std::int32_t wheel_right_mmps_ = 0;
  bool wheels_driving_ = false;

  // schedules and change detection
  Every motor_tx_;
  Every telemetry_tx_;
  Every state_tx_;
  Every led_tx_;
  Every display_tx_;
  saulcan::RobotState published_state_ = saulcan::RobotState::off;
  bool started_ = false;
  TimeUs boot_us_ = 0;
  TimeUs last_step_us_ = 0;

  char scratch_[console::kMaxReply]{};

  // the loop trace (balance_trace.cpp)
  Excitation excite_;
  float setpoint_deg_ = 0.0F;      // the balance PID's setpoint in the last iteration (with the excitation)
  float request_mmps_ = 0.0F;      // the speed request in the last iteration
  std::uint32_t loop_seq_ = 0;     // loop iterations since power-on: the records' seq
  std::uint16_t trace_divider_ = 0;  // 0: not streaming
  std::uint32_t trace_sent_ = 0;
  std::uint32_t trace_dropped_ = 0;
  bool trace_was_armed_ = false;   // the last iteration was BALANCE/MANUAL (a latch after it freezes the recorder)
  std::size_t dump_next_ = 0;      // the next flight-recorder record to send
  bool dumping_ = false;
  trace::LoopTrace last_trace_{};
  FlightRecorder recorder_;
};

}  // namespace saul::fw
