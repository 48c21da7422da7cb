#include "explorer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "fakes.hpp"
#include "saulproto/core/rc_input.hpp"
#include "saulproto/core/saul_can.hpp"
#include "saulsim/world.hpp"

namespace fwtest::explore {
namespace {

using saul::saulcan::RobotState;
using Kind = Event::Kind;

constexpr TimeUs kMs = 1000;

bool is_armed(RobotState s) { return s == RobotState::balance || s == RobotState::manual; }
bool is_latched(RobotState s) {
  return s == RobotState::estop || s == RobotState::tilt_cutoff || s == RobotState::fault;
}

Event make(Kind kind, std::int32_t a = 0, std::int32_t b = 0) {
  Event e;
  e.kind = kind;
  e.a = a;
  e.b = b;
  return e;
}
Event console(int board, std::string text) {
  Event e = make(Kind::console, board);
  e.text = std::move(text);
  return e;
}
Event can(Kind kind, const CanFrame& f) {
  Event e = make(kind);
  e.frame = f;
  return e;
}

// ---- generation -------------------------------------------------------------------------------------------------

/// The speed cap raised from 10 % to 50 % or more (what a test signal needs, trace::kExciteMinCapPct), one console
/// step per line from t on as a technician types them; returns the time of the last. Refused while armed.
TimeUs raise_cap(Rng& rng, TimeUs t, std::vector<Event>& out) {
  const auto top = 10 * (rng.chance(70) ? rng.range(5, 7) : rng.range(8, 10));
  for (std::int64_t pct = 20; pct <= top; pct += 10) {
    t += static_cast<TimeUs>(rng.range(2, 40)) * kMs;
    Event e = console(0, "speed_limit " + std::to_string(pct));
    e.at_us = t;
    out.push_back(std::move(e));
  }
  return t;
}

/// Weighted choice of the next event kind, with the events it implies (a press and its release, a pulse's end).
void next_events(Rng& rng, TimeUs t, std::vector<Event>& out, TimeUs& calm_until) {
  auto at = [&](TimeUs when, Event e) {
    e.at_us = when;
    out.push_back(std::move(e));
  };
  const auto ms = [&](std::int64_t lo, std::int64_t hi) { return static_cast<TimeUs>(rng.range(lo, hi)) * kMs; };
  // Someone lifts the body back up by hand (through the dynamics: the gyro sees it) and onto the bench stand. The
  // stand alone would move it there in one step, which no IMU filter follows at once.
  const auto stand_up = [&](TimeUs when) {
    at(when, make(Kind::tilt, 0));
    at(when + 300 * kMs, make(Kind::upright));
  };
  static constexpr int kWeights[] = {24, 20, 6, 4, 10, 3, 3, 6, 4, 6, 8, 4, 3, 6,
                                     6,  2,  6, 3, 2,  3, 1, 3, 3, 12, 2, 6, 8};
  int total = 0;
  for (int w : kWeights) total += w;
  int pick = static_cast<int>(rng.below(static_cast<std::uint64_t>(total)));
  int k = 0;
  while (pick >= kWeights[k]) pick -= kWeights[k++];
  switch (k) {
    case 0: {  // a press of the arming button: short, about 3 s, or long
      const auto which = rng.below(100);
      const TimeUs hold = which < 35 ? ms(3000, 4500) : which < 60 ? ms(4500, 12000) : ms(30, 2990);
      at(t, make(Kind::button, 1));
      at(t + hold, make(Kind::button, 0));
      if (rng.chance(50)) calm_until = t + hold;  // nothing else happens meanwhile: a clean hold
      return;
    }
    case 1: at(t, console(0, "arm")); return;
    case 2: at(t, console(0, "disarm")); return;
    case 3: at(t, console(0, "estop")); return;
    case 4: {
      const auto pct = 10 * (rng.chance(70) ? rng.range(1, 4) : rng.range(1, 10));
      at(t, console(0, "speed_limit " + std::to_string(pct)));
      return;
    }
    case 5: {
      static const char* const kOther[] = {"tilt_limit 12", "tilt_limit 25", "tilt_limit 4", "pid 60 400 1.5",
                                           "pid 0 0 0",     "status",        "reboot",       "speed_limit 15",
                                           "fly",           "arm now"};
      at(t, console(0, kOther[rng.below(10)]));
      return;
    }
    case 6: {
      static const char* const kIo[] = {"estop", "disarm", "arm", "speed_limit 100", "status"};
      at(t, console(1, kIo[rng.below(5)]));
      return;
    }
    case 7: {  // CH5: mostly at arm; exactly 1500 is not arm
      const auto w = rng.below(20);
      at(t, make(Kind::radio, 5, w < 15 ? 2000 : w < 19 ? 1000 : 1500));
      return;
    }
    case 8: {  // CH6: a pulse
      at(t, make(Kind::radio, 6, 2000));
      at(t + ms(1, 600), make(Kind::radio, 6, 1000));
      return;
    }
    case 9: {  // CH7
      const auto w = rng.below(10);
      at(t, make(Kind::radio, 7, w == 0 ? 880 : w == 1 ? 2160 : static_cast<std::int32_t>(rng.range(988, 2012))));
      return;
    }
    case 10: {  // CH2 throttle: centred, in the deadband, or anywhere
      const auto w = rng.below(100);
      at(t, make(Kind::radio, 2,
                 w < 40 ? 1500 : w < 55 ? static_cast<std::int32_t>(rng.range(1490, 1510))
                                        : static_cast<std::int32_t>(rng.range(988, 2012))));
      if (rng.chance(70)) at(t + ms(200, 3000), make(Kind::radio, 2, 1500));  // and back to centre
      return;
    }
    case 11: at(t, make(Kind::radio, 1, static_cast<std::int32_t>(rng.range(988, 2012)))); return;
    case 12: {  // the kill switch: a pulse
      at(t, make(Kind::kill, 1));
      at(t + ms(1, 2000), make(Kind::kill, 0));
      return;
    }
    case 13: {  // a receiver (or both) lost and back
      const auto which = static_cast<std::int32_t>(rng.below(3));
      at(t, make(Kind::receiver, which, 0));
      at(t + (rng.chance(80) ? ms(5, 400) : ms(400, 2500)), make(Kind::receiver, which, 1));
      return;
    }
    case 14: {  // the Orin streams 0x300
      const auto w = rng.below(10);
      const auto speed = static_cast<std::int16_t>(w < 7   ? rng.range(-400, 400)
                                                   : w < 9 ? rng.range(-3000, 3000)
                                                           : (rng.chance(50) ? 32767 : -32768));
      const auto steer = static_cast<std::int16_t>(rng.chance(90) ? rng.range(-600, 600) : rng.range(-32768, 32767));
      at(t, can(Kind::stream, saul::saulcan::encode(saul::saulcan::VelocityCmd{speed, steer})));
      return;
    }
    case 15: at(t, make(Kind::stream_stop)); return;
    case 16: {  // 0x302 mode: off, balance, manual, estop, or one that does not exist
      const auto w = rng.below(20);
      const auto mode = static_cast<std::uint8_t>(w < 5 ? 0 : w < 10 ? 1 : w < 14 ? 2 : w < 18 ? 3 : rng.range(4, 255));
      at(t, can(Kind::can, std_frame(0x302, {mode})));
      return;
    }
    case 17: {  // 0x303 config, in range or not
      const auto tilt = static_cast<std::uint16_t>(rng.chance(70) ? rng.range(500, 2500) : rng.range(0, 6000));
      const auto max = static_cast<std::uint16_t>(rng.chance(80) ? rng.range(0, 3000) : 65535);
      at(t, can(Kind::can, saul::saulcan::encode(saul::saulcan::ConfigCmd{tilt, max})));
      return;
    }
    case 18: {  // 0x301 tuning: a set (sometimes out of range), or a stray frame
      const auto seq = static_cast<std::uint8_t>(rng.below(256));
      const float kp = rng.chance(80) ? rng.uniform(0.0F, 120.0F) : -5.0F;
      using saul::saulcan::Gain;
      at(t, can(Kind::can, saul::saulcan::encode(saul::saulcan::PidGain{Gain::kp, seq, kp})));
      if (rng.chance(70)) {
        at(t + kMs, can(Kind::can, saul::saulcan::encode(saul::saulcan::PidGain{Gain::ki, seq, rng.uniform(0, 500)})));
        const float kd = rng.uniform(0, 3);
        at(t + 2 * kMs, can(Kind::can, saul::saulcan::encode(saul::saulcan::PidGain{Gain::kd, seq, kd})));
      }
      return;
    }
    case 19: {  // malformed frames: wrong lengths, unknown ids in the SAUL range, an extended 0x302
      const auto w = rng.below(6);
      const auto b = static_cast<std::uint8_t>(rng.below(256));
      const CanFrame f = w == 0   ? std_frame(0x300, {b, b})
                         : w == 1 ? std_frame(0x302, {3, 0})
                         : w == 2 ? std_frame(0x302, {})
                         : w == 3 ? std_frame(0x303, {b, b, b})
                         : w == 4 ? ext_frame(0x302, {3})
                                  : std_frame(static_cast<std::uint32_t>(rng.range(0x304, 0x3FF)), {b, 3, b, b});
      at(t, can(Kind::can, f));
      return;
    }
    case 20: at(t, make(Kind::hang)); return;
    case 21: {  // the inter-board link cut and restored
      at(t, make(Kind::link, 1));
      at(t + (rng.chance(80) ? ms(2, 300) : ms(300, 2000)), make(Kind::link, 0));
      return;
    }
    case 22: {
      const auto w = rng.below(3);
      if (w == 0) {
        at(t, make(Kind::tilt, static_cast<std::int32_t>(rng.range(-40, 40))));
      } else if (w == 1) {
        at(t, make(Kind::imu, 0));
        at(t + ms(2, 200), make(Kind::imu, 1));
      } else {
        at(t, make(Kind::push, static_cast<std::int32_t>(rng.range(-60, 60))));
      }
      if (rng.chance(70)) stand_up(t + ms(300, 3000));  // someone stands it up again
      return;
    }
    case 23: stand_up(t); return;
    case 25: {  // the button held through a stop (a latch or a disarm) and on for 3 s and more: no arming from it
      stand_up(t);
      const TimeUs press = t + 400 * kMs;
      at(press, make(Kind::button, 1));
      const TimeUs stop = press + (rng.chance(80) ? ms(50, 2900) : ms(3100, 5000));
      switch (rng.below(6)) {
        case 0: at(stop, can(Kind::can, std_frame(0x302, {3}))); break;
        case 1: at(stop, console(0, "estop")); break;
        case 2: at(stop, make(Kind::hang)); break;
        case 3: at(stop, rng.chance(50) ? console(0, "disarm") : can(Kind::can, std_frame(0x302, {0}))); break;
        case 4:
          at(stop, make(Kind::radio, 5, 1000));
          at(stop + ms(20, 300), make(Kind::radio, 5, 2000));
          break;
        default:
          at(stop, make(Kind::kill, 1));
          at(stop + ms(1, 300), make(Kind::kill, 0));
          break;
      }
      if (rng.chance(50)) at(stop + ms(50, 1000), console(0, "disarm"));
      const TimeUs release = stop + ms(3200, 6000);
      at(release, make(Kind::button, 0));
      calm_until = release;
      return;
    }
    case 26: {  // armed and driving, then one stop input: each must cut the motors in time
      stand_up(t);
      const TimeUs go = t + 400 * kMs;
      at(go, make(Kind::radio, 5, 2000));
      at(go, make(Kind::radio, 2, 1500));
      at(go + kMs, console(0, "arm"));
      const auto mode = static_cast<std::uint8_t>(rng.range(1, 2));
      if (rng.chance(50)) at(go + 2 * kMs, can(Kind::can, std_frame(0x302, {mode})));
      const TimeUs stop = go + ms(200, 2500);
      const TimeUs back = stop + ms(105, 700);
      switch (rng.below(5)) {
        case 0:
          at(stop, make(Kind::receiver, 0, 0));
          at(back, make(Kind::receiver, 0, 1));
          break;
        case 1:
          at(stop, make(Kind::link, 1));
          at(back, make(Kind::link, 0));
          break;
        case 2:
          at(stop, make(Kind::kill, 1));
          at(back, make(Kind::kill, 0));
          break;
        case 3:
          at(stop, make(Kind::radio, 6, 2000));
          at(back, make(Kind::radio, 6, 1000));
          break;
        default: at(stop, make(Kind::tilt, rng.chance(50) ? 35 : -35)); break;
      }
      calm_until = back;
      return;
    }
    default:
      at(t, make(Kind::push, static_cast<std::int32_t>(rng.range(-150, 150))));
      if (rng.chance(70)) stand_up(t + ms(300, 3000));
      return;
  }
}

/// The simulator control command of an event (firmware/sim's World::command, and `sim` steps in a suite).
std::string sim_command(const Event& e) {
  switch (e.kind) {
    case Kind::button: return e.a != 0 ? "button down" : "button up";
    case Kind::radio: return "radio " + std::to_string(e.a) + " " + std::to_string(e.b);
    case Kind::kill: return e.a != 0 ? "kill on" : "kill off";
    case Kind::receiver: {
      const char* which = e.a == 0 ? "rc" : e.a == 1 ? "crsf" : "elrs";
      return std::string(which) + (e.b != 0 ? " ok" : " loss");
    }
    case Kind::link: return e.a != 0 ? "link cut" : "link ok";
    case Kind::hang: return "hang balance";
    case Kind::push: return "push " + std::to_string(e.a);
    case Kind::tilt: return "tilt " + std::to_string(e.a);
    case Kind::upright: return "upright";
    case Kind::imu: return e.a != 0 ? "imu on" : "imu off";
    case Kind::console: return std::string("type ") + (e.a == 0 ? "balance " : "io ") + e.text;
    default: return "";
  }
}

// ---- the model ------------------------------------------------------------------------------------------------

/// A level input and since when it has had its present value.
struct Level {
  bool on = false;
  TimeUs since = 0;
  void set(bool v, TimeUs t) {
    if (v != on) {
      on = v;
      since = t;
    }
  }
  /// On continuously for at least d by now.
  [[nodiscard]] bool held(TimeUs now, TimeUs d) const { return on && now - since >= d; }
};

/// A deadline of the stop oracle: by `due`, the named boards' outputs are zero (and BALANCE is in ESTOP).
struct Deadline {
  TimeUs due = 0;
  TimeUs from = 0;  // the event's time
  std::string why;
  bool bal = true;
  bool io = true;
  bool estop_state = false;
  const Level* level = nullptr;  // the condition must have stayed on since `from` (nullptr: no condition)
  bool needs_radio = false;      // and a receiver sending all the while
  bool not_armed = false;        // BALANCE must be disarmed by then
};

class Explorer {
 public:
  Explorer(const Episode& e, const std::vector<Event>& events) : episode_(e), events_(events) {
    saul::sim::WorldConfig c;
    c.plant.seed = static_cast<std::uint32_t>(e.seed ^ (e.seed >> 32));
    config_ = c;
    world_.emplace(c);
    ch_.fill(1500);
    ch_[5] = 2000;
    ch_[6] = 1000;
    ch_[7] = 988;
    radio_on_.set(true, 0);
    ch5_off_.on = false;
    const auto cap_mmps = [&](int pct) { return config_.balance.hard_max_speed_mmps * pct / 100; };
    for (int pct = 0; pct <= 100; ++pct)
      cap_erpm_[static_cast<std::size_t>(pct)] = static_cast<std::int32_t>(
          static_cast<std::int64_t>(cap_mmps(pct)) * 60 * config_.balance.pole_pairs /
          config_.balance.wheel_circumference_mm);
  }

  Result run() {
    Result r;
    std::size_t next = 0;
    auto& w = *world_;
    while (w.now_us() < episode_.length_us) {
      const TimeUs t = w.now_us();
      if (!hung_ && !reset_last_tick_) {  // a hung BALANCE reads what came meanwhile on its first step after the reset
        console_arm_ = explicit_disarm_ = false;
        speed_limit_asked_ = -1;
      }
      while (next < events_.size() && events_[next].at_us <= t) apply(events_[next++], t);
      if (stream_on_ && t >= stream_next_) {
        w.send_can(stream_frame_);
        stream_next_ = t + 50 * kMs;
      }
      w.step();
      ++stats_.ticks;
      if (auto v = observe()) {
        r.violation = v;
        break;
      }
    }
    r.stats = stats_;
    return r;
  }

 private:
  // ---- inputs ----
  void apply(const Event& e, TimeUs t) {
    auto& w = *world_;
    if (debug_) std::printf("%8.3f %s\n", static_cast<double>(t) / 1e6, describe(e).c_str());
    last_event_us_ = t;
    const bool armed_now = is_armed(w.balance().state());
    switch (e.kind) {
      case Kind::button:
        if ((e.a != 0) != button_) {
          button_ = e.a != 0;
          if (button_) press_start_ = t;
        }
        break;
      case Kind::radio: {
        if (e.a < 1 || e.a > 16) break;
        ch_[static_cast<std::size_t>(e.a)] = static_cast<std::uint16_t>(e.b);
        if (e.a == 5 && e.b <= 1500 && !ch5_off_.on && radio_on_.on) {
          add_deadline(t, 10 * kMs, "CH5 at disarm", false, &ch5_off_, true, armed_now);
          pending_.back().not_armed = true;
        }
        if (e.a == 6 && e.b > 1500 && !ch6_on_.on && radio_on_.on)
          add_deadline(t, 10 * kMs, "CH6 ESTOP", true, &ch6_on_, true, armed_now, true);
        if (radio_on_.on && ((e.a == 5 && e.b <= 1500) || (e.a == 6 && e.b > 1500))) last_stop_input_us_ = t;
        ch5_off_.set(ch_[5] <= 1500, t);
        ch6_on_.set(ch_[6] > 1500, t);
        break;
      }
      case Kind::kill:
        if (e.a != 0) last_stop_input_us_ = t;
        if (e.a != 0 && !kill_.on) add_deadline(t, kMs, "kill switch", true, &kill_, false, armed_now, true);
        kill_.set(e.a != 0, t);
        break;
      case Kind::receiver:
        if (e.a != 2) crsf_on_ = e.b != 0;
        if (e.a != 1) elrs_on_ = e.b != 0;
        radio_on_.set(crsf_on_ || elrs_on_, t);
        break;
      case Kind::link:
        if (e.a != 0 && !link_cut_.on) {
          link_cut_.set(true, t);
          add_deadline(t, 102 * kMs, "inter-board link cut", false, &link_cut_, false, armed_now);
        }
        link_cut_.set(e.a != 0, t);
        if (e.a != 0) last_link_cut_us_ = t;
        break;
      case Kind::hang:
        if (!hung_) {
          hung_ = true;
          hang_at_ = t;
          last_stop_input_us_ = t;
          Deadline d;
          d.from = t;
          d.due = t + 53 * kMs;
          d.why = "BALANCE hang (watchdog 50 ms)";
          pending_.push_back(d);
          if (armed_now) ++stats_.stops_while_armed;
        }
        break;
      case Kind::console:
        if (e.text == "estop" || e.text == "disarm") last_stop_input_us_ = t;  // either board's console
        if (e.a == 0) {
          if (e.text == "arm") console_arm_ = true;
          if (e.text == "disarm") explicit_disarm_ = true;
          if (e.text == "estop")
            add_deadline(t, kMs, "console estop (BALANCE)", true, nullptr, false, armed_now, false, 2);
          if (e.text.rfind("speed_limit ", 0) == 0) speed_limit_asked_ = std::atoi(e.text.c_str() + 12);
        } else if (e.text == "estop") {
          io_estop_at_ = t;
          io_estop_seen_ = true;
          add_deadline(t, kMs, "console estop (IO)", true, nullptr, false, armed_now, true);
        }
        break;
      case Kind::can:
        if (const auto config = saul::saulcan::decode_config_cmd(e.frame);
            config && config->tilt_limit_x100 >= saul::saulcan::ConfigCmd::kMinTiltX100 &&
            config->tilt_limit_x100 <= saul::saulcan::ConfigCmd::kMaxTiltX100)
          orin_max_mmps_ = config->max_speed_mmps;  // BALANCE takes both fields, or neither (docs/protocol.md)
        if (!e.frame.extended && e.frame.id == 0x302 && e.frame.dlc == 1) {
          if (e.frame.data[0] == 3) add_deadline(t, kMs, "0x302 mode 3", true, nullptr, false, armed_now, false, 2);
          if (e.frame.data[0] == 0) explicit_disarm_ = true;
          if (e.frame.data[0] == 0 || e.frame.data[0] == 3) last_stop_input_us_ = t;
        }
        break;
      case Kind::stream:
        stream_on_ = true;
        stream_frame_ = e.frame;
        stream_next_ = t;
        break;
      case Kind::stream_stop: stream_on_ = false; break;
      case Kind::tilt:
      case Kind::upright:
        hand_moved_ = true;
        hand_moved_us_ = t;
        break;
      default: break;
    }
    if (explicit_disarm_) last_explicit_disarm_us_ = t;
    // The world itself.
    switch (e.kind) {
      case Kind::console: w.console_input(e.a == 0 ? "balance" : "io", e.text + "\n"); break;
      case Kind::can: w.send_can(e.frame); break;
      case Kind::stream:
      case Kind::stream_stop: break;
      default: (void)w.command(sim_command(e)); break;
    }
  }

  /// A stop deadline. estop: BALANCE must be in ESTOP by then (when it heard of it: link intact, not hung). io_lag:
  /// the IO board learns of it from BALANCE's STATE (one tick later).
  void add_deadline(TimeUs t, TimeUs after, std::string why, bool estop, const Level* level, bool radio,
                    bool armed_now, bool via_io = false, int io_lag = 1) {
    Deadline d;
    d.from = t;
    d.due = t + after;
    d.why = std::move(why);
    d.level = level;
    d.needs_radio = radio;
    d.estop_state = estop;
    if (armed_now) ++stats_.stops_while_armed;
    if (io_lag > 1) {  // BALANCE's own: IO follows a tick later
      Deadline io = d;
      io.bal = false;
      io.estop_state = false;
      io.due = t + after + kMs;
      pending_.push_back(io);
      d.io = false;
    }
    if (via_io && (link_cut_.on || hung_)) {  // BALANCE hears of it only through the link: then its own stop rules
      d.bal = false;
      d.estop_state = false;
    }
    pending_.push_back(d);
  }

  // ---- observation and the oracles ----
  std::optional<Violation> observe() {
    auto& w = *world_;
    const TimeUs now = w.now_us();
    // what BALANCE put on the bus
    for (const auto& f : w.take_can_output()) {
      const auto l = set_rpm_of(f, 68);
      const auto r = set_rpm_of(f, 56);
      if (l) erpm_l_ = *l;
      if (r) erpm_r_ = *r;
      if ((l && *l != 0) || (r && *r != 0)) last_nonzero_rpm_us_ = now;
    }
    if (debug_) {
      for (const char* board : {"balance", "io"}) {
        const std::string out = w.take_console_output(board);
        if (!out.empty() && out.size() < 200)
          std::printf("%8.3f %s> %s", static_cast<double>(now) / 1e6, board, out.c_str());
      }
    } else if (now % (100 * kMs) == 0) {
      (void)w.take_console_output("balance");
      (void)w.take_console_output("io");
    }
    const auto& bal = w.balance();
    const RobotState st = bal.state();
    const bool io_armed = w.io().armed();
    const std::uint16_t duty = w.io_drive_duty();
    const int pct = bal.speed_limit_pct();
    const bool reset = w.balance_resets() != resets_;
    const double pitch = w.plant().pitch_deg();
    if (debug_ && std::getenv("SAUL_EXPLORE_TRACE") != nullptr && now % (20 * kMs) == 0)
      std::printf("%8.3f   pitch %.2f est %.2f rpm %d/%d duty %u stand %d\n", static_cast<double>(now) / 1e6, pitch,
                  bal.pitch_deg(), erpm_l_, erpm_r_, duty, w.plant().on_stand() ? 1 : 0);
    if (debug_ && (st != prev_state_ || io_armed != prev_io_armed_))
      std::printf("%8.3f BALANCE %s IO %s pitch %.1f faults 0x%02X\n", static_cast<double>(now) / 1e6,
                  saul::saulcan::to_string(st), io_armed ? "armed" : "-", pitch, bal.faults());
    if (reset) {
      resets_ = w.balance_resets();
      last_reset_us_ = now;
      hung_ = false;
      ++stats_.resets;
    }
    const bool bal_out = erpm_l_ != 0 || erpm_r_ != 0;
    if (bal_out) ++stats_.bal_driving_ticks;
    if (duty > 0) ++stats_.io_driving_ticks;

    // levels of the inputs, as the model sees them
    const bool radio = crsf_on_ || elrs_on_;
    radio_on_.set(radio, now);
    if (radio) radio_ever_ = true;
    ch5_off_.set(ch_[5] <= 1500, now);
    ch6_on_.set(ch_[6] > 1500, now);
    throttle_off_.set(std::abs(static_cast<int>(ch_[2]) - 1500) > static_cast<int>(saul::rc::kDeadbandUs), now);
    const int ch7 = saul::rc::speed_cap_pct(ch_[7]);
    const int eff = std::min(ch7, pct);
    throttle_cmd_.set(saul::rc::stick_permille(ch_[2]) * eff / 100 != 0, now);
    // After a hand put the body somewhere (tilt, upright), an IMU filter needs time to follow a plant that moved
    // it without the dynamics (the gyro seeing little of it): the pitch rules wait until it can have (3 filter
    // time constants of 1 s bring a 30 degree step within 1.5 degrees).
    const bool settled = !hand_moved_ || now - hand_moved_us_ > 3000 * kMs;
    tilted_.set(settled && std::fabs(pitch) > 8.0, now);
    const double limit = std::min(static_cast<double>(bal.tilt_limit_x100()), 2500.0) / 100.0;
    beyond_limit_.set(settled && std::fabs(pitch) > limit + 3.0, now);
    const bool radio_live = radio_on_.held(now, 11 * kMs);
    const bool io_estop = io_estop_seen_ && now - io_estop_at_ <= 490 * kMs;

    // the button's arming conditions, broken for sure (the firmware may see a break a little earlier)
    const bool rc_dead = !radio_on_.on && now - radio_on_.since >= 105 * kMs;
    const bool broken_now = kill_.on || io_estop || rc_dead ||
                            (radio_live && (ch6_on_.held(now, 11 * kMs) || ch5_off_.held(now, 11 * kMs) ||
                                            throttle_off_.held(now, 11 * kMs))) ||
                            tilted_.held(now, 25 * kMs) || link_cut_.held(now, 105 * kMs);
    if (broken_now) last_broken_us_ = now;

    // stops: a latch, a disarm, a reset
    const bool bal_stop = (st != prev_state_ && (is_latched(st) || (is_armed(prev_state_) && !is_armed(st)) ||
                                                 (is_latched(prev_state_) && st == RobotState::off))) ||
                          reset;
    if (bal_stop || (prev_io_armed_ && !io_armed)) last_stop_us_ = now;
    if (is_armed(prev_state_) && !is_armed(st)) bal_left_armed_us_ = now;
    if (is_latched(st) && (st != prev_state_ || reset)) {
      ++stats_.latches;
    }
    // CH5 at disarm as the RC_CMD carries it (a live radio): its rising edge is the radio's explicit disarm.
    const bool ch5_disarm = radio_on_.on && ch_[5] <= 1500;
    if (ch5_disarm && !ch5_disarm_prev_) {
      ch5_disarm_at_ = now;
      last_explicit_disarm_us_ = now;
    }
    ch5_disarm_prev_ = ch5_disarm;

    std::optional<Violation> v;
    auto fail = [&](const char* rule, std::string what, std::string check) {
      if (v) return;
      v = Violation{now, rule, std::move(what), std::move(check)};
    };
    const auto state_text = [](RobotState s) { return std::string(saul::saulcan::to_string(s)); };

    // -- excite: a test signal on the setpoint only while BALANCE (it stops in the iteration that leaves it)
    const bool excited = bal.excitation() != saul::trace::Excite::none;
    if (excited) {
      ++stats_.excite_ticks;
      if (!excited_) ++stats_.excite_starts;
      if (st != RobotState::balance)
        fail("excite", std::string("excitation ") + saul::trace::to_string(bal.excitation()) + " still on in " +
                           state_text(st), "");
      // and only at a speed cap from the minimum to the maximum: the console's speed_limit, lowered by the Orin's 0x303
      const int hard_max = config_.balance.hard_max_speed_mmps;
      const int cap_mmps = std::min(hard_max * pct / 100, orin_max_mmps_);
      if (cap_mmps * 100 < hard_max * saul::trace::kExciteMinCapPct ||
          cap_mmps * 100 > hard_max * saul::trace::kExciteMaxCapPct)
        fail("excite", std::string("excitation ") + saul::trace::to_string(bal.excitation()) + " on with the speed cap at " +
                           std::to_string(cap_mmps) + " mm/s (speed_limit " + std::to_string(pct) + " %), outside " +
                           std::to_string(saul::trace::kExciteMinCapPct) + "-" +
                           std::to_string(saul::trace::kExciteMaxCapPct) + " %", "");
    }
    excited_ = excited;
    if (bal.last_trace().excite != 0 && bal.last_trace().state != static_cast<std::uint8_t>(RobotState::balance))
      fail("excite", "a trace record marks an excitation outside BALANCE", "");

    // -- arming
    if (is_armed(st) && !is_armed(prev_state_) && !reset) {
      const bool link_ok = !link_cut_.on && now - link_cut_.since >= 2 * kMs;
      bool console_ok = console_arm_ && !tilted_.on && !link_cut_.held(now, 105 * kMs);
      if (console_ok && link_ok) {
        const bool radio_says_no = radio_live && (ch6_on_.held(now, 11 * kMs) || ch5_off_.held(now, 11 * kMs) ||
                                                  throttle_cmd_.held(now, 11 * kMs));
        console_ok = !kill_.on && !io_estop && !radio_says_no && !(radio_ever_ && rc_dead);
      }
      // The press began after the last stop or disarm input from any source, whether or not it changed a state
      // (last_stop_input_us_, from the inputs the explorer gave), and after the last stop BALANCE showed.
      const bool button_ok = button_ && now - press_start_ >= 3000 * kMs && last_broken_us_ < press_start_ &&
                             last_stop_before_ < press_start_ && last_stop_input_us_ < press_start_;
      last_arming_us_ = now;
      if (console_ok) ++stats_.armings_console;
      if (button_ok) ++stats_.armings_button;
      if (!console_ok && !button_ok)
        fail("arming",
             "armed (" + state_text(st) + ") without a valid arming: " +
                 (console_arm_ ? "console arm with a condition broken" : "no console arm, and the button " +
                  (button_ ? "held " + std::to_string((now - press_start_) / kMs) + " ms, conditions broken " +
                                 (last_broken_us_ >= press_start_ ? "during the hold" : "before") +
                                 (last_stop_before_ >= press_start_ ? ", a stop since the press" : "") +
                                 (last_stop_input_us_ >= press_start_ ? ", a stop or disarm input since the press" : "")
                           : std::string("not pressed"))),
             "expect no telemetry_a state=BALANCE for 300ms");
      // A latch is left only to OFF (issue 33): never straight into an armed state, by any arming.
      if (is_latched(prev_state_))
        fail("latch", "left " + state_text(prev_state_) + " straight for " + state_text(st) + " (a latch is left only to OFF)",
             "expect no telemetry_a state<=2 for 300ms");
    }
    // -- latch: leaving one for OFF only by an explicit disarm
    const bool ch5_recent = now - ch5_disarm_at_ <= 15 * kMs && ch5_disarm_at_ != 0;
    if (is_latched(prev_state_) && st == RobotState::off && !reset && !explicit_disarm_ && !ch5_recent)
      fail("latch", "left " + state_text(prev_state_) + " for OFF without an explicit disarm",
           "expect no telemetry_a state<=2 for 300ms");

    // -- output: none while not armed or latched (a reset board sends its zeros on its first step)
    if (!is_armed(st) && bal_out && !reset && !reset_last_tick_)
      fail("output",
           "SET_RPM " + std::to_string(erpm_l_) + "/" + std::to_string(erpm_r_) + " in force while " + state_text(st),
           saul_bal_check(std::max(bal_left_armed_us_ + kMs, last_nonzero_rpm_us_), 0));
    if (duty > 0) {
      const bool recent_gap = now - last_link_cut_us_ <= 120 * kMs || link_cut_.on || hung_ ||
                              now - hang_at_ <= 120 * kMs;
      const TimeUs grace = recent_gap ? 103 * kMs : 2 * kMs;
      if (!io_armed) {
        fail("output", "BTS7960 duty " + std::to_string(duty) + " while the IO board is not armed",
             saul_io_check(now, 0));
      } else if (!is_armed(st) && now - bal_left_armed_us_ > grace) {
        fail("output", "BTS7960 duty " + std::to_string(duty) + " while BALANCE is " + state_text(st),
             saul_io_check(bal_left_armed_us_ + grace, 0));
      }
    }

    // -- stop deadlines
    for (auto it = pending_.begin(); it != pending_.end();) {
      const Deadline& d = *it;
      if (d.due > now) {
        ++it;
        continue;
      }
      // (a fresh arming since the stop input is judged by the arming oracle; the deadline is void then)
      const bool kept = last_arming_us_ <= d.from &&
                        (d.level == nullptr || (d.level->on && d.level->since <= d.from)) &&
                        (!d.needs_radio || (radio_on_.on && radio_on_.since <= d.from));
      if (kept) {
        if (d.bal && bal_out && !hung_ && !reset)
          fail("stop", "SET_RPM " + std::to_string(erpm_l_) + "/" + std::to_string(erpm_r_) + " " +
                           std::to_string((now - d.from) / kMs) + " ms after " + d.why,
               saul_bal_check(now, 0));
        if (d.not_armed && is_armed(st) && !hung_)
          fail("stop", "still " + state_text(st) + " " + std::to_string((now - d.from) / kMs) + " ms after " + d.why,
               "expect no telemetry_a state=BALANCE for 300ms");
        if (d.io && duty > 0)
          fail("stop", "BTS7960 duty " + std::to_string(duty) + " " + std::to_string((now - d.from) / kMs) +
                           " ms after " + d.why,
               saul_io_check(now, 0));
        if (d.estop_state && st != RobotState::estop && !hung_ && last_reset_us_ < d.from &&
            last_explicit_disarm_us_ < d.from)
          fail("stop", "state " + state_text(st) + " " + std::to_string((now - d.from) / kMs) + " ms after " + d.why +
                           " (ESTOP expected)",
               "hold telemetry_a state=ESTOP for 300ms");
      }
      it = pending_.erase(it);
    }
    if (beyond_limit_.held(now, 20 * kMs) && bal_out && !hung_ && !reset)
      fail("stop", "SET_RPM in force with the body at " + std::to_string(pitch) + " degrees for 20 ms",
           saul_bal_check(now, 0));
    if (beyond_limit_.held(now, 21 * kMs) && duty > 0)
      fail("stop", "BTS7960 duty with the body at " + std::to_string(pitch) + " degrees", saul_io_check(now, 0));
    const bool rc_lost = radio_ever_ && !radio_on_.on && now - radio_on_.since >= 101 * kMs;
    if (rc_lost && !rc_lost_seen_) {
      rc_lost_seen_ = true;
      if (is_armed(st)) ++stats_.stops_while_armed;
    }
    if (radio_on_.on) rc_lost_seen_ = false;
    if (rc_lost && (bal_out && !hung_ && !reset))
      fail("stop", "SET_RPM in force 101 ms after RC loss", saul_bal_check(now, 0));
    if (rc_lost && duty > 0) fail("stop", "BTS7960 duty 101 ms after RC loss", saul_io_check(now, 0));

    // -- cap
    if (reset && pct != 10) fail("cap", "speed limit " + std::to_string(pct) + " % after a reset", "");
    if (pct > prev_pct_ && !reset) {
      ++stats_.cap_raises;
      if (speed_limit_asked_ != pct || pct != prev_pct_ + 10)
        fail("cap", "speed limit raised from " + std::to_string(prev_pct_) + " to " + std::to_string(pct) +
                        " % without one console step to it", "");
      if (is_armed(st))
        fail("cap", "speed limit raised to " + std::to_string(pct) + " % while armed",
             "expect no vesc_set_rpm |erpm|>" + std::to_string(cap_erpm_[static_cast<std::size_t>(prev_pct_)]) +
                 " for 5s");
    }
    if (pct < prev_pct_) {
      cap_before_ = prev_pct_;
      cap_lowered_us_ = now;
    }
    const int bal_cap = now - cap_lowered_us_ <= 11 * kMs ? std::max(pct, cap_before_) : pct;
    const std::int32_t cap_erpm = cap_erpm_[static_cast<std::size_t>(std::clamp(bal_cap, 0, 100))];
    if ((std::abs(erpm_l_) > cap_erpm || std::abs(erpm_r_) > cap_erpm) && !hung_ && !reset)
      fail("cap",
           "SET_RPM " + std::to_string(erpm_l_) + "/" + std::to_string(erpm_r_) + " above the " +
               std::to_string(bal_cap) + " % cap (" + std::to_string(cap_erpm) + " ERPM)",
           saul_bal_check(std::max(now - 10 * kMs, cap_lowered_us_ + 11 * kMs), cap_erpm));
    if (ch7 < ch7_prev_) {
      ch7_before_ = ch7_prev_;
      ch7_lowered_us_ = now;
    }
    ch7_prev_ = ch7;
    const int io_bal_cap = now - cap_lowered_us_ <= 103 * kMs ? std::max(pct, cap_before_) : pct;
    const int io_ch7 = now - ch7_lowered_us_ <= 11 * kMs ? std::max(ch7, ch7_before_) : ch7;
    const int io_cap = std::min(io_bal_cap, io_ch7);
    if (duty > 10 * io_cap)
      fail("cap", "BTS7960 duty " + std::to_string(duty) + " above the " + std::to_string(io_cap) + " % cap",
           saul_io_check(now, 10 * io_cap));

    last_stop_before_ = last_stop_us_;
    reset_last_tick_ = reset;
    prev_state_ = st;
    prev_io_armed_ = io_armed;
    prev_pct_ = pct;
    return v;
  }

  /// Bench steps from `from` (at the earliest the last event) on: no SET_RPM above `limit`.
  std::string saul_bal_check(TimeUs from, std::int32_t limit) const {
    return "from " + std::to_string(from) + " expect no vesc_set_rpm |erpm|>" + std::to_string(limit) + " for 30ms";
  }
  std::string saul_io_check(TimeUs from, int limit) const {
    return "from " + std::to_string(from) + " io " + std::to_string(limit);
  }

  const Episode& episode_;
  const std::vector<Event>& events_;
  bool debug_ = std::getenv("SAUL_EXPLORE_DEBUG") != nullptr;
  saul::sim::WorldConfig config_;
  std::optional<saul::sim::World> world_;
  Stats stats_;
  std::array<std::int32_t, 101> cap_erpm_{};

  // inputs
  std::array<std::uint16_t, 17> ch_{};  // index = channel number
  bool button_ = false;
  TimeUs press_start_ = 0;
  bool crsf_on_ = true;
  bool elrs_on_ = true;
  bool radio_ever_ = false;
  Level radio_on_, ch5_off_, ch6_on_, throttle_off_, throttle_cmd_, kill_, link_cut_, tilted_, beyond_limit_;
  TimeUs last_stop_input_us_ = 0;  // the last stop or disarm input of any source (a console, the Orin, the radio, ...)
  bool ch5_disarm_prev_ = false;
  TimeUs ch5_disarm_at_ = 0;
  TimeUs last_link_cut_us_ = 0;
  bool hand_moved_ = false;
  TimeUs hand_moved_us_ = 0;
  bool hung_ = false;
  TimeUs hang_at_ = 0;
  bool io_estop_seen_ = false;
  TimeUs io_estop_at_ = 0;
  bool stream_on_ = false;
  CanFrame stream_frame_{};
  TimeUs stream_next_ = 0;
  TimeUs last_event_us_ = 0;
  bool console_arm_ = false;
  bool explicit_disarm_ = false;
  TimeUs last_explicit_disarm_us_ = 0;
  int speed_limit_asked_ = -1;
  int orin_max_mmps_ = 0xFFFF;  // the last 0x303 max speed BALANCE accepted (kept across a reset)

  // observations
  std::int32_t erpm_l_ = 0;
  std::int32_t erpm_r_ = 0;
  TimeUs last_nonzero_rpm_us_ = 0;
  RobotState prev_state_ = RobotState::off;
  bool prev_io_armed_ = false;
  std::uint32_t resets_ = 0;
  bool reset_last_tick_ = false;
  TimeUs last_reset_us_ = 0;
  TimeUs last_arming_us_ = 0;
  TimeUs last_broken_us_ = 0;
  TimeUs last_stop_us_ = 0;
  TimeUs last_stop_before_ = 0;  // last_stop_us_ as it was before this tick's observation
  TimeUs bal_left_armed_us_ = 0;
  bool rc_lost_seen_ = false;
  int prev_pct_ = 10;
  bool excited_ = false;
  int cap_before_ = 10;
  TimeUs cap_lowered_us_ = 0;
  int ch7_prev_ = 10;
  int ch7_before_ = 10;
  TimeUs ch7_lowered_us_ = 0;
  std::vector<Deadline> pending_;
};


}  // namespace

// ---- public -------------------------------------------------------------------------------------------------------

/// The loop trace's console commands on BALANCE (test signals, the trace, the flight recorder) at random times, from
/// a generator of their own so that every other event of a seed stays as it was.
void add_excitations(std::uint64_t seed, TimeUs length_us, std::vector<Event>& out) {
  static const char* const kLines[] = {"excite step 2 3",       "excite step -1.5 20",  "excite chirp 1 0.5 20 10",
                                       "excite chirp 2 1 5 20", "excite prbs 2 8",      "excite prbs 1 20",
                                       "excite off",            "trace on",             "trace on 10",
                                       "trace off",             "trace dump",           "trace arm",
                                       "excite step 3 1",       "excite chirp 1 0 5 5", "excite"};
  Rng rng(seed ^ 0x7ACE'E1C1'7ACE'E1C1ULL);
  if (rng.chance(50)) (void)raise_cap(rng, 0, out);  // ready for test signals from power-on
  for (TimeUs t = static_cast<TimeUs>(rng.range(500, 3000)) * kMs; t < length_us;
       t += static_cast<TimeUs>(rng.range(200, 1500)) * kMs) {
    if (rng.chance(25)) {  // the cap raised for them (a step at a time; BALANCE takes it only while disarmed)
      t = raise_cap(rng, t, out);
      continue;
    }
    Event e = console(0, kLines[rng.below(std::size(kLines))]);
    e.at_us = t;
    out.push_back(std::move(e));
  }
}

Episode generate(std::uint64_t seed, TimeUs length_us) {
  Rng rng(seed);
  Episode e;
  e.seed = seed;
  e.length_us = length_us;
  auto start = [&](Event ev) {
    ev.at_us = 0;
    e.events.push_back(std::move(ev));
  };
  if (rng.chance(8)) start(make(Kind::receiver, 0, 0));  // a bench without a transmitter (for a while)
  start(make(Kind::radio, 7, static_cast<std::int32_t>(rng.range(988, 2012))));
  if (rng.chance(15)) start(make(Kind::radio, 5, 1000));
  TimeUs t = static_cast<TimeUs>(rng.range(100, 1500)) * kMs;
  TimeUs calm_until = 0;
  while (t < length_us) {
    next_events(rng, t, e.events, calm_until);
    const TimeUs gap = static_cast<TimeUs>(rng.chance(15) ? rng.range(1000, 5000) : rng.range(1, 700)) * kMs;
    t = std::max(t + gap, calm_until + kMs);
  }
  add_excitations(seed, length_us, e.events);
  std::erase_if(e.events, [&](const Event& ev) { return ev.at_us >= length_us; });
  std::stable_sort(e.events.begin(), e.events.end(), [](const Event& a, const Event& b) { return a.at_us < b.at_us; });
  return e;
}

Result run(const Episode& e, const std::vector<Event>& events) { return Explorer(e, events).run(); }

std::vector<Event> shrink(const Episode& e, const Violation& v, int max_runs) {
  std::vector<Event> current;
  for (const auto& ev : e.events)
    if (ev.at_us < v.at_us) current.push_back(ev);
  Episode bounded = e;
  bounded.length_us = v.at_us + 2 * kMs;
  int runs = 0;
  const auto fails = [&](const std::vector<Event>& candidate) {
    ++runs;
    const Result r = run(bounded, candidate);
    return r.violation && r.violation->rule == v.rule;
  };
  // ddmin: try removing chunks of size n/granularity, refining until single events.
  std::size_t granularity = 2;
  while (current.size() >= 2 && runs < max_runs) {
    const std::size_t chunk = (current.size() + granularity - 1) / granularity;
    bool reduced = false;
    for (std::size_t start = 0; start < current.size() && runs < max_runs; start += chunk) {
      std::vector<Event> complement;
      for (std::size_t i = 0; i < current.size(); ++i)
        if (i < start || i >= start + chunk) complement.push_back(current[i]);
      if (fails(complement)) {
        current = std::move(complement);
        granularity = std::max<std::size_t>(granularity - 1, 2);
        reduced = true;
        break;
      }
    }
    if (!reduced) {
      if (granularity >= current.size()) break;
      granularity = std::min(current.size(), granularity * 2);
    }
  }
  if (current.size() == 1 && runs < max_runs && fails({})) current.clear();
  return current;
}

std::string describe(const Event& ev) {
  switch (ev.kind) {
    case Kind::can: return "send frame " + candump(ev.frame);
    case Kind::stream: {
      const auto speed = static_cast<std::int16_t>(ev.frame.data[0] | (ev.frame.data[1] << 8));
      const auto steer = static_cast<std::int16_t>(ev.frame.data[2] | (ev.frame.data[3] << 8));
      return "stream velocity_cmd speed_mmps=" + std::to_string(speed) + " steer_mrad=" + std::to_string(steer) +
             " every 50ms";
    }
    case Kind::stream_stop: return "stop";
    default: return "sim " + sim_command(ev);
  }
}

std::string listing(const std::vector<Event>& events) {
  std::string s;
  for (const auto& ev : events) s += "  t=" + std::to_string(ev.at_us / kMs) + "ms " + describe(ev) + "\n";
  return s;
}

std::string to_saul(const Episode& e, const std::vector<Event>& events, const Violation& v) {
  std::string s = "suite: explorer seed " + std::to_string(e.seed) + ": " + v.rule + " (" + v.what + ")\n";
  s += "# Written by the firmware explorer (tests/firmware/explorer.hpp): the shrunk input sequence that broke the\n";
  s += "# rule, then a check that fails where it broke. Replay: saulctl test --sim THIS_FILE (the explorer ran\n";
  s += "# the plant with seed " + std::to_string(static_cast<std::uint32_t>(e.seed ^ (e.seed >> 32))) +
       "; the suite runs on the simulator's own, so noise-sensitive timings may differ)\n";
  s += "requires: sim\n";
  TimeUs t = 0;
  auto wait_until = [&](TimeUs when) {
    if (when > t) s += "wait " + std::to_string((when - t) / kMs) + "ms\n";
    t = std::max(t, when);
  };
  for (const auto& ev : events) {
    wait_until(ev.at_us);
    s += describe(ev) + "\n";
  }
  // The check: "from T expect ..." / "from T io LIMIT" from the oracle, or a plain step.
  std::string check = v.saul_check;
  if (check.rfind("from ", 0) == 0) {
    const auto sp = check.find(' ', 5);
    const TimeUs from = std::strtoull(check.c_str() + 5, nullptr, 10);
    check = check.substr(sp + 1);
    wait_until(std::min(from, v.at_us));
    if (check.rfind("io ", 0) == 0) {
      s += "sim peak reset\n";
      wait_until(v.at_us + 2 * kMs);
      s += "sim check io_duty_peak<=" + check.substr(3) + "\n";
      return s;
    }
  } else if (check.empty()) {
    s += "# (no bench step observes this rule directly: " + v.what + ")\n";
    return s;
  } else {
    wait_until(v.at_us > kMs ? v.at_us - kMs : 0);  // a check of the state: from just before it went wrong
  }
  s += check + "\n";
  return s;
}

}  // namespace fwtest::explore
