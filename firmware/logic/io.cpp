#include "saulfw/io.hpp"

#include <variant>

#include "saulfw/arming.hpp"
#include "saulfw/mutant.hpp"

namespace saul::fw {

using saulcan::RobotState;

namespace {

// STATE's error_state as the arming table's states (saulfw/arming.hpp): IO follows BALANCE's state.
bool is_latched(std::uint8_t state) noexcept { return arming::is_latched(static_cast<RobotState>(state)); }
bool is_armed_state(std::uint8_t state) noexcept { return arming::is_armed(static_cast<RobotState>(state)); }

std::int16_t clamp_permille(std::int32_t v, std::int32_t limit = 1000) noexcept {
  return static_cast<std::int16_t>(v > limit ? limit : (v < -limit ? -limit : v));
}

/// A stick's permille scaled by a cap in percent, truncated toward zero (never above the cap).
std::int16_t scaled(std::int16_t permille, std::uint8_t cap_pct) noexcept {
  return static_cast<std::int16_t>(static_cast<std::int32_t>(permille) * cap_pct / 100);
}

bool valid_cap(std::uint8_t pct) noexcept { return pct >= 10 && pct <= 100 && pct % 10 == 0; }

const char* flight_mode_name(std::uint8_t state) noexcept {
  switch (static_cast<RobotState>(state)) {
    case RobotState::off: return "OFF";
    case RobotState::balance: return "BALANCE";
    case RobotState::manual: return "MANUAL";
    case RobotState::estop: return "ESTOP";
    case RobotState::tilt_cutoff: return "TILT";
    case RobotState::fault: return "FAULT";
  }
  return "?";
}

}  // namespace

IoBoard::IoBoard(const Hardware& hw, const IoConfig& config) noexcept
    : hw_(hw),
      config_(config),
      rc_cmd_tx_(config.rc_cmd_period_us),
      sensor_tx_(config.sensor_period_us),
      fault_tx_(config.fault_period_us),
      telemetry_tx_(config.telemetry_period_us),
      led_tx_(config.led_period_us),
      refresh_(config.output_refresh_us) {
  if (config_.led_count > kMaxLeds) config_.led_count = kMaxLeds;
}

void IoBoard::boot(TimeUs now) noexcept {
  started_ = true;
  boot_us_ = now;
  motors_off();  // power-on: drivers disabled before anything else happens
}

// ---- the loop ---------------------------------------------------------------------------------------------------

void IoBoard::step(TimeUs now) noexcept {
  if (!started_) boot(now);
  if (refresh_.due(now)) outputs_known_ = false;  // rewrite every output this iteration

  check_estop(now);  // first, every iteration
  read_receiver(crsf_, hw_.crsf, rc::Source::crsf, now);
  read_receiver(elrs_, hw_.elrs, rc::Source::elrs, now);
  selector_.update(now);
  check_estop(now);  // receivers that went silent no longer count

  read_link(now);
  read_console(now);
  arming(now);
  drive_motors(now);
  to_balance(now);
  telemetry(now);
  outputs(now);
  outputs_known_ = true;
  hw_.watchdog.feed();
}

void IoBoard::check_estop(TimeUs now) noexcept {
  bool rc_estop = false;
  for (const Receiver* r : {&crsf_, &elrs_})
    if (r->seen && age(now, r->last_us) <= rc::ReceiverSelector::kSilenceUs && r->command.estop) rc_estop = true;
  estop_level_ = (!SAUL_MUTANT(kill_switch) && hw_.gpio.read(InputPin::kill_switch)) || rc_estop;
  if (console_estop_ && age(now, console_estop_us_) > config_.console_estop_us) console_estop_ = false;
  if (estop_level_ || console_estop_) {
    motors_off();
    disarm(arming::Event::estop);
  }
  if (fault_flags() != sent_faults_) {  // an ESTOP (or RC loss) goes to BALANCE at once, before anything else
    send_fault();
    send_rc_cmd();
  }
}

// ---- receivers ----------------------------------------------------------------------------------------------------

void IoBoard::read_receiver(Receiver& receiver, SerialPort& port, rc::Source source, TimeUs now) noexcept {
  std::uint8_t buffer[64];
  for (int round = 0; round < 4; ++round) {
    const std::size_t n = port.read(buffer);
    if (n == 0) break;
    receiver.decoder.push(std::span<const std::uint8_t>(buffer, n < sizeof buffer ? n : sizeof buffer),
                          [&](const crsf::Frame& frame) {
                            if (frame.type != static_cast<std::uint8_t>(crsf::Type::rc_channels_packed)) return;
                            const auto m = crsf::decode(frame);
                            if (!m) return;
                            const auto* channels = std::get_if<crsf::RcChannels>(&m.value());
                            if (channels == nullptr) return;
                            receiver.us = crsf::channels_us(*channels);
                            receiver.command = rc::map_channels(receiver.us);  // ESTOP evaluated first in there
                            receiver.last_us = now;
                            receiver.seen = true;
                            selector_.on_frame(source, now);
                            if (receiver.command.estop) check_estop(now);  // at once, inside the receive loop
                          });
  }
}

const IoBoard::Receiver* IoBoard::active_receiver() const noexcept {
  switch (selector_.active()) {
    case rc::Source::crsf: return &crsf_;
    case rc::Source::elrs: return &elrs_;
    case rc::Source::none: break;
  }
  return nullptr;
}

const rc::Command* IoBoard::active_command() const noexcept {
  const Receiver* r = active_receiver();
  return r != nullptr ? &r->command : nullptr;
}

std::uint8_t IoBoard::speed_cap_pct() const noexcept {
  const rc::Command* cmd = active_command();
  const std::uint8_t ch7 = cmd != nullptr ? cmd->speed_cap_pct : 10;
  if (SAUL_MUTANT(io_cap)) return ch7;
  return ch7 < balance_cap_pct_ ? ch7 : balance_cap_pct_;  // CH7 can only lower the cap
}

rc::Command IoBoard::capped_command() const noexcept {
  const Receiver* r = active_receiver();
  rc::Command c{};
  if (r == nullptr || r->command.estop || estop_level_ || console_estop_) return c;
  c = r->command;
  c.speed_cap_pct = speed_cap_pct();
  c.throttle = scaled(rc::stick_permille(r->us[rc::kThrottleChannel]), c.speed_cap_pct);
  // Stick right (CH1 > 1500) is a right turn: negative steer (REP-103), as rc::map_channels.
  c.steer = scaled(static_cast<std::int16_t>(-rc::stick_permille(r->us[rc::kSteerChannel])), c.speed_cap_pct);
  return c;
}

std::uint8_t IoBoard::fault_flags() const noexcept {
  std::uint8_t f = 0;
  // A receiver never heard since power-on is no radio (a bench without a transmitter), not a lost one.
  if (selector_.rc_loss() && (crsf_.seen || elrs_.seen)) f |= interboard::Fault::kRcLoss;
  if (estop_level_ || console_estop_) f |= interboard::Fault::kEstop;
  return f;
}

// ---- BALANCE link -------------------------------------------------------------------------------------------------

void IoBoard::read_link(TimeUs now) noexcept {
  std::uint8_t buffer[64];
  for (int round = 0; round < 8; ++round) {
    const std::size_t n = hw_.link.read(buffer);
    if (n == 0) break;
    for (std::size_t i = 0; i < n && i < sizeof buffer; ++i) {
      const auto m = link_rx_.push(buffer[i]);
      if (!m) continue;
      if (const auto* s = std::get_if<interboard::State>(&*m)) {
        const bool new_latch = is_latched(s->error_state) && (!state_seen_ || s->error_state != state_.error_state);
        state_ = *s;
        state_us_ = now;
        state_seen_ = true;
        // BALANCE just latched ESTOP, TILT_CUTOFF or FAULT: re-arming takes a new press and a fresh 3 s hold.
        if (new_latch) disarm(arming::Event::fault);
      } else if (const auto* c = std::get_if<interboard::SpeedCap>(&*m)) {
        if (valid_cap(c->percent)) balance_cap_pct_ = c->percent;  // anything else: keep the cap it had
      } else if (const auto* l = std::get_if<interboard::LedCmd>(&*m)) {
        led_cmd_ = *l;
        led_cmd_us_ = now;
        led_cmd_seen_ = true;
      } else if (const auto* b = std::get_if<interboard::Buzzer>(&*m)) {
        buzzer_tone_ = b->tone_id;
        buzzer_until_us_ = now + static_cast<TimeUs>(b->duration_ms) * 1000U;
      }
    }
  }
}

bool IoBoard::state_fresh(TimeUs now) const noexcept {
  return state_seen_ && age(now, state_us_) <= config_.state_timeout_us;
}

bool IoBoard::balance_armed(TimeUs now) const noexcept { return state_fresh(now) && is_armed_state(state_.error_state); }

// ---- arming -------------------------------------------------------------------------------------------------------

void IoBoard::disarm(arming::Event event) noexcept {
  armed_ = false;
  // The arming table's hold column (an IO armed flag is only ever high while BALANCE is armed or arming).
  if (arming::rule(RobotState::balance, event).cancels_hold) {
    hold_active_ = false;
    if (!SAUL_MUTANT(new_press)) need_release_ = true;  // the next arming starts with a new press
  }
}

void IoBoard::arming(TimeUs now) noexcept {
  const rc::Command* cmd = active_command();
  const bool arm_switch = cmd != nullptr && cmd->armed;
  const bool estop = estop_level_ || console_estop_;
  const bool rc_ok = !selector_.rc_loss();
  const bool fresh = state_fresh(now);
  const std::int32_t pitch = state_.pitch_x100;
  const bool upright = fresh && (pitch < 0 ? -pitch : pitch) <= config_.upright_x100;
  const Receiver* receiver = active_receiver();
  const bool centred = SAUL_MUTANT(throttle_centred) ||
                       (receiver != nullptr && rc::stick_permille(receiver->us[rc::kThrottleChannel]) == 0);

  if (armed_) {
    if (!arm_switch || estop || !rc_ok) {
      disarm(estop ? arming::Event::estop : arming::Event::disarm);
    } else if (fresh && !is_armed_state(state_.error_state) && age(now, armed_us_) > config_.arm_confirm_us) {
      disarm(arming::Event::disarm);  // BALANCE did not take the arming (not upright by its own IMU, a fault, ...)
    }
  }

  const bool pressed = hw_.gpio.read(InputPin::arm_button);
  button_ = pressed;
  if (!pressed) {
    need_release_ = false;
    hold_active_ = false;
    return;
  }
  if (armed_ || need_release_) return;
  const bool can_hold = arm_switch && upright && !estop && rc_ok && centred;
  if (!can_hold) {  // pressed while not allowed, or a condition failed during the hold: release and start over
    hold_active_ = false;
    need_release_ = true;
    return;
  }
  if (!hold_active_) {
    hold_active_ = true;
    hold_start_us_ = now;
    return;
  }
  if (age(now, hold_start_us_) >= config_.arm_hold_us) {
    armed_ = true;
    armed_us_ = now;
    hold_active_ = false;
    need_release_ = true;
    send_rc_cmd();  // BALANCE sees the rising armed flag now, not at the next 10 ms slot
  }
}

// ---- motors -------------------------------------------------------------------------------------------------------

void IoBoard::set_pwm(PwmChannel channel, std::uint16_t permille) noexcept {
  const auto i = static_cast<std::size_t>(channel);
  if (outputs_known_ && pwm_out_[i] == permille) return;
  pwm_out_[i] = permille;
  hw_.pwm.set(channel, permille);
}

void IoBoard::set_pin(OutputPin pin, bool on) noexcept {
  const auto i = static_cast<std::size_t>(pin);
  if (outputs_known_ && pin_out_[i] == on) return;
  pin_out_[i] = on;
  hw_.gpio.write(pin, on);
}

void IoBoard::set_side(PwmChannel forward, PwmChannel reverse, OutputPin r_en, OutputPin l_en,
                       std::int16_t permille, bool enabled) noexcept {
  if (!enabled) {  // enables first: the half bridges go high-impedance at once
    set_pin(r_en, false);
    set_pin(l_en, false);
    set_pwm(forward, 0);
    set_pwm(reverse, 0);
    return;
  }
  const std::uint16_t fwd = permille > 0 ? static_cast<std::uint16_t>(permille) : 0;
  const std::uint16_t rev = permille < 0 ? static_cast<std::uint16_t>(-permille) : 0;
  set_pwm(fwd > 0 ? reverse : forward, 0);  // never both directions at once, not even between two writes
  set_pwm(forward, fwd);
  set_pwm(reverse, rev);
  set_pin(r_en, true);
  set_pin(l_en, true);
}

void IoBoard::motors_off() noexcept {
  motors_enabled_ = false;
  left_permille_ = 0;
  right_permille_ = 0;
  set_side(PwmChannel::left_rpwm, PwmChannel::left_lpwm, OutputPin::left_r_en, OutputPin::left_l_en, 0, false);
  set_side(PwmChannel::right_rpwm, PwmChannel::right_lpwm, OutputPin::right_r_en, OutputPin::right_l_en, 0, false);
}

void IoBoard::drive_motors(TimeUs now) noexcept {
  const bool enable = armed_ && balance_armed(now) && !estop_level_ && !console_estop_ && active_command() != nullptr;
  if (!enable) {
    motors_off();
    return;
  }
  motors_enabled_ = true;
  const rc::Command cmd = capped_command();
  const std::int32_t limit = 10 * static_cast<std::int32_t>(cmd.speed_cap_pct);  // steering never exceeds it
  left_permille_ = clamp_permille(static_cast<std::int32_t>(cmd.throttle) - cmd.steer, limit);
  right_permille_ = clamp_permille(static_cast<std::int32_t>(cmd.throttle) + cmd.steer, limit);
  set_side(PwmChannel::left_rpwm, PwmChannel::left_lpwm, OutputPin::left_r_en, OutputPin::left_l_en, left_permille_,
           true);
  set_side(PwmChannel::right_rpwm, PwmChannel::right_lpwm, OutputPin::right_r_en, OutputPin::right_l_en,
           right_permille_, true);
}

// ---- to BALANCE ---------------------------------------------------------------------------------------------------

void IoBoard::send_link(const interboard::Message& message) noexcept {
  std::uint8_t buffer[interboard::kMaxFrameSize];
  const auto n = interboard::encode(message, buffer);
  if (n) (void)hw_.link.write(std::span<const std::uint8_t>(buffer, *n));
}

void IoBoard::send_fault() noexcept {
  sent_faults_ = fault_flags();
  send_link(interboard::Fault{sent_faults_});
}

std::uint8_t IoBoard::rc_flags() const noexcept {
  const rc::Command* cmd = active_command();
  std::uint8_t f = 0;
  if (armed_) f |= interboard::RcCmd::kArmed;
  if (estop_level_ || console_estop_) f |= interboard::RcCmd::kKill;
  if (cmd != nullptr && !cmd->armed) f |= interboard::RcCmd::kDisarmSwitch;  // a live radio with CH5 at disarm
  if (button_) f |= interboard::RcCmd::kButton;
  return f;
}

void IoBoard::send_rc_cmd() noexcept {
  const rc::Command cmd = capped_command();
  interboard::RcCmd m{cmd.throttle, cmd.steer, rc_flags()};
  sent_rc_flags_ = m.flags;
  send_link(m);
}

void IoBoard::to_balance(TimeUs now) noexcept {
  // FAULT first, so BALANCE learns of an RC loss before the RC_CMD that has lost its armed flag.
  if (fault_flags() != sent_faults_) {
    send_fault();
    fault_tx_.trigger();
    (void)fault_tx_.due(now);  // the periodic repeat counts from now
  } else if (fault_tx_.due(now)) {
    send_fault();
  }
  const bool due = rc_cmd_tx_.due(now);
  if (due || rc_flags() != sent_rc_flags_) send_rc_cmd();  // a flag change (CH5, button, ...) goes at once
  if (sensor_tx_.due(now)) {
    readings_ = hw_.sensors.read();
    interboard::Sensor s{};
    s.tof_mm = readings_.tof_valid ? readings_.tof_mm : 0xFFFF;
    if (readings_.pressure_valid) {
      if (!baro_reference_set_) {  // the pressure at the first reading is the reference
        baro_reference_set_ = true;
        baro_reference_pa_ = readings_.pressure_pa;
      }
      const std::int32_t d = readings_.pressure_pa - baro_reference_pa_;
      s.baro_delta_pa = static_cast<std::int16_t>(d > 32767 ? 32767 : (d < -32768 ? -32768 : d));
    }
    s.nfc_present = readings_.nfc_present ? 1 : 0;
    send_link(s);
  }
}

// ---- CRSF telemetry -----------------------------------------------------------------------------------------------

void IoBoard::telemetry(TimeUs now) noexcept {
  if (!telemetry_tx_.due(now)) return;
  SerialPort& port = selector_.active() == rc::Source::elrs ? hw_.elrs : hw_.crsf;
  std::uint8_t frame[crsf::kMaxFrameSize];
  Result<std::size_t> n = Reason::out_of_range;
  const bool fresh = state_fresh(now);
  for (int tries = 0; tries < 3 && !n.ok(); ++tries) {
    const std::uint8_t slot = telemetry_slot_;
    telemetry_slot_ = static_cast<std::uint8_t>((telemetry_slot_ + 1U) % 3U);
    if (slot == 0) {
      if (!fresh || state_.pitch_x100 == 32767) continue;  // pitch unknown: skip
      // degrees x 100 -> radians x 10000: x pi / 180 x 100
      std::int32_t rad = static_cast<std::int32_t>(state_.pitch_x100) * 174533 / 100000;
      rad = rad > crsf::Attitude::kLimit ? crsf::Attitude::kLimit : (rad < -crsf::Attitude::kLimit ? -crsf::Attitude::kLimit : rad);
      n = crsf::encode(crsf::Attitude{static_cast<std::int16_t>(rad), 0, 0}, frame);
    } else if (slot == 1) {
      const char* name = estop_level_ || console_estop_ ? "KILL" : (!fresh ? "NO LINK" : flight_mode_name(state_.error_state));
      if (const auto mode = crsf::make_flight_mode(name)) n = crsf::encode(*mode, frame);
    } else {
      if (readings_.battery_mv == 0) continue;  // no pack voltage on this board: nothing to say
      crsf::BatterySensor b{};
      b.voltage_x10 = static_cast<std::uint16_t>(readings_.battery_mv / 100U);
      n = crsf::encode(b, frame);
    }
  }
  if (n) (void)port.write(std::span<const std::uint8_t>(frame, *n));
}

// ---- LEDs, horn, headlight, fan -----------------------------------------------------------------------------------

void IoBoard::outputs(TimeUs now) noexcept {
  const rc::Channels* us = selector_.active() == rc::Source::crsf   ? &crsf_.us
                           : selector_.active() == rc::Source::elrs ? &elrs_.us
                                                                    : nullptr;
  const auto channel_on = [&](std::uint8_t index) {
    return us != nullptr && index < rc::kChannelCount && (*us)[index] > rc::kMidUs;
  };

  if (led_tx_.due(now)) {
    LedCommand c;
    if (estop_level_ || console_estop_) {
      c = {LedPattern::blink, {255, 0, 0}};
    } else if (hold_active_) {
      c = {LedPattern::chase, {0, 255, 0}};  // arming in progress
    } else if (!state_fresh(now)) {
      c = {LedPattern::blink, {255, 0, 255}};  // BALANCE silent
    } else if (led_cmd_seen_ && age(now, led_cmd_us_) <= config_.led_cmd_timeout_us) {
      c = {static_cast<LedPattern>(led_cmd_.pattern), {led_cmd_.r, led_cmd_.g, led_cmd_.b}};
    } else {
      c = led_for_state(static_cast<RobotState>(state_.error_state));
    }
    const auto pixels = std::span<Rgb>(pixels_, config_.led_count);
    render(c.pattern, c.color, now, pixels);
    hw_.leds.show(pixels);
  }

  std::uint16_t hz = 0;
  if (channel_on(config_.horn_channel)) {
    hz = config_.horn_hz;
  } else if (now < buzzer_until_us_) {
    hz = tone_hz(buzzer_tone_);
  }
  if (hz != horn_hz_out_ || !outputs_known_) {
    horn_hz_out_ = hz;
    hw_.horn.tone(hz);
  }

  const bool robot_armed = balance_armed(now);
  set_pwm(PwmChannel::headlight, channel_on(config_.headlight_channel) || robot_armed ? 1000 : 0);
  if (!config_.elrs_fitted) set_pin(OutputPin::fan, armed_ || robot_armed || motors_enabled_);
}

// ---- console ------------------------------------------------------------------------------------------------------

void IoBoard::read_console(TimeUs now) noexcept {
  console_in_.pump(hw_.console, [&](std::string_view line, bool overflowed) { on_console_line(line, overflowed, now); });
}

void IoBoard::on_console_line(std::string_view line, bool overflowed, TimeUs now) noexcept {
  SerialPort& out = hw_.console;
  console::ParseResult parsed;
  const console::Command* command = read_command(out, line, overflowed, parsed, scratch_);
  if (command == nullptr) return;
  const auto ok = [&] { write_ok(out, scratch_); };
  using console::Verb;
  switch (console::verb_of(*command)) {
    case Verb::help:
      write_formatted(out, console::format_help(scratch_), scratch_);
      ok();
      return;
    case Verb::status: {
      console::StatusReport r;
      r.board = console::Board::io;
      const bool fresh = state_fresh(now);
      r.state = fresh ? static_cast<RobotState>(state_.error_state) : RobotState::off;
      r.pitch_x100 = fresh ? state_.pitch_x100 : 32767;
      r.pid_out = fresh ? state_.pid_out : 0;
      r.speed_limit_pct = speed_cap_pct();
      r.faults = fault_flags();  // bits 0..2 are the 0x401 bits
      r.battery_mv = readings_.battery_mv;
      r.uptime_ms = static_cast<std::uint32_t>(age(now, boot_us_) / 1000U);
      write_status(out, r, console::CanStats{}, console::UartStats::from(link_rx_.counters()), scratch_);
      return;
    }
    case Verb::arm:
      write_refusal(out, "hold the arming button for 3 s (or use the BALANCE console)");
      return;
    case Verb::disarm:
      disarm(arming::Event::disarm);
      send_rc_cmd();
      ok();
      return;
    case Verb::estop:
      console_estop_ = true;
      console_estop_us_ = now;
      check_estop(now);
      ok();
      return;
    case Verb::pid:
    case Verb::tilt_limit:
    case Verb::speed_limit:
      write_refusal(out, "set on the BALANCE board");
      return;
    case Verb::can_stats:
      write_stats(out, console::CanStats{}, scratch_);  // no CAN controller on the IO board
      return;
    case Verb::uart_stats:
      write_stats(out, console::UartStats::from(link_rx_.counters()), scratch_);
      return;
    case Verb::reboot:
      if (armed_ || motors_enabled_) {
        write_refusal(out, "disarm before rebooting");
        return;
      }
      reboot_requested_ = true;
      ok();
      return;
  }
}

}  // namespace saul::fw
