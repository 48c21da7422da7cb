// A model-based explorer of both boards' safety: the real firmware logic of BALANCE and IO on the simulated robot
// (firmware/sim's World: plant, IMU, radio, VESCs, 1 ms ticks), driven by long seeded random sequences of every
// input at random times, with every safety rule checked as an oracle after EVERY tick.
//
// Inputs (Event): the arming button, RC channels (CH1 steer, CH2 throttle, CH5 arm, CH6 estop, CH7 speed cap), the
// kill switch, CRSF and ELRS loss and return, the Orin's 0x300 stream and 0x301/0x302/0x303 frames (in range, out of
// range, malformed), both boards' console commands, a BALANCE hang, the inter-board link cut and restored, the IMU
// pulled, pushes, tilts and the bench stand.
//
// Oracles (written from the system reference and docs/protocol.md's safety decisions, not from the code; they see
// the boards only through their outputs and states, and the inputs through what the explorer itself did):
//   output      no motor output (a VESC's last SET_RPM, the BTS7960 duty on the IO board's pins) while not armed
//               or while latched;
//   stop        motors zero within the reference's time after an ESTOP (Orin 0x302 mode 3, either console, CH6,
//               the kill switch), a tilt beyond the limit, RC loss, inter-board link loss, CH5 at disarm or a hang,
//               and ESTOP latched;
//   arming      no arming unless every arming condition held for the whole 3 s of a new press that began after
//               the last stop or disarm input of any source, whether or not it changed a state (or, by console,
//               when the console's conditions hold);
//   latch       a latched state (ESTOP, TILT_CUTOFF, FAULT) is left only to OFF, and only by an explicit disarm
//               (BALANCE console disarm, 0x302 mode 0, CH5 moved to disarm) without an estop input;
//   excite      a test signal on the pitch setpoint (`excite ...` on BALANCE's console) only while BALANCE: it
//               stops in the iteration that leaves it (latch, disarm, estop), and the trace record says so; and
//               only while the speed cap (speed_limit, lowered by the last 0x303 BALANCE accepted) is within
//               trace::kExciteMinCapPct..kExciteMaxCapPct: it stops in the iteration that lowers it below;
//   cap         every motor output within the speed cap (10 % at power-on, one 10 % step per console command and
//               only while disarmed; CH7 only lowers the IO board's output).
//
// Seeded and reproducible: one seed gives one episode (a power-on and its event list) and one result. A violation
// is shrunk by delta debugging over the event list and written out as a .saul bench suite that replays it.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "saulfw/hal.hpp"
#include "saulproto/core/can_frame.hpp"

namespace fwtest::explore {

using saul::CanFrame;
using saul::fw::TimeUs;

struct Event {
  enum class Kind : std::uint8_t {
    button,       ///< a: 1 down, 0 up
    radio,        ///< a: channel 1..16, b: microseconds
    kill,         ///< a: 1 on
    receiver,     ///< a: 0 both, 1 CRSF, 2 ELRS; b: 1 back, 0 lost
    link,         ///< a: 1 cut, 0 restored
    hang,         ///< the BALANCE loop stops (its watchdog resets it)
    push,         ///< a: deg/s
    tilt,         ///< a: degrees
    upright,      ///< back on the bench stand
    imu,          ///< a: 1 on, 0 pulled
    console,      ///< a: 0 BALANCE, 1 IO; text: the line
    can,          ///< frame: one frame from the Orin
    stream,       ///< frame: a 0x300 the Orin repeats every 50 ms from now on
    stream_stop,  ///< the Orin falls silent
  };
  TimeUs at_us = 0;
  Kind kind = Kind::upright;
  std::int32_t a = 0;
  std::int32_t b = 0;
  std::string text;
  CanFrame frame{};
};

/// One power-on of the simulated robot and what happens to it.
struct Episode {
  std::uint64_t seed = 0;
  TimeUs length_us = 0;
  std::vector<Event> events;  ///< sorted by time
};

/// Random episode: events of every kind at random times, biased so that armings happen often (long calm button
/// holds, console arms) and are then disturbed.
Episode generate(std::uint64_t seed, TimeUs length_us);

struct Violation {
  TimeUs at_us = 0;
  std::string rule;  ///< output, stop, arming, latch, cap
  std::string what;  ///< one line
  std::string saul_check;  ///< the bench-suite steps, run from just before at_us, that fail on this violation
};

struct Stats {
  std::uint64_t ticks = 0;
  std::uint64_t armings_button = 0;
  std::uint64_t armings_console = 0;
  std::uint64_t stops_while_armed = 0;  ///< stop events (any kind) that found the robot armed
  std::uint64_t latches = 0;
  std::uint64_t io_driving_ticks = 0;   ///< ticks with BTS7960 duty on
  std::uint64_t bal_driving_ticks = 0;  ///< ticks with a non-zero SET_RPM in force
  std::uint64_t resets = 0;
  std::uint64_t cap_raises = 0;
  std::uint64_t excite_ticks = 0;  ///< ticks with a test signal on BALANCE's setpoint
  std::uint64_t excite_starts = 0;  ///< test signals started (none -> on)
};

struct Result {
  std::optional<Violation> violation;
  Stats stats;
};

/// Runs an episode (events may be a subset of e.events) until its end or the first violation.
Result run(const Episode& e, const std::vector<Event>& events);
inline Result run(const Episode& e) { return run(e, e.events); }

/// Delta debugging (ddmin) over the events: a smallest subset still giving a violation of the same rule. At most
/// max_runs replays.
std::vector<Event> shrink(const Episode& e, const Violation& v, int max_runs = 400);

/// One event as text, and the whole sequence as a bench suite (tests/suites syntax, requires: sim) whose last steps
/// check the violated rule: it fails where the violation happens and passes on a robot that keeps the rule.
std::string describe(const Event& event);
std::string to_saul(const Episode& e, const std::vector<Event>& events, const Violation& v);

/// The episode's events, one per line with their times.
std::string listing(const std::vector<Event>& events);

}  // namespace fwtest::explore
