#include "saulfw/balance.hpp"

#include <cmath>
#include <variant>

#include "saulfw/mutant.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/vesc.hpp"

namespace saul::fw {

using saulcan::AckResult;
using saulcan::RobotState;
namespace fault = saulcan::fault;

namespace {

constexpr std::int16_t saturate16(std::int64_t v) noexcept {
  return static_cast<std::int16_t>(v > 32767 ? 32767 : (v < -32768 ? -32768 : v));
}

/// A float wheel speed as whole mm/s within +-cap, truncated toward zero; NaN gives 0.
std::int32_t whole_mmps(float v, std::int32_t cap) noexcept {
  if (!std::isfinite(v)) return 0;
  const auto c = static_cast<float>(cap);
  if (v > c) return cap;
  if (v < -c) return -cap;
  auto i = static_cast<std::int32_t>(v);
  return i > cap ? cap : (i < -cap ? -cap : i);
}

constexpr std::uint8_t kAckPid = static_cast<std::uint8_t>(saulcan::kPidGainId & 0xFFU);
constexpr std::uint8_t kAckMode = static_cast<std::uint8_t>(saulcan::kModeCmdId & 0xFFU);
constexpr std::uint8_t kAckConfig = static_cast<std::uint8_t>(saulcan::kConfigCmdId & 0xFFU);
static_assert(kAckPid == 0x01 && kAckMode == 0x02 && kAckConfig == 0x03);

/// The speed loop's gains for a BalancePid whose output is in permille of max_lean_deg (0 when it is not above 0).
saulcan::PidGains speed_gains(const BalanceConfig& c) noexcept {
  if (!(c.max_lean_deg > 0.0F)) return {0.0F, 0.0F, 0.0F};
  const float permille_per_deg = BalancePid::kOutputLimit / c.max_lean_deg;
  return {c.speed_kp_deg_per_mps * permille_per_deg, c.speed_ki_deg_per_m * permille_per_deg, 0.0F};
}

constexpr std::uint16_t clamp_tilt(std::uint16_t x100) noexcept {
  return x100 < saulcan::ConfigCmd::kMinTiltX100
             ? saulcan::ConfigCmd::kMinTiltX100
             : (x100 > saulcan::ConfigCmd::kMaxTiltX100 ? saulcan::ConfigCmd::kMaxTiltX100 : x100);
}

}  // namespace

BalanceBoard::BalanceBoard(const Hardware& hw, const BalanceConfig& config, ResetReason reset) noexcept
    : hw_(hw),
      config_(config),
      reset_(reset),
      filter_(config.filter_tau_s),
      pid_(config.gains, config.integral_limit),
      speed_pid_(speed_gains(config), BalancePid::kOutputLimit),
      tilt_limit_x100_(clamp_tilt(config.tilt_limit_x100)),
      motor_tx_(config.motor_period_us),
      telemetry_tx_(config.telemetry_period_us),
      state_tx_(config.state_period_us),
      led_tx_(config.led_period_us),
      display_tx_(config.display_period_us) {}

// ---- the loop ---------------------------------------------------------------------------------------------------

void BalanceBoard::boot(TimeUs now) noexcept {
  started_ = true;
  boot_us_ = now;
  last_step_us_ = now;
  imu_ok_us_ = now;
  control_us_ = now;
  if (reset_ == ResetReason::watchdog) {
    state_ = RobotState::fault;
    latched_faults_ = fault::kWatchdogReset;
    fault_reason_ = FaultReason::watchdog_reset;
  }
  RetainedLimits& kept = hw_.retained;
  if (reset_ != ResetReason::power_on && kept.check == kept.expected() &&
      kept.tilt_limit_x100 >= saulcan::ConfigCmd::kMinTiltX100) {
    // Tighten only: a kept limit never loosens what the configuration gives.
    if (kept.tilt_limit_x100 < tilt_limit_x100_) tilt_limit_x100_ = kept.tilt_limit_x100;
    if (kept.orin_max_speed_mmps < orin_max_speed_mmps_) orin_max_speed_mmps_ = kept.orin_max_speed_mmps;
    write_text(hw_.console, "limits kept across the reset (tilt limit, 0x303 speed): see status\n");
  }
  remember_limits();
  published_state_ = state_;
}

void BalanceBoard::step(TimeUs now) noexcept {
  if (!started_) {
    boot(now);
  } else if (age(now, last_step_us_) > config_.hang_us && armed()) {
    fault(fault::kWatchdogReset, FaultReason::loop_hang);  // the loop stood still: never carry on as if nothing happened
  }
  last_step_us_ = now;
  estop_this_iteration_ = false;

  read_imu(now);
  read_link(now);
  read_can(now);
  update_live(now);
  supervise(now);
  excite_check();  // a latch or disarm so far stops the test signal before anything can arm again
  if (io_arm_request_) {
    io_arm_request_ = false;
    (void)try_arm(true);
  }
  read_console(now);
  control(now);
  publish(now);
  trace_loop(now);
  hw_.watchdog.feed();  // the loop ran to its end; a missing sensor is a FAULT above, not a reboot loop
}

void BalanceBoard::read_imu(TimeUs now) noexcept {
  ImuSample sample;
  bool accepted = false;
  for (int i = 0; i < 16 && hw_.imu.read(sample); ++i) {
    sample.ax -= base_accel_g_;  // the base's own acceleration is not tilt (small-angle: x axis only)
    const float raw_gy = sample.gy;
    sample.gy -= gyro_bias_dps_;
    if (!filter_.update(sample)) continue;
    accepted = true;
    // Learn the gyro's offset while the motors are off and the body looks still.
    const TimeUs gap = sample.t_us > bias_us_ ? sample.t_us - bias_us_ : 0;
    bias_us_ = sample.t_us;
    if (armed() || !(config_.gyro_bias_tau_s > 0.0F) || std::fabs(sample.gy) >= config_.gyro_still_dps ||
        gap > ComplementaryFilter::kMaxGapUs)
      continue;
    const float dt = static_cast<float>(gap) * 1e-6F;
    gyro_bias_dps_ += (raw_gy - gyro_bias_dps_) * dt / (config_.gyro_bias_tau_s + dt);
  }
  if (accepted) {  // freshness by the sample's own timestamp: a backlog read late is not fresh data
    imu_ok_us_ = filter_.last_us() > now ? now : filter_.last_us();
    imu_ever_ = true;
  }
}

// ---- inter-board link ---------------------------------------------------------------------------------------------

void BalanceBoard::read_link(TimeUs now) noexcept {
  std::uint8_t buffer[64];
  for (int round = 0; round < 8; ++round) {
    const std::size_t n = hw_.link.read(buffer);
    if (n == 0) break;
    for (std::size_t i = 0; i < n && i < sizeof buffer; ++i)
      if (auto m = link_rx_.push(buffer[i])) {
        on_link_message(*m, now);
        excite_check();
      }
  }
}

void BalanceBoard::on_link_message(const interboard::Message& message, TimeUs now) noexcept {
  if (const auto* rc = std::get_if<interboard::RcCmd>(&message)) {
    rc_ = *rc;
    rc_us_ = now;
    rc_seen_ = true;
    if (rc->kill()) estop();
    if (rc->armed()) {
      if (io_armed_ == Tri::no) io_arm_request_ = true;  // a fresh arming: 0 -> 1 seen on two valid RC_CMDs
      io_armed_ = Tri::yes;
    } else {
      // The IO board dropped its flag: a disarm while armed. In a latch it dropped it because of the latch, and in
      // OFF after an arming BALANCE refused: neither is an operator's disarm.
      if (io_armed_ == Tri::yes && armed()) (void)apply(arming::Event::disarm);
      io_armed_ = Tri::no;
    }
    if (!rc->button()) button_released_ = true;
    // A live radio with CH5 at disarm: disarmed now and kept so (every RC_CMD); its edge (from a seen "at arm") is
    // also the radio's way out of a latch, to OFF. A level already there at power-on or when the link returns is no
    // edge: a latch (a reset's FAULT) stays on the display until the operator moves the switch.
    if (rc->disarm_switch() && !SAUL_MUTANT(arm_switch)) {
      if (disarm_switch_ == Tri::no || !latched()) (void)apply(arming::Event::disarm);
      disarm_switch_ = Tri::yes;
    } else {
      disarm_switch_ = rc->disarm_switch() ? Tri::yes : Tri::no;
    }
  } else if (const auto* f = std::get_if<interboard::Fault>(&message)) {
    io_faults_ = f->flags;
    if ((f->flags & interboard::Fault::kEstop) != 0) estop();
    // RC loss while armed latches FAULT on the message itself: the RC_CMD that drops the armed flag may follow in
    // this same read, and must not turn the loss into a plain disarm.
    if ((f->flags & interboard::Fault::kRcLoss) != 0 && armed() && !SAUL_MUTANT(rc_loss_stop))
      fault(fault::kRcLoss, FaultReason::rc_lost);
  } else if (const auto* s = std::get_if<interboard::Sensor>(&message)) {
    sensor_ = *s;
  }
  // STATE, LED_CMD and BUZZER travel the other way; one arriving here is ignored.
}

// ---- CAN ------------------------------------------------------------------------------------------------------------

void BalanceBoard::read_can(TimeUs now) noexcept {
  CanFrame frame;
  for (int i = 0; i < 32 && hw_.can.receive(frame); ++i) {
    on_can_frame(frame, now);
    excite_check();
  }
  on_stager(stager_.poll(now));
}

void BalanceBoard::on_can_frame(const CanFrame& frame, TimeUs now) noexcept {
  const auto decoded = decode_bus_frame(frame);
  if (!decoded) {
    // A well-formed 0x302 with a mode that does not exist is a handled command: refuse it out loud.
    if (decoded.reason() == Reason::out_of_range && !frame.extended && frame.id == saulcan::kModeCmdId)
      send_ack(kAckMode, 0, AckResult::out_of_range);
    return;
  }
  const BusMessage& m = *decoded;
  if (const auto* v = std::get_if<saulcan::VelocityCmd>(&m)) {
    velocity_ = *v;
    velocity_us_ = now;
    velocity_seen_ = true;
  } else if (const auto* g = std::get_if<saulcan::PidGain>(&m)) {
    on_stager(stager_.accept(*g, now));
  } else if (const auto* mode = std::get_if<saulcan::ModeCmd>(&m)) {
    on_mode(mode->mode);
  } else if (const auto* c = std::get_if<saulcan::ConfigCmd>(&m)) {
    on_config(*c);
  } else if (const auto* s1 = std::get_if<vesc::Status1>(&m)) {
    Vesc* wheel =
        s1->controller_id == vesc::kLeftId ? &left_ : (s1->controller_id == vesc::kRightId ? &right_ : nullptr);
    if (wheel != nullptr) {
      wheel->erpm = s1->erpm;
      wheel->status_us = now;
      wheel->status_seen = true;
    }
  } else if (const auto* s5 = std::get_if<vesc::Status5>(&m)) {
    if ((s5->controller_id == vesc::kLeftId || s5->controller_id == vesc::kRightId) && s5->voltage_in_x10 > 0) {
      const std::int32_t mv = static_cast<std::int32_t>(s5->voltage_in_x10) * 100;
      battery_mv_ = static_cast<std::uint16_t>(mv > 65535 ? 65535 : mv);
    }
  }
}

void BalanceBoard::on_mode(saulcan::Mode mode) noexcept {
  switch (mode) {
    case saulcan::Mode::off:
      send_ack(kAckMode, 0, apply(arming::Event::disarm) == nullptr ? AckResult::applied : AckResult::not_allowed);
      return;
    case saulcan::Mode::estop:
      estop();
      send_ack(kAckMode, 0, AckResult::applied);
      return;
    case saulcan::Mode::balance:
    case saulcan::Mode::manual: {
      if (!armed()) {  // the mode frame never arms the robot
        send_ack(kAckMode, 0, AckResult::not_allowed);
        return;
      }
      const RobotState to = mode == saulcan::Mode::balance ? RobotState::balance : RobotState::manual;
      if (state_ != to) {
        state_ = to;
        pid_.reset();
      }
      send_ack(kAckMode, 0, AckResult::applied);
      return;
    }
  }
}

void BalanceBoard::on_config(const saulcan::ConfigCmd& config) noexcept {
  if (config.tilt_limit_x100 < saulcan::ConfigCmd::kMinTiltX100 ||
      config.tilt_limit_x100 > saulcan::ConfigCmd::kMaxTiltX100) {
    send_ack(kAckConfig, 0, AckResult::out_of_range);  // never clamped; neither field is applied
    return;
  }
  tilt_limit_x100_ = config.tilt_limit_x100;
  orin_max_speed_mmps_ = config.max_speed_mmps;  // can only lower the cap: see speed_cap_mmps()
  remember_limits();
  send_ack(kAckConfig, 0, AckResult::applied);
}

void BalanceBoard::on_stager(const saulcan::StagerOutcome& outcome) noexcept {
  using Kind = saulcan::StagerOutcome::Kind;
  if (outcome.kind == Kind::none) return;
  if (outcome.kind == Kind::applied) pid_.set_gains(outcome.gains);
  send_ack(kAckPid, outcome.sequence, outcome.result);
}

// ---- supervision ------------------------------------------------------------------------------------------------

void BalanceBoard::update_live(TimeUs now) noexcept {
  std::uint8_t live = 0;
  const bool link = rc_seen_ && age(now, rc_us_) <= config_.io_link_timeout_us;
  if (!link) {
    live |= fault::kIoLinkLoss;
    io_armed_ = Tri::unknown;  // the next arming needs a 0 seen first
    disarm_switch_ = Tri::unknown;
    io_arm_request_ = false;
  } else {
    if ((io_faults_ & interboard::Fault::kRcLoss) != 0) live |= fault::kRcLoss;
    if ((io_faults_ & interboard::Fault::kMotorFault) != 0) live |= fault::kMotorFault;
    if (rc_.kill() || (io_faults_ & interboard::Fault::kEstop) != 0) live |= fault::kEstop;
  }
  if (!velocity_seen_ || age(now, velocity_us_) > config_.orin_timeout_us) live |= fault::kOrinTimeout;
  for (const Vesc* v : {&left_, &right_})
    if (v->status_seen && age(now, v->status_us) > config_.vesc_status_timeout_us) live |= fault::kMotorFault;
  if (battery_mv_ != 0 && battery_mv_ < config_.low_battery_mv) live |= fault::kLowBattery;
  const TimeUs stall_limit = imu_ever_ ? config_.imu_stall_us : config_.imu_startup_us;
  imu_stalled_ = age(now, imu_ok_us_) > stall_limit;
  live_faults_ = live;
}

void BalanceBoard::supervise(TimeUs now) noexcept {
  if (estop_input() && state_ != RobotState::estop) estop();
  if (SAUL_MUTANT(estop_latch) && state_ == RobotState::estop && !estop_input()) state_ = RobotState::off;
  // A missing or silent sensor is a FAULT whether armed or not (once per stall), never a reboot loop.
  if (imu_stalled_ && !imu_fault_seen_) {
    fault(fault::kWatchdogReset, imu_ever_ ? FaultReason::imu_silent : FaultReason::imu_missing);
  }
  imu_fault_seen_ = imu_stalled_;
  if (!rc_seen_ && !io_silent_seen_ && age(now, boot_us_) > config_.io_startup_us) {
    io_silent_seen_ = true;
    fault(fault::kIoLinkLoss, FaultReason::io_link_silent);
  }
  if (!armed()) return;
  std::uint8_t causes = live_faults_ & (fault::kIoLinkLoss | fault::kRcLoss | fault::kMotorFault);
  if (SAUL_MUTANT(rc_loss_stop)) causes &= static_cast<std::uint8_t>(~fault::kRcLoss);
  if (SAUL_MUTANT(link_loss_stop)) causes &= static_cast<std::uint8_t>(~fault::kIoLinkLoss);
  const bool tilted = !imu_stalled_ && filter_.valid() &&
                      std::fabs(filter_.pitch_deg()) * 100.0F > static_cast<float>(tilt_limit_x100_);
  if (tilted && !SAUL_MUTANT(tilt_cutoff)) (void)apply(arming::Event::tilt, fault::kTiltCutoff);
  if (causes != 0) {
    fault(causes, (causes & fault::kIoLinkLoss) != 0 ? FaultReason::io_link_lost
                  : (causes & fault::kRcLoss) != 0  ? FaultReason::rc_lost
                                                    : FaultReason::motor);
  }
}

bool BalanceBoard::armed() const noexcept { return state_ == RobotState::balance || state_ == RobotState::manual; }

bool BalanceBoard::latched() const noexcept {
  return state_ == RobotState::estop || state_ == RobotState::tilt_cutoff || state_ == RobotState::fault;
}

bool BalanceBoard::estop_input() const noexcept { return (live_faults_ & fault::kEstop) != 0; }

void BalanceBoard::remember_limits() noexcept {
  RetainedLimits& kept = hw_.retained;
  kept.tilt_limit_x100 = tilt_limit_x100_;
  kept.orin_max_speed_mmps = orin_max_speed_mmps_;
  kept.check = kept.expected();
}

void BalanceBoard::estop() noexcept {
  estop_this_iteration_ = true;
  (void)apply(arming::Event::estop, fault::kEstop);
}

const char* BalanceBoard::apply(arming::Event event, std::uint8_t cause) noexcept {
  const arming::Rule& rule = arming::rule(state_, event);
  latched_faults_ |= cause;
  // Every stop and every disarm cancels a hold in progress, whether or not the state changes: a press that began
  // before it can no longer arm (rule 1). The mutant keeps the hold where the state stays (the bug of issue 33).
  if (rule.cancels_hold && !(SAUL_MUTANT(hold_cancel) && rule.next == state_)) {
    // A press under way (the last RC_CMD says the button is down, or the link is not fresh enough to say) can no
    // longer arm; with the button seen up just now there is no press to cancel, and the next one is a new one.
    const bool seen_up = rc_seen_ && (live_faults_ & fault::kIoLinkLoss) == 0 && !rc_.button();
    button_released_ = button_released_ && seen_up;
    io_arm_request_ = false;
  }
  if (rule.refusal != nullptr && !(SAUL_MUTANT(arm_from_latch) && latched())) return rule.refusal;
  if (rule.kept_by_estop_input && (estop_input() || estop_this_iteration_))
    return "ESTOP stays while an estop input is active (kill switch, CH6, IO console estop)";
  if (event == arming::Event::arm) return nullptr;  // allowed from here; try_arm's checks decide
  state_ = rule.next;  // OFF after a latch keeps its cause bits in 0x401 until the next arming
  return nullptr;
}

void BalanceBoard::fault(std::uint8_t cause, FaultReason reason) noexcept {
  (void)apply(arming::Event::fault, cause);
  if (fault_reason_ == FaultReason::none) fault_reason_ = reason;
  write_text(hw_.console, "FAULT: ");
  write_text(hw_.console, fault_reason_text(reason));
  write_text(hw_.console, state_ == RobotState::fault ? " (motors off)\n" : " (motors off, state stays latched)\n");
}

const char* BalanceBoard::try_arm(bool by_button) noexcept {
  if (const char* why = apply(arming::Event::arm)) return why;
  if (estop_this_iteration_ || estop_input()) return "emergency stop active";
  if (by_button && !button_released_ && !SAUL_MUTANT(new_press))
    return "the arming button was not released since the last stop: a new press is needed";
  if (reboot_requested_) return "reboot pending";
  if (imu_stalled_ || !filter_.valid()) return "no pitch from the IMU";
  if (std::fabs(filter_.pitch_deg()) * 100.0F > static_cast<float>(config_.upright_x100))
    return "not upright (|pitch| must be 5 degrees or less)";
  if ((live_faults_ & fault::kIoLinkLoss) != 0) return "no link to the IO board";
  if ((live_faults_ & fault::kRcLoss) != 0) return "RC link lost";
  if (rc_.disarm_switch() && !SAUL_MUTANT(arm_switch)) return "the ARM switch (CH5) is at disarm";
  if (rc_.throttle != 0 && !SAUL_MUTANT(throttle_centred)) return "the throttle stick is not centred";
  if ((live_faults_ & fault::kMotorFault) != 0) return "motor fault";
  state_ = RobotState::balance;
  latched_faults_ = 0;
  fault_reason_ = FaultReason::none;
  pid_.reset();
  balancing_ = false;
  return nullptr;
}

// ---- console ------------------------------------------------------------------------------------------------------

void BalanceBoard::read_console(TimeUs now) noexcept {
  console_in_.pump(hw_.console, [&](std::string_view line, bool overflowed) {
    on_console_line(line, overflowed, now);
    excite_check();
  });
}

void BalanceBoard::on_console_line(std::string_view line, bool overflowed, TimeUs now) noexcept {
  SerialPort& out = hw_.console;
  if (!overflowed && on_trace_line(line, now)) return;
  console::ParseResult parsed;
  const console::Command* command = read_command(out, line, overflowed, parsed, scratch_);
  if (command == nullptr) return;
  const auto ok = [&] { write_ok(out, scratch_); };
  using console::Verb;
  switch (console::verb_of(*command)) {
    case Verb::help:
      write_formatted(out, console::format_help(scratch_), scratch_);
      write_text(out, trace::kHelp);
      ok();
      return;
    case Verb::status: {
      console::StatusReport r;
      r.board = console::Board::balance;
      r.state = state_;
      r.pitch_x100 = pitch_x100();
      r.pid_out = pid_out_;
      r.kp = pid_.gains().kp;
      r.ki = pid_.gains().ki;
      r.kd = pid_.gains().kd;
      r.tilt_limit_x100 = tilt_limit_x100_;
      r.speed_limit_pct = speed_limit_pct_;
      r.faults = faults();
      r.battery_mv = battery_mv_;
      r.uptime_ms = static_cast<std::uint32_t>(age(now, boot_us_) / 1000U);
      write_trace_status();
      write_status(out, r, hw_.can.stats(), console::UartStats::from(link_rx_.counters()), scratch_);
      return;
    }
    case Verb::pid: {
      if (const auto* p = std::get_if<console::PidCmd>(command)) pid_.set_gains({p->kp, p->ki, p->kd});
      ok();
      return;
    }
    case Verb::arm:
      if (const char* why = try_arm(false)) {
        write_refusal(out, why);
      } else {
        ok();
      }
      return;
    case Verb::disarm:
      if (const char* why = apply(arming::Event::disarm)) {
        write_refusal(out, why);
      } else {
        ok();
      }
      return;
    case Verb::estop:
      estop();
      ok();
      return;
    case Verb::tilt_limit:
      if (const auto* t = std::get_if<console::TiltLimitCmd>(command)) {
        tilt_limit_x100_ = t->tilt_limit_x100;
        remember_limits();
      }
      ok();
      return;
    case Verb::speed_limit: {
      const auto* limit = std::get_if<console::SpeedLimitCmd>(command);
      const std::uint8_t pct = limit != nullptr ? limit->percent : speed_limit_pct_;
      if (pct > speed_limit_pct_ && armed() && !SAUL_MUTANT(raise_while_armed)) {
        write_refusal(out, "raise the speed limit only while disarmed");
        return;
      }
      if (pct > speed_limit_pct_ + console::SpeedLimitCmd::kStep) {
        write_refusal(out, "raise the speed limit one 10 % step at a time");
        return;
      }
      if (pct != speed_limit_pct_) state_tx_.trigger();  // the IO board's drivers follow at once (SPEED_CAP)
      speed_limit_pct_ = pct;
      ok();
      return;
    }
    case Verb::can_stats:
      write_stats(out, hw_.can.stats(), scratch_);
      return;
    case Verb::uart_stats:
      write_stats(out, console::UartStats::from(link_rx_.counters()), scratch_);
      return;
    case Verb::reboot:
      if (armed()) {
        write_refusal(out, "disarm before rebooting");
        return;
      }
      reboot_requested_ = true;
      ok();
      return;
  }
}

// ---- control ------------------------------------------------------------------------------------------------------

std::uint16_t BalanceBoard::speed_cap_mmps() const noexcept {
  if (SAUL_MUTANT(speed_cap)) return config_.hard_max_speed_mmps;
  const std::uint32_t pct_cap = static_cast<std::uint32_t>(config_.hard_max_speed_mmps) * speed_limit_pct_ / 100U;
  const std::uint32_t cap = pct_cap < orin_max_speed_mmps_ ? pct_cap : orin_max_speed_mmps_;
  return static_cast<std::uint16_t>(cap);
}

std::int32_t BalanceBoard::erpm_of(std::int32_t mmps) const noexcept {
  if (config_.wheel_circumference_mm == 0) return 0;
  const std::int64_t e = static_cast<std::int64_t>(mmps) * 60 * config_.pole_pairs / config_.wheel_circumference_mm;
  return static_cast<std::int32_t>(e);
}

void BalanceBoard::control(TimeUs now) noexcept {
  float dt = static_cast<float>(age(now, control_us_)) * 1e-6F;
  if (dt > 0.02F) dt = 0.02F;
  control_us_ = now;
  excite_check();
  request_mmps_ = 0.0F;
  setpoint_deg_ = config_.pitch_setpoint_deg;

  const bool drive = armed() && !imu_stalled_ && filter_.valid();
  const auto cap = static_cast<std::int32_t>(speed_cap_mmps());
  float left = 0.0F;
  float right = 0.0F;
  if (drive) {
    const auto hard_max = static_cast<float>(config_.hard_max_speed_mmps);
    const auto max_steer = static_cast<float>(config_.max_steer_mrad);
    float v = 0.0F;
    float steer = 0.0F;
    if (orin_active()) {
      v = static_cast<float>(velocity_.speed_mmps);
      steer = static_cast<float>(velocity_.steer_mrad);
    } else if ((live_faults_ & fault::kIoLinkLoss) == 0) {  // RC only
      v = static_cast<float>(rc_.throttle) * hard_max / 1000.0F;
      steer = static_cast<float>(rc_.steer) * max_steer / 1000.0F;
    }
    if (steer > max_steer) steer = max_steer;
    if (steer < -max_steer) steer = -max_steer;
    request_mmps_ = v;
    float base = v;
    if (state_ == RobotState::balance) {  // the request goes through the speed loop, never to the wheels directly
      const float out = balance_output(v, cap, now, dt);
      pid_out_ = static_cast<std::int16_t>(std::lround(out));
      base = out * hard_max / 1000.0F;
    } else {
      pid_.reset();
      balancing_ = false;
      lean_deg_ = 0.0F;
      pid_out_ = 0;
    }
    // Steering angle -> wheel speed difference (bicycle model: yaw rate = v tan(steer) / wheelbase).
    const float diff = config_.wheelbase_mm == 0
                           ? 0.0F
                           : base * std::tan(steer / 1000.0F) * static_cast<float>(config_.track_mm) /
                                 (2.0F * static_cast<float>(config_.wheelbase_mm));
    left = base - diff;
    right = base + diff;
    const float biggest = std::fabs(left) > std::fabs(right) ? std::fabs(left) : std::fabs(right);
    if (biggest > static_cast<float>(cap)) {  // scale both: the turn keeps its shape, the cap holds
      const float k = static_cast<float>(cap) / biggest;
      left *= k;
      right *= k;
    }
  } else {
    pid_.reset();
    balancing_ = false;
    lean_deg_ = 0.0F;
    pid_out_ = 0;
  }
  wheel_left_mmps_ = whole_mmps(left, cap);
  wheel_right_mmps_ = whole_mmps(right, cap);

  const bool change = drive != wheels_driving_;  // starting or, above all, stopping: at once
  wheels_driving_ = drive;
  if (motor_tx_.due(now) || change) {
    const std::int32_t l = erpm_of(wheel_left_mmps_);
    const std::int32_t r = erpm_of(wheel_right_mmps_);
    send_wheels(config_.invert_left ? -l : l, config_.invert_right ? -r : r);
    // What the VESCs now hold until the next SET_RPM: their mean ERPM back in m/s (mechanical RPM x circumference).
    sent_mps_ = config_.pole_pairs == 0 ? 0.0F
                                        : static_cast<float>(l + r) * 0.5F / static_cast<float>(config_.pole_pairs) *
                                              static_cast<float>(config_.wheel_circumference_mm) / 60'000.0F;
  }
  // The drive model follows the command as the VESCs receive it (every motor_period_us), not the wheel speed
  // worked out every loop: between two SET_RPMs the wheels still chase the last one.
  if (config_.drive_tau_s > 0.0F && dt > 0.0F) {
    float a = (sent_mps_ - base_speed_model_mps_) / config_.drive_tau_s;
    const float limit = config_.drive_max_accel_mps2;
    a = a > limit ? limit : (a < -limit ? -limit : a);
    base_speed_model_mps_ += a * dt;
    base_accel_g_ = a / 9.80665F;
  }
}

float BalanceBoard::balance_output(float request_mmps, std::int32_t cap, TimeUs now, float dt) noexcept {
  // Outer loop: the request, within its share of the cap, against the measured speed (the drive model's when the
  // VESCs do not report) -> a lean within +-max_lean_deg (forward = nose down = a negative pitch setpoint).
  if (!balancing_) {
    balancing_ = true;
    balance_since_us_ = now;
    speed_pid_.reset();
    speed_filtered_mps_ = base_speed_model_mps_;
    speed_target_mps_ = 0.0F;
  }
  const float most = age(now, balance_since_us_) < config_.speed_settle_us
                         ? 0.0F
                         : config_.speed_request_share * static_cast<float>(cap);
  const float request = (request_mmps > most ? most : (request_mmps < -most ? -most : request_mmps)) * 1e-3F;
  std::int64_t measured = 0;
  const float speed_mps =
      measured_speed(now, measured) ? static_cast<float>(measured) * 1e-3F : base_speed_model_mps_;
  speed_filtered_mps_ += (speed_mps - speed_filtered_mps_) * dt / (config_.speed_filter_tau_s + dt);
  if (!std::isfinite(speed_filtered_mps_)) speed_filtered_mps_ = 0.0F;
  // The target follows the request at speed_ramp_mps2, and waits while the wheels lag it by more than
  // speed_guard_share of the cap: a robot still catching its balance is not asked for more.
  const float step = config_.speed_ramp_mps2 * dt;
  const float delta = request - speed_target_mps_;
  const float lag = speed_target_mps_ - speed_filtered_mps_;
  const bool away = delta * speed_target_mps_ > 0.0F || speed_target_mps_ == 0.0F;  // the target grows
  const bool wait = away && std::fabs(lag) > config_.speed_guard_share * static_cast<float>(cap) * 1e-3F;
  if (!wait) speed_target_mps_ += step > 0.0F ? (delta > step ? step : (delta < -step ? -step : delta)) : delta;
  // While a test signal runs the speed loop's lean is held where it was when the signal began (its PI is not
  // updated, so nothing winds up meanwhile): the signal then meets the pitch loop alone. Otherwise the speed loop
  // answers a step by moving the setpoint back, and no direct step test sees the pitch loop by itself
  // (docs/tuning.md). excite_check() ends the signal before the held lean can drive the robot into the speed cap.
  if (!excite_.active())
    lean_deg_ = speed_pid_.update(speed_target_mps_ - speed_filtered_mps_, 0.0F, dt) * config_.max_lean_deg /
                BalancePid::kOutputLimit;
  // Inner loop: the balance PID holds that lean, plus the test signal while one runs (excite_check() stops it).
  setpoint_deg_ = config_.pitch_setpoint_deg - lean_deg_ + excite_.update(now);
  return pid_.update(setpoint_deg_ - filter_.pitch_deg(), filter_.rate_dps(), dt);
}

bool BalanceBoard::measured_speed(TimeUs now, std::int64_t& mmps) const noexcept {
  const bool fresh = left_.status_seen && right_.status_seen &&
                     age(now, left_.status_us) <= config_.vesc_status_timeout_us &&
                     age(now, right_.status_us) <= config_.vesc_status_timeout_us;
  if (!fresh) return false;
  mmps = (mech_rpm(left_, config_.invert_left) + mech_rpm(right_, config_.invert_right)) *
         config_.wheel_circumference_mm / 120;  // mean mechanical RPM x circumference / 60 s
  return true;
}

std::int64_t BalanceBoard::mech_rpm(const Vesc& v, bool invert) const noexcept {
  if (!v.status_seen || config_.pole_pairs == 0) return 0;
  const std::int64_t e = invert ? -static_cast<std::int64_t>(v.erpm) : v.erpm;
  return e / config_.pole_pairs;
}

void BalanceBoard::send_wheels(std::int32_t left_erpm, std::int32_t right_erpm) noexcept {
  (void)hw_.can.send(vesc::encode(vesc::SetRpm{vesc::kLeftId, left_erpm}));
  (void)hw_.can.send(vesc::encode(vesc::SetRpm{vesc::kRightId, right_erpm}));
}

// ---- outputs ------------------------------------------------------------------------------------------------------

std::int16_t BalanceBoard::pitch_x100() const noexcept {
  if (!filter_.valid()) return 32767;  // unknown: never "upright"
  return saturate16(std::lround(filter_.pitch_deg() * 100.0F));  // single precision: the S3's FPU has no double
}

LcdView BalanceBoard::view() const noexcept {
  LcdView v;
  v.pitch_x100 = pitch_x100();
  v.speed_mmps = saturate16((static_cast<std::int64_t>(wheel_left_mmps_) + wheel_right_mmps_) / 2);
  v.battery_known = battery_mv_ != 0;
  v.battery_mv = battery_mv_;
  if (v.battery_known && config_.battery_full_mv > config_.battery_empty_mv) {
    const std::int32_t span = config_.battery_full_mv - config_.battery_empty_mv;
    std::int32_t pct = (static_cast<std::int32_t>(battery_mv_) - config_.battery_empty_mv) * 100 / span;
    pct = pct < 0 ? 0 : (pct > 100 ? 100 : pct);
    v.battery_pct = static_cast<std::uint8_t>(pct);
  }
  v.state = state_;
  v.faults = faults();
  v.speed_limit_pct = speed_limit_pct_;
  v.tilt_limit_x100 = tilt_limit_x100_;
  v.orin_active = orin_active();
  v.fault_reason = fault_reason_;
  return v;
}

void BalanceBoard::send_ack(std::uint8_t command, std::uint8_t sequence, AckResult result) noexcept {
  (void)hw_.can.send(saulcan::encode(saulcan::CommandAck{command, sequence, result}));
}

void BalanceBoard::send_link(const interboard::Message& message) noexcept {
  std::uint8_t buffer[interboard::kMaxFrameSize];
  const auto n = interboard::encode(message, buffer);
  if (n) (void)hw_.link.write(std::span<const std::uint8_t>(buffer, *n));
}

void BalanceBoard::send_state() noexcept {
  send_link(interboard::State{pitch_x100(), pid_out_, static_cast<std::uint8_t>(state_)});
}

void BalanceBoard::send_led() noexcept {
  const LedCommand c = led_for_state(state_);
  send_link(interboard::LedCmd{static_cast<std::uint8_t>(c.pattern), c.color.r, c.color.g, c.color.b});
}

void BalanceBoard::publish(TimeUs now) noexcept {
  if (state_ != published_state_) {
    const bool was_armed = published_state_ == RobotState::balance || published_state_ == RobotState::manual;
    if (latched()) {
      send_link(interboard::Buzzer{static_cast<std::uint8_t>(Tone::alarm), 1000});
    } else if (armed() && !was_armed) {
      send_link(interboard::Buzzer{static_cast<std::uint8_t>(Tone::armed), 200});
    } else if (state_ == RobotState::off) {
      send_link(interboard::Buzzer{static_cast<std::uint8_t>(Tone::disarmed), 150});
    }
    published_state_ = state_;
    state_tx_.trigger();
    led_tx_.trigger();
  }
  if (state_tx_.due(now)) {
    send_state();
    send_link(interboard::SpeedCap{speed_limit_pct_});
  }
  if (led_tx_.due(now)) send_led();
  if (telemetry_tx_.due(now)) {
    // Speed: the wheels' measured average when both VESCs report, else what is commanded.
    std::int64_t speed = (static_cast<std::int64_t>(wheel_left_mmps_) + wheel_right_mmps_) / 2;
    (void)measured_speed(now, speed);
    const std::int64_t l_rpm = mech_rpm(left_, config_.invert_left);
    const std::int64_t r_rpm = mech_rpm(right_, config_.invert_right);
    (void)hw_.can.send(saulcan::encode(saulcan::TelemetryA{pitch_x100(), pid_out_, saturate16(speed), state_}));
    (void)hw_.can.send(
        saulcan::encode(saulcan::TelemetryB{saturate16(l_rpm), saturate16(r_rpm), battery_mv_, faults()}));
  }
  if (display_tx_.due(now)) hw_.display.show(view());
}

}  // namespace saul::fw
