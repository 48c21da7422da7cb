// BalanceBoard's loop trace, flight recorder and excitation (docs/protocol.md section 10, firmware/README.md).
// Kept apart from balance.cpp: the control loop calls trace_loop() once per iteration and excite_check() at every
// point where the state may have left BALANCE; nothing here changes the robot's state.
#include <cmath>

#include "saulfw/balance.hpp"
#include "saulfw/mutant.hpp"

namespace saul::fw {

using saulcan::RobotState;

namespace {

constexpr std::int16_t clamp16(float v) noexcept {
  if (!(v == v)) return 0;  // NaN
  return v >= 32767.0F ? std::int16_t{32767} : (v <= -32768.0F ? std::int16_t{-32768} : static_cast<std::int16_t>(v));
}
std::int16_t scaled(float v, float scale) noexcept { return clamp16(std::round(v * scale)); }

// The dead band of the speed request inside which an excitation may run: a stick or an Orin command beyond it is
// someone driving, and the test signal gives way at once.
constexpr std::int16_t kRcDeadBandPermille = 30;
constexpr std::int16_t kOrinDeadBandMmps = 30;
constexpr std::int16_t kOrinDeadBandMrad = 30;
constexpr bool beyond(std::int32_t v, std::int32_t band) noexcept { return v > band || v < -band; }

/// Records a dump sends per loop iteration: 32 x 39 bytes, ~1.2 MB/s at 1 kHz, well inside the USB's 12 Mbit/s;
/// 5000 records take 160 ms.
constexpr std::size_t kDumpPerLoop = 32;

}  // namespace

void BalanceBoard::excite_check() noexcept {
  if (!excite_.active()) return;
  bool stop = state_ != RobotState::balance && !SAUL_MUTANT(excite_latch);
  const bool link = (live_faults_ & saulcan::fault::kIoLinkLoss) == 0;
  if (link && (beyond(rc_.throttle, kRcDeadBandPermille) || beyond(rc_.steer, kRcDeadBandPermille))) stop = true;
  if (orin_active() &&
      (beyond(velocity_.speed_mmps, kOrinDeadBandMmps) || beyond(velocity_.steer_mrad, kOrinDeadBandMrad)))
    stop = true;
  // The speed loop's lean is held while the signal runs (balance_output), so nothing but the signal keeps the
  // robot's speed: past half the speed cap the signal ends, and the speed loop brings the robot back with the
  // other half.
  if (balancing_ && std::fabs(speed_filtered_mps_) * 2000.0F > static_cast<float>(speed_cap_mmps())) stop = true;
  // The cap may be lowered while armed (speed_limit, the Orin's 0x303): below the minimum the signal ends at once.
  if (excite_cap_outside()) stop = true;
  if (stop) excite_.stop();
}

bool BalanceBoard::excite_cap_outside() const noexcept {
  // trace::kExciteMinCapPct and kExciteMaxCapPct say why and what the simulator showed: the other half of a low cap
  // is too little to bring the robot back from where a test signal takes it, and the whole of the full cap brings it
  // back so hard that it falls.
  if (SAUL_MUTANT(excite_cap)) return false;
  const auto cap = static_cast<std::uint32_t>(speed_cap_mmps()) * 100U;
  const auto hard_max = static_cast<std::uint32_t>(config_.hard_max_speed_mmps);
  return cap < hard_max * trace::kExciteMinCapPct || cap > hard_max * trace::kExciteMaxCapPct;
}

void BalanceBoard::trace_loop(TimeUs now) noexcept {
  trace::LoopTrace r;
  r.time_us = static_cast<std::uint32_t>(now);
  r.seq = loop_seq_++;
  r.pitch_x100 = pitch_x100();
  r.rate_x10 = filter_.valid() ? scaled(filter_.rate_dps(), 10.0F) : std::int16_t{0};
  r.setpoint_x100 = scaled(setpoint_deg_, 100.0F);
  if (balancing_) {
    r.p_term = scaled(pid_.p_term(), 1.0F);
    r.i_term = scaled(pid_.integral(), 1.0F);
    r.d_term = scaled(pid_.d_term(), 1.0F);
  }
  r.output = pid_out_;
  r.erpm_left = clamp16(static_cast<float>(erpm_of(wheel_left_mmps_)));
  r.erpm_right = clamp16(static_cast<float>(erpm_of(wheel_right_mmps_)));
  std::int64_t wheel = (static_cast<std::int64_t>(wheel_left_mmps_) + wheel_right_mmps_) / 2;
  (void)measured_speed(now, wheel);
  r.wheel_mmps = clamp16(static_cast<float>(wheel));
  r.request_mmps = clamp16(request_mmps_);
  r.state = static_cast<std::uint8_t>(state_);
  r.faults = faults();
  r.excite = static_cast<std::uint8_t>(excite_.kind());
  r.excite_x100 = scaled(excite_.offset_deg(), 100.0F);
  last_trace_ = r;

  // The flight recorder keeps every loop, and freezes at a latch that ends an armed run: the seconds before it
  // are what a bench engineer needs (a latch while disarmed stopped nothing moving and keeps it recording).
  recorder_.record(r);
  if (trace_was_armed_ && latched()) recorder_.freeze(now, saulcan::to_string(state_));
  trace_was_armed_ = armed();

  if (dumping_) {
    pump_dump();
  } else if (trace_divider_ != 0 && r.seq % trace_divider_ == 0) {
    send_trace(r);
  }
}

void BalanceBoard::send_trace(const trace::LoopTrace& record) noexcept {
  // Whole or not at all, never waiting: a full USB buffer drops the record and counts it (seq shows the gap).
  std::uint8_t frame[trace::kFrameSize];
  (void)trace::encode(record, frame);
  if (hw_.console.write_room() < sizeof frame) {
    ++trace_dropped_;
    return;
  }
  if (hw_.console.write(frame) == sizeof frame) {
    ++trace_sent_;
  } else {
    ++trace_dropped_;
  }
}

void BalanceBoard::pump_dump() noexcept {
  for (std::size_t i = 0; i < kDumpPerLoop && dump_next_ < recorder_.size(); ++i) {
    std::uint8_t frame[trace::kFrameSize];
    (void)trace::encode(recorder_.at(dump_next_), frame);
    if (hw_.console.write_room() < sizeof frame) return;  // the rest goes in the next iteration
    (void)hw_.console.write(frame);
    ++dump_next_;
  }
  if (dump_next_ < recorder_.size()) return;
  dumping_ = false;
  console::TextWriter w(scratch_);
  w.text("trace dump end: ").unsigned_number(static_cast<std::uint32_t>(recorder_.size())).text(" records\nok\n");
  write_formatted(hw_.console, w.finish(), scratch_);
}

bool BalanceBoard::on_trace_line(std::string_view line, TimeUs now) noexcept {
  const trace::CommandParse parsed = trace::parse_command(line);
  if (!parsed.matched) return false;
  SerialPort& out = hw_.console;
  if (parsed.error.reason != Reason::ok) {
    write_formatted(out, console::format_error(parsed.error, scratch_), scratch_);
    return true;
  }
  const auto ok = [&] { write_formatted(out, console::format_ok(scratch_), scratch_); };
  if (dumping_) {
    write_refusal(out, "a trace dump is being sent");
    return true;
  }
  if (const auto* on = std::get_if<trace::TraceOn>(&parsed.command)) {
    trace_divider_ = on->divider;
    ok();
  } else if (std::holds_alternative<trace::TraceOff>(parsed.command)) {
    trace_divider_ = 0;
    ok();
  } else if (std::holds_alternative<trace::TraceArm>(parsed.command)) {
    recorder_.arm();
    ok();
  } else if (std::holds_alternative<trace::TraceDump>(parsed.command)) {
    recorder_.freeze(now, "dump");  // a ring still recording is frozen as it is now
    console::TextWriter w(scratch_);
    w.text("trace dump: ").unsigned_number(static_cast<std::uint32_t>(recorder_.size())).text(" records, frozen at ");
    w.unsigned_number(static_cast<std::uint32_t>(recorder_.frozen_us() / 1000U)).text(" ms by ").text(recorder_.why());
    write_formatted(out, w.ch('\n').finish(), scratch_);
    dumping_ = true;
    dump_next_ = 0;
    pump_dump();
  } else if (const auto* e = std::get_if<trace::ExciteStart>(&parsed.command)) {
    if (state_ != RobotState::balance) {
      write_refusal(out, "excite runs only in BALANCE (arm first)");
      return true;
    }
    if (excite_cap_outside()) {  // the cap moves only while disarmed: say how, and which limit holds it
      console::TextWriter w(scratch_);
      const bool high = static_cast<std::uint32_t>(speed_cap_mmps()) * 100U >
                        static_cast<std::uint32_t>(config_.hard_max_speed_mmps) * trace::kExciteMaxCapPct;
      if (high) {  // only speed_limit raises the cap (the Orin's 0x303 only lowers it)
        w.text(trace::kExciteCapHighRefusal).unsigned_number(trace::kExciteMaxCapPct).text(" % (speed_limit is ");
        w.unsigned_number(speed_limit_pct_).text(" %: disarm, lower it to ").unsigned_number(trace::kExciteMaxCapPct);
        w.text(", arm again)");
      } else {
        w.text(trace::kExciteCapRefusal).unsigned_number(trace::kExciteMinCapPct).text(" % (");
        if (speed_limit_pct_ < trace::kExciteMinCapPct) {
          w.text("speed_limit is ").unsigned_number(speed_limit_pct_).text(" %: disarm, raise it to ");
          w.unsigned_number(trace::kExciteMinCapPct).text(" one 10 % step at a time, arm again)");
        } else {
          w.text("the Orin's 0x303 max speed holds it at ").unsigned_number(speed_cap_mmps()).text(" mm/s)");
        }
      }
      const auto n = w.finish();
      write_refusal(out, std::string_view(scratch_, n.ok() ? *n : 0));
      return true;
    }
    excite_.start(*e, now);
    excite_check();  // a stick or an Orin request beyond the dead band refuses it at once
    if (!excite_.active()) {
      write_refusal(out, "a speed or steering request is active (sticks centred, Orin at 0)");
      return true;
    }
    ok();
  } else if (std::holds_alternative<trace::ExciteOff>(parsed.command)) {
    excite_.stop();
    ok();
  }
  return true;
}

void BalanceBoard::write_trace_status() noexcept {
  console::TextWriter w(scratch_);
  w.text("report=trace divider=").unsigned_number(trace_divider_).text(" sent=").unsigned_number(trace_sent_);
  w.text(" dropped=").unsigned_number(trace_dropped_).text(" recorder=");
  w.unsigned_number(static_cast<std::uint32_t>(recorder_.size())).text(recorder_.frozen() ? " frozen=1" : " frozen=0");
  w.text(" excite=").text(trace::to_string(excite_.kind())).ch('\n');
  write_formatted(hw_.console, w.finish(), scratch_);
}

}  // namespace saul::fw
