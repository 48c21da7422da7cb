// saulctl tune record: a loop trace from BALANCE's console (or from the simulated robot, on simulated time) into a
// trace file (docs/captures.md, "Loop traces"). The talking is libsaulproto's (host/robot/trace_session.hpp), the
// simulated run firmware/sim's (trace_run.hpp), the counting host/report/trace_report.hpp's.
#include <fmt/core.h>

#include <memory>
#include <vector>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/host/capture/trace_file.hpp"
#include "saulproto/host/link/shared_link.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/trace_report.hpp"
#include "saulproto/host/robot/trace_session.hpp"
#include "saulsim/trace_run.hpp"

namespace saulctl {
namespace {

struct TuneRecordOptions {
  std::string out;
  std::string duration = "10s";
  std::string excite;
  float amplitude = 1.0F;
  float f0 = 0.5F;
  float f1 = 15.0F;
  std::uint16_t divider = 1;
  std::string console_balance;
  bool sim = false;
  std::uint32_t seed = 1;
  std::vector<float> gains;  // --gains KP KI KD (--sim only)
  bool dump = false;
  bool json = false;
};

std::optional<saul::trace::ExciteStart> excitation(const TuneRecordOptions& o) {
  using saul::trace::Excite;
  if (o.excite.empty()) return std::nullopt;
  saul::trace::ExciteStart e;
  e.kind = o.excite == "step" ? Excite::step : o.excite == "chirp" ? Excite::chirp : Excite::prbs;
  e.amplitude_deg = o.amplitude;
  e.f0_hz = o.f0;
  e.f1_hz = o.f1;
  e.duration_s = saul::trace::kMaxDurationS;
  return e;
}

int run_tune_record(const TuneRecordOptions& o) {
  const auto duration = parse_duration(o.duration);
  if (duration.count() <= 0) throw CLI::ValidationError("--duration", "the duration must be at least 1 ms");
  if (!o.sim && o.console_balance.empty())
    throw CLI::ValidationError("--console-balance", "name BALANCE's console port (or --sim for the simulated robot)");
  if (!o.gains.empty() && !o.sim)
    throw CLI::ValidationError("--gains", "only with --sim: on the robot send gains with 'saulctl pid' (and see them acked)");
  saul::host::TraceFileWriter file(o.out);
  saul::host::TraceTap tap;
  const auto take = [&](std::span<const std::uint8_t> bytes) {
    file.write(bytes);
    tap.push(bytes);
  };
  const auto interrupted = [] { return g_interrupted.load(); };
  std::string stopped;
  std::uint64_t dump_records = 0;
  const auto started = std::chrono::steady_clock::now();
  double simulated_s = 0;
  if (o.sim) {
    saul::sim::TraceRunOptions options;
    options.seed = o.seed;
    options.duration_us = static_cast<saul::fw::TimeUs>(duration.count()) * 1000;
    options.divider = o.divider;
    options.excite = excitation(o);
    options.dump = o.dump;
    if (o.gains.size() == 3) options.gains = saul::saulcan::PidGains{o.gains[0], o.gains[1], o.gains[2]};
    const auto r = saul::sim::run_sim_trace(options, take, interrupted);
    stopped = r.stopped;
    dump_records = r.dump_records;
    simulated_s = r.simulated_s;
  } else {
    saul::host::SerialSettings settings;
    auto port = saul::host::open_shared_serial(o.console_balance, settings);  // beside monitor, console, ...
    saul::host::LiveTraceOptions options;
    options.duration = duration;
    options.divider = o.divider;
    options.excite = excitation(o);
    options.dump = o.dump;
    const auto done = [&] { return !tap.refusal().empty() || tap.dump_ended(); };
    const auto traced_s = [&] { return tap.stats().duration_s(); };
    stopped = saul::host::run_live_trace(*port, options, take, interrupted, done, traced_s).stopped;
  }
  tap.finish();
  file.close();
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const auto& s = tap.stats();
  if (!tap.refusal().empty()) stopped = "BALANCE refused: " + tap.refusal();
  if (!o.sim && tap.refusal().find(saul::trace::kExciteCapRefusal) != std::string::npos)
    say("{}: BALANCE refused the test signal, its speed cap is below {} %: {}", o.console_balance,
        saul::trace::kExciteMinCapPct, raise_cap_hint(o.console_balance));
  if (o.json) {
    nlohmann::json j = s.json(o.out);
    j["stopped"] = stopped;
    if (o.sim) j["simulated_s"] = simulated_s;
    j["wall_s"] = wall_s;
    fmt::print("{}\n", saul::host::json_line(j));
  } else {
    fmt::print("saulctl tune record: {} records ({} gaps, {} missing) at {:.1f} Hz over {:.3f} s into {}\n",
               s.records(), s.gaps(), s.missing(), s.rate_hz(), s.duration_s(), o.out);
    if (o.sim)
      fmt::print("simulated robot (seed {}): {:.1f} s simulated in {:.2f} s ({:.0f}x real time)\n", o.seed, simulated_s,
                 wall_s, wall_s > 0 ? simulated_s / wall_s : 0.0);
    if (o.dump) fmt::print("flight recorder: {} records{}\n", o.sim ? dump_records : s.records(), "");
    fmt::print("stopped: {}\n", stopped);
  }
  const bool ok = stopped.starts_with("duration") || stopped.starts_with("the flight recorder");
  return g_interrupted ? kFailure : (ok && s.records() > 0 ? kOk : kFailure);
}

}  // namespace

void add_tune_record_command(CLI::App& tune, Runner& run) {
  auto [cmd, o] = add_verb<TuneRecordOptions>(tune, run, "record",
                                              "Record BALANCE's 1 kHz loop trace into a trace file", run_tune_record);
  cmd->add_option("-o,--output", o->out, "the trace file to write")->required();
  add_duration_option(cmd, o->duration, "how long to trace, on the robot's clock (its records' time)")->capture_default_str();
  cmd->add_option("--excite", o->excite, "add a test signal to the pitch setpoint while tracing")
      ->check(CLI::IsMember({"step", "chirp", "prbs"}));
  cmd->add_option("--amplitude", o->amplitude, "the test signal's amplitude in degrees (at most 2)")
      ->check(CLI::Range(-2.0F, 2.0F))
      ->capture_default_str();
  cmd->add_option("--f0", o->f0, "chirp: start frequency in Hz")->check(CLI::Range(0.05F, 100.0F))->capture_default_str();
  cmd->add_option("--f1", o->f1, "chirp: end frequency in Hz")->check(CLI::Range(0.05F, 100.0F))->capture_default_str();
  cmd->add_option("--divider", o->divider, "a record every N-th loop (1 = every loop, 1 kHz)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--console-balance", o->console_balance, "BALANCE board USB console port, e.g. /dev/ttyACM1");
  cmd->add_flag("--sim", o->sim, "trace the simulated robot in this process, on simulated time (armed first)");
  cmd->add_option("--seed", o->seed, "noise seed for --sim")->capture_default_str();
  cmd->add_option("--gains", o->gains, "--sim: the balance PID's gains KP KI KD instead of the sim's shipped 100 500 3")
      ->expected(3)
      ->check(CLI::Range(0.0F, 1000.0F));
  cmd->add_flag("--dump", o->dump,
                "fetch the flight recorder (the last 5 s before a latch) instead; with --sim: trace, tilt, then dump");
  cmd->add_flag("--json", o->json, "print the summary as one JSON object");
  cmd->footer(
      "\nThe file holds the console's bytes: 39-byte records (docs/protocol.md section 10) and any text between them;\n"
      "BALANCE's status reply comes first, so the file says which gains the loop ran with (tune report shows them).\n"
      "decode, stats, convert (CSV) and plot read it. The test signal needs BALANCE (armed), sticks centred, Orin at 0.\n"
      "While it runs BALANCE holds its speed loop's lean (the signal meets the pitch loop alone) and ends it when the\n"
      "wheels pass half the speed cap; below a 50 % cap it refuses the signal (the robot could not be brought back),\n"
      "and above 90 % (it came back so hard that it fell): set the cap while disarmed first ('saulctl console PORT\n"
      "speed_limit 20', 30, 40, 50); --sim does. With --sim, --excite step is a series of 2 s steps, 3.5 s apart, the\n"
      "sign alternating.\n"
      "The console port is shared: 'saulctl console' or another saulctl can use it beside the recording.\n"
      "\nExamples:\n"
      "  saulctl tune record --sim --seed 3 --duration 10s --excite chirp --amplitude 1 -o run.trace\n"
      "  saulctl tune record --sim --gains 140 700 4 --excite prbs -o stiff.trace    another gain set, simulated\n"
      "  saulctl tune record --console-balance /dev/ttyACM1 --duration 30s --excite step --amplitude 0.5 -o step.trace\n"
      "  saulctl tune record --console-balance /dev/ttyACM1 --dump -o fall.trace     the 5 s before the last latch\n"
      "  saulctl stats run.trace; saulctl convert run.trace run.csv\n"
      "\nExit codes: 0 recorded, 1 nothing recorded or BALANCE refused (the reason is printed), 2 usage.\n");
}

}  // namespace saulctl
