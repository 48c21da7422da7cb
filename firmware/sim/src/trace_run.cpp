#include "saulsim/trace_run.hpp"

#include <fmt/core.h>

#include "saulproto/host/report/trace_report.hpp"
#include "saulsim/world.hpp"

namespace saul::sim {

namespace {

constexpr fw::TimeUs kMs = 1000;

/// The console line of a command, as saulctl would type it.
std::string line_of(const trace::Command& command) {
  char text[64];
  const auto n = trace::format_command(command, text);
  return std::string(text, n.ok() ? *n : 0);
}

}  // namespace

TraceRunResult run_sim_trace(const TraceRunOptions& options, const std::function<void(std::span<const std::uint8_t>)>& out,
                             const std::function<bool()>& interrupted) {
  TraceRunResult result;
  WorldConfig config;
  config.plant.seed = options.seed;
  if (options.gains) config.balance.gains = *options.gains;
  World world(config);
  host::TraceTap tap;  // the trace, then (with dump) the flight recorder's records
  bool tracing = false;
  // Steps the world to t, handing the console's bytes on (and counting them once the trace runs).
  const auto run_to = [&](fw::TimeUs t) {
    while (world.now_us() < t) {
      world.step();
      const std::string bytes = world.take_console_output("balance");
      const auto span = std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
      if (tracing) tap.push(span);
      out(span);
      if (world.now_us() % (10 * kMs) == 0) {
        (void)world.take_can_output();  // nobody reads the bus here
        (void)world.take_console_output("io");
        if (interrupted()) return false;
      }
    }
    return true;
  };
  const auto finish = [&](const std::string& why) {
    tap.finish();
    result.simulated_s = static_cast<double>(world.now_us()) / 1e6;
    result.stopped = why;
    return result;
  };

  // The speed cap raised to 50 % (one 10 % step per line, disarmed), typed at power-on as a suite's `sim type`
  // lines are: a test signal holds the speed loop's lean and ends at half the cap, and at the power-on 10 %
  // (200 mm/s) a 1 deg chirp reaches that within seconds.
  for (const char* raise : {"speed_limit 20\n", "speed_limit 30\n", "speed_limit 40\n", "speed_limit 50\n"})
    world.console_input("balance", raise);
  // Arm as the bench suites do: the IO board up, the 3 s hold of the button, then a moment to find the balance.
  if (!run_to(1500 * kMs)) return finish("interrupted");
  (void)world.command("button down");
  if (!run_to(world.now_us() + 3200 * kMs)) return finish("interrupted");
  (void)world.command("button up");
  if (!run_to(world.now_us() + 2500 * kMs)) return finish("interrupted");
  if (world.balance().state() != saulcan::RobotState::balance)
    return finish("not armed: the simulated robot did not reach BALANCE after the 3 s button hold");

  // With dump, the robot balances for the duration untraced: the file then holds the flight recorder's records only.
  // BALANCE's status first: its "report=status ... kp= ki= kd=" line in the file says which gains the trace ran
  // with (docs/captures.md, "Loop traces"), in the board's own words.
  world.console_input("balance", "status\n");
  if (!run_to(world.now_us() + 20 * kMs)) return finish("interrupted");
  tracing = !options.dump;
  if (!options.dump)
    world.console_input("balance", line_of(trace::TraceOn{options.divider == 0 ? std::uint16_t{1} : options.divider}));
  const fw::TimeUs end = world.now_us() + options.duration_us;
  if (options.excite && options.excite->kind == trace::Excite::step) {
    // A direct step test: after a quiet second, steps of the amplitude held kStepHold (the step response's 1.5 s
    // and a margin), each followed by kStepRest of the speed loop bringing the robot back, the sign alternating
    // so that it drives to and fro. The held lean (BalanceBoard::balance_output) keeps the setpoint flat during
    // each step, so tune report measures the pitch loop's response at every one of them (step_direct). Each step
    // starts kSpread later in BALANCE's 10 ms SET_RPM period than the one before, so ten steps meet the wheels'
    // command at every phase, as a chirp does and as steps on the robot do: 5.5 s apart, a whole number of periods,
    // every step met it at the same phase, and the averaged response was that phase's (docs/tuning.md).
    constexpr fw::TimeUs kStepHold = 2000 * kMs;
    constexpr fw::TimeUs kStepRest = 3500 * kMs;
    constexpr fw::TimeUs kSpread = World::kStepUs;
    trace::ExciteStart e = *options.excite;
    e.duration_s = static_cast<float>(kStepHold) * 1e-6F;
    const fw::TimeUs quiet = std::min<fw::TimeUs>(1000 * kMs, options.duration_us / 4);
    if (!run_to(world.now_us() + quiet)) return finish("interrupted");
    for (float sign = 1.0F; world.now_us() + kStepHold <= end; sign = -sign) {
      e.amplitude_deg = sign * options.excite->amplitude_deg;
      world.console_input("balance", line_of(e));
      if (!run_to(std::min(end, world.now_us() + kStepHold + kStepRest + kSpread))) return finish("interrupted");
    }
  } else if (options.excite) {
    // The signal for the trace's duration: at most 20 s at a time (an excitation's limit), and when one ends early
    // (the robot's speed reached half the cap) or the trace is longer, kRest of the speed loop and the next.
    constexpr fw::TimeUs kRest = 5000 * kMs;
    while (world.now_us() + kRest < end) {
      trace::ExciteStart e = *options.excite;
      e.duration_s = std::min(trace::kMaxDurationS, static_cast<float>(end - world.now_us()) * 1e-6F);
      world.console_input("balance", line_of(e));
      if (!run_to(world.now_us() + 10 * kMs)) return finish("interrupted");
      while (world.now_us() < end && world.balance().excitation() != trace::Excite::none)
        if (!run_to(world.now_us() + 10 * kMs)) return finish("interrupted");
      if (!run_to(std::min(end, world.now_us() + kRest))) return finish("interrupted");
    }
  }
  if (!run_to(end)) return finish("interrupted");
  world.console_input("balance", line_of(trace::TraceOff{}));
  if (!run_to(world.now_us() + 5 * kMs)) return finish("interrupted");
  tracing = false;
  const host::TraceStats& stats = tap.stats();
  result.records = stats.records();
  result.gaps = stats.gaps();
  result.missing = stats.missing();
  if (!tap.refusal().empty()) return finish("BALANCE refused: " + tap.refusal());
  if (!options.dump && result.records == 0) return finish("no records came");
  if (world.balance().state() != saulcan::RobotState::balance) return finish("the robot left BALANCE during the trace");
  result.ok = true;
  if (!options.dump) return finish("duration");

  // The flight recorder: a push beyond what the loop holds trips the tilt cutoff; the dump brings the 5 s before it.
  (void)world.command("tilt 40");
  if (!run_to(world.now_us() + 1000 * kMs)) return finish("interrupted");
  world.console_input("balance", line_of(trace::TraceDump{}));
  const std::uint64_t traced = tap.stats().records();
  tracing = true;
  for (fw::TimeUs until = world.now_us() + 2000 * kMs; !tap.dump_ended() && world.now_us() < until;)
    if (!run_to(world.now_us() + 10 * kMs)) return finish("interrupted");
  result.dump_records = tap.stats().records() - traced;
  result.gaps = tap.stats().gaps();
  result.missing = tap.stats().missing();
  return finish(tap.dump_ended() ? "duration, then the flight recorder after a tilt cutoff"
                                  : "the flight recorder's dump did not end");
}

}  // namespace saul::sim
