// saulctl tune auto --sim: proposes balance gains from experiments on the simulated robot, and verifies them there
// before showing them. The experiment: the shipped gains scaled together (ratios kept) by 1.0 .. 2.0, each run with
// a 20 s chirp (8 s deconvolution windows) on the seed given and its step response estimated (host/tune/analysis.hpp); the stiffest scale whose
// estimate overshoots under 25 %, shows no oscillation and never falls is proposed, then run 60 s untouched on every
// verification seed against the shipped gains: proposed only when it never falls and its mean pitch RMS is lower.
// Gains are never applied to anything: they are printed (send them with 'saulctl pid'). Without --sim it prints the
// experiment it would run on the live robot and sends nothing; with --yes it runs it there over BALANCE's console
// (the robot already armed in BALANCE: it never arms): each scaled set sent with `pid` and acknowledged, a chirp
// traced per set, the first set that falls, oscillates or overshoots ends it, and the robot's own gains are restored
// at the end, on Ctrl-C and on any error (read back with `status`).
#include <fmt/core.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include <unistd.h>  // getpid: a temporary file of this process

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/core/trace.hpp"
#include "saulproto/host/capture/trace_file.hpp"
#include "saulproto/host/link/shared_link.hpp"
#include "saulproto/host/report/trace_report.hpp"
#include "saulproto/host/robot/console_client.hpp"
#include "saulproto/host/robot/trace_session.hpp"
#include "saulproto/host/tune/analysis.hpp"
#include "saulproto/host/tune/series.hpp"
#include "saulsim/trace_run.hpp"

namespace saulctl {

namespace {

struct TuneAutoOptions {
  bool sim = false;
  std::string console_balance;  // the live robot's BALANCE console
  std::uint32_t seed = 1;
  std::uint32_t verify_seeds = 20;
  bool yes = false;
  std::string per_set = "20s";  // live: the chirp traced per gain set
};

constexpr float kShippedKp = 100.0F, kShippedKi = 500.0F, kShippedKd = 3.0F;  // the sim's shipped set (world.cpp)
constexpr double kMaxOvershootPct = 25.0;
constexpr float kChirpDeg = 1.0F, kChirpF0 = 0.5F, kChirpF1 = 15.0F;
constexpr std::chrono::seconds kTail{5};  // live: traced after each chirp (the speed loop's own motion)

/// A temporary trace file of this process.
std::string temp_trace() {
  return (std::filesystem::temp_directory_path() /
          fmt::format("saulctl-tune-auto-{}.trace", static_cast<long>(::getpid())))
      .string();
}

/// One gain set's figures printed; true when the set is good enough to propose (a step response overshooting under
/// the limit, no oscillation). `r` absent: the robot did not balance for the whole run.
bool judge(float scale, const saul::saulcan::PidGains& g, const std::optional<saul::host::tune::Report>& r,
           const std::string& fell) {
  if (!r || !r->step) {
    fmt::print("  x{:.1f}: {}\n", scale, r ? "no step response: " + r->step_reason : fell);
    return false;
  }
  const auto& f = r->step->figures;
  const bool good = f.overshoot_pct < kMaxOvershootPct && !r->oscillation;
  fmt::print("  x{:.1f}: Kp {:g} Ki {:g} Kd {:g}: overshoot {:.1f} %, settling {}, pitch RMS {:.3f} deg{}\n", scale,
             g.kp, g.ki, g.kd, f.overshoot_pct,
             f.settling_time_s ? fmt::format("{:.3f} s", *f.settling_time_s) : std::string("none"), r->pitch_rms_deg,
             good ? "" : r->oscillation ? "  (oscillates)" : "  (overshoots too much)");
  std::fflush(stdout);
  return good;
}

std::string settling_of(const saul::host::tune::StepFigures& f) {
  return f.settling_time_s ? fmt::format("{:.3f} s", *f.settling_time_s) : std::string("none");
}

/// One simulated run with these gains, analysed. No value when the robot did not balance for the whole run.
std::optional<saul::host::tune::Report> run(const saul::saulcan::PidGains& gains, std::uint32_t seed, double seconds,
                                            bool chirp, const std::string& file) {
  saul::sim::TraceRunOptions options;
  options.seed = seed;
  options.duration_us = static_cast<saul::fw::TimeUs>(seconds * 1e6);
  options.gains = gains;
  if (chirp) {
    saul::trace::ExciteStart e;
    e.kind = saul::trace::Excite::chirp;
    e.amplitude_deg = kChirpDeg;
    e.f0_hz = kChirpF0;
    e.f1_hz = kChirpF1;
    options.excite = e;
  }
  saul::host::TraceFileWriter writer(file);
  const auto r = saul::sim::run_sim_trace(options, [&](std::span<const std::uint8_t> b) { writer.write(b); },
                                          [] { return g_interrupted.load(); });
  writer.close();
  if (!r.ok) return std::nullopt;
  auto report = saul::host::tune::analyse(saul::host::tune::read_trace_series(file));
  if (report.falls > 0) return std::nullopt;
  return report;
}

/// The live robot's own gains, put back whatever ends the experiment: restore() at the end (and after Ctrl-C), the
/// destructor when an error (the port gone, a refusal) leaves early. Every change is printed as it is sent.
class GainsKeeper {
 public:
  GainsKeeper(saul::host::SerialPort& port, std::string& pending, const saul::saulcan::PidGains& own)
      : port_(port), pending_(pending), own_(own) {}
  GainsKeeper(const GainsKeeper&) = delete;
  GainsKeeper& operator=(const GainsKeeper&) = delete;
  ~GainsKeeper() {
    if (!changed_) return;
    try {
      (void)restore();
    } catch (const std::exception& e) {
      say("{}: could not restore the robot's gains ({}): send them yourself: saulctl console {} {}", port_.path(),
          e.what(), port_.path(), saul::host::pid_command(own_));
    }
  }

  /// Sends a set, waits for its "ok"; true when acknowledged. From the first send on, the robot's gains are ours to
  /// restore (a set may be taken even when its "ok" is lost).
  bool send(const saul::saulcan::PidGains& g, const std::string& why, const std::function<bool()>& interrupted) {
    const auto line = saul::host::pid_command(g);
    fmt::print("sending: {} ({}) ... ", line, why);
    std::fflush(stdout);
    changed_ = true;
    pending_.clear();
    const auto reply = saul::host::console_command(port_, line, std::chrono::seconds(2), pending_, interrupted);
    fmt::print("{}\n", reply.end == saul::host::ConsoleReply::End::ok ? "acknowledged"
                       : reply.end == saul::host::ConsoleReply::End::error ? reply.final_line
                                                                             : "no answer");
    std::fflush(stdout);
    return reply.end == saul::host::ConsoleReply::End::ok;
  }

  /// The robot's own gains sent back (a Ctrl-C no longer cuts the wait) and read back with status; true when the
  /// robot reports them.
  bool restore() {
    const auto never = [] { return false; };
    for (int attempt = 0; attempt < 3; ++attempt) {
      if (!send(own_, "restoring the robot's gains", never)) continue;
      pending_.clear();
      const auto status = saul::host::status_in(
          saul::host::console_command(port_, "status", std::chrono::seconds(2), pending_, never));
      if (status && status->kp == own_.kp && status->ki == own_.ki && status->kd == own_.kd) {
        fmt::print("restored: the robot reports kp={:g} ki={:g} kd={:g} again\n", status->kp, status->ki, status->kd);
        changed_ = false;
        return true;
      }
    }
    say("{}: the robot's gains could not be restored and read back: send them yourself: saulctl console {} {}",
        port_.path(), port_.path(), saul::host::pid_command(own_));
    return false;
  }

 private:
  saul::host::SerialPort& port_;
  std::string& pending_;
  saul::saulcan::PidGains own_;
  bool changed_ = false;
};

/// Reads and drops what the console sends for `time` (the speed loop brings the robot back between sets); false when
/// interrupted.
bool settle(saul::host::SerialPort& port, std::chrono::milliseconds time) {
  std::uint8_t buffer[4096];
  const auto until = std::chrono::steady_clock::now() + time;
  while (std::chrono::steady_clock::now() < until)
    if (g_interrupted || (port.read(buffer, std::chrono::milliseconds(20)), g_interrupted)) return false;
  return true;
}

/// One set's chirp traced on the live robot (host/robot/trace_session.hpp) into `file`, analysed. Absent with `why`
/// when BALANCE refused the signal or the run was interrupted.
std::optional<saul::host::tune::Report> live_run(saul::host::SerialPort& port, std::chrono::milliseconds per_set,
                                                 const std::string& file, std::string& why) {
  saul::host::TraceFileWriter writer(file);
  saul::host::TraceTap tap;
  saul::host::LiveTraceOptions options;
  // The trace runs on after the chirp while the speed loop brings the robot back: the chirp does not reach below
  // 0.5 Hz, and without that tail the estimate's low frequencies (its final value, so its overshoot) are guesses
  // (10 s chirps alone: overshoot 9-130 % for the same gains; docs/tuning.md).
  options.duration = per_set + kTail;
  saul::trace::ExciteStart e;
  e.kind = saul::trace::Excite::chirp;
  e.amplitude_deg = kChirpDeg;
  e.f0_hz = kChirpF0;
  e.f1_hz = kChirpF1;
  e.duration_s = static_cast<float>(per_set.count()) / 1000.0F;
  options.excite = e;
  const auto end = saul::host::run_live_trace(
      port, options,
      [&](std::span<const std::uint8_t> b) {
        writer.write(b);
        tap.push(b);
      },
      [] { return g_interrupted.load(); }, [&] { return !tap.refusal().empty(); },
      [&] { return tap.stats().duration_s(); });
  tap.finish();
  writer.close();
  if (!tap.refusal().empty()) why = "BALANCE refused the test signal: " + tap.refusal();
  else if (end.stopped == "interrupted") why = "interrupted";
  else if (end.stopped != "duration") why = "BALANCE's trace stopped: " + end.stopped;
  if (!why.empty()) return std::nullopt;
  return saul::host::tune::analyse(saul::host::tune::read_trace_series(file));
}

/// The live robot: the experiment printed; with --yes run over BALANCE's console, the robot's gains restored after.
int run_live(const TuneAutoOptions& o) {
  const auto per_set = parse_duration(o.per_set);
  if (per_set < std::chrono::seconds(10) || per_set > std::chrono::seconds(20))
    throw CLI::ValidationError("--duration", "between 10 s (5 deconvolution windows of 8 s) and 20 s (BALANCE's "
                                            "limit for a test signal)");
  const double per_set_s = static_cast<double>(per_set.count()) / 1000.0;
  fmt::print("live plan (robot: BALANCE console {}):\n", o.console_balance.empty() ? "not given (--console-balance)" : o.console_balance);
  fmt::print("  gains:      the robot's own (read from its status), scaled together by 1.0 .. 2.0 in steps of 0.2; each\n"
             "              set sent as one 'pid' command on BALANCE's console and its 'ok' awaited; the robot's gains\n"
             "              restored at the end, on Ctrl-C and on any error, and every change printed as it is sent\n");
  fmt::print("  excitation: chirp of {:g} deg on the pitch setpoint, {:g}-{:g} Hz, {:g} s per set, traced {:g} s more\n"
             "              (6 sets: about {:g} s), the loop traced at 1 kHz on BALANCE's console; the robot armed in\n"
             "              BALANCE on its tether beforehand (it is never armed by this), the speed cap raised to 50-90 %\n"
             "              first while disarmed\n",
             kChirpDeg, kChirpF0, kChirpF1, per_set_s, static_cast<double>(kTail.count()),
             6 * (per_set_s + static_cast<double>(kTail.count()) + 1));
  fmt::print("  limits:     amplitude at most {:g} deg and {:g} s per excitation (BALANCE refuses more); a set whose\n"
             "              trace shows a fall, an oscillation or an overshoot over {:g} % ends the experiment and the\n"
             "              robot's gains are restored\n",
             saul::trace::kMaxAmplitudeDeg, saul::trace::kMaxDurationS, kMaxOvershootPct);
  if (!o.yes) {
    fmt::print("nothing sent: this is the plan only (--yes runs it on the robot)\n");
    return kOk;
  }
  if (o.console_balance.empty())
    throw CLI::ValidationError("--console-balance", "--yes runs the plan on a robot: name BALANCE's console port");
  auto port = saul::host::open_shared_serial(o.console_balance, saul::host::SerialSettings{});
  std::string pending;
  const auto interrupted = [] { return g_interrupted.load(); };
  const auto status =
      saul::host::status_in(saul::host::console_command(*port, "status", std::chrono::seconds(2), pending, interrupted));
  if (!status) {
    say("{}: no status reply from BALANCE (is this BALANCE's USB console, and is it running?); nothing was sent",
        port->path());
    return kTimeout;
  }
  if (status->board != saul::console::Board::balance || status->state != saul::saulcan::RobotState::balance) {
    say("{}: the robot is in {}, not armed in BALANCE: arm it on its tether first (tune auto never arms it); "
        "nothing was sent",
        port->path(), saul::saulcan::to_string(status->state));
    return kFailure;
  }
  if (status->speed_limit_pct < saul::trace::kExciteMinCapPct) {
    say("{}: the speed cap is {} %, and BALANCE refuses a test signal below {} %: {}; nothing was sent", port->path(),
        status->speed_limit_pct, saul::trace::kExciteMinCapPct, raise_cap_hint(port->path()));
    return kFailure;
  }
  if (status->speed_limit_pct > saul::trace::kExciteMaxCapPct) {
    say("{}: the speed cap is {} %, and BALANCE refuses a test signal above {} %: disarm, then 'saulctl console {} "
        "speed_limit {}', arm again; nothing was sent",
        port->path(), status->speed_limit_pct, saul::trace::kExciteMaxCapPct, port->path(), saul::trace::kExciteMaxCapPct);
    return kFailure;
  }
  const saul::saulcan::PidGains own{status->kp, status->ki, status->kd};
  fmt::print("the robot's gains: kp={:g} ki={:g} kd={:g}\n", own.kp, own.ki, own.kd);
  const std::string file = temp_trace();
  std::optional<float> best;
  saul::saulcan::PidGains proposed;
  std::optional<saul::host::tune::StepFigures> predicted;
  std::string ended;
  {
    GainsKeeper keeper(*port, pending, own);
    for (int k = 10; k <= 20 && ended.empty(); k += 2) {
      const float scale = static_cast<float>(k) / 10.0F;
      const saul::saulcan::PidGains g{own.kp * static_cast<float>(k) / 10.0F, own.ki * static_cast<float>(k) / 10.0F,
                                     own.kd * static_cast<float>(k) / 10.0F};  // 100 x 12 / 10 is 120, not 120.00001
      if (k > 10 && !keeper.send(g, fmt::format("x{:.1f}", scale), interrupted)) {
        ended = g_interrupted ? "interrupted" : "BALANCE did not acknowledge the set";
        break;
      }
      std::string why;
      const auto r = live_run(*port, per_set, file, why);
      if (!why.empty()) {
        ended = why;
        break;
      }
      if (r->falls > 0) {
        ended = fmt::format("x{:.1f} fell", scale);
        judge(scale, g, std::nullopt, "fell (TILT_CUTOFF)");
        break;
      }
      if (!judge(scale, g, r, "")) {
        ended = fmt::format("x{:.1f} did not meet the limits", scale);
        break;
      }
      best = scale;
      proposed = g;
      predicted = r->step->figures;
      if (k < 20 && !settle(*port, std::chrono::seconds(1))) ended = "interrupted";
    }
    std::remove(file.c_str());
    if (!keeper.restore()) return kFailure;
  }
  if (!ended.empty()) fmt::print("ended: {}\n", ended);
  if (g_interrupted) return kFailure;
  if (!best) {
    fmt::print("no answer: no set met the overshoot and oscillation limits\n");
    return kTimeout;
  }
  fmt::print("proposed: Kp {:g} Ki {:g} Kd {:g}  (x{:.1f}; measured: overshoot {:.1f} %, rise {:.3f} s, settling {})\n",
             proposed.kp, proposed.ki, proposed.kd, *best, predicted->overshoot_pct, predicted->rise_time_s,
             settling_of(*predicted));
  fmt::print("not applied: the robot runs its own gains again; send these with 'saulctl console {} {}' when you "
             "choose to\n",
             o.console_balance, saul::host::pid_command(proposed));
  return kOk;
}

int run_tune_auto(const TuneAutoOptions& o) {
  if (!o.sim) return run_live(o);
  fmt::print("experiment: the shipped gains (Kp {} Ki {} Kd {}) scaled together by 1.0 .. 2.0; each scale balances\n"
             "  20 s with a 1 deg chirp (0.5-15 Hz) on seed {}; the stiffest whose estimated step response overshoots\n"
             "  under {:g} % without oscillation is verified: 60 s on seeds 1-{}, never falling, mean pitch RMS below\n"
             "  the shipped gains'. Nothing is applied: the gains are printed for you to send ('saulctl pid').\n",
             kShippedKp, kShippedKi, kShippedKd, o.seed, kMaxOvershootPct, o.verify_seeds);
  const std::string file = temp_trace();
  std::optional<float> best;
  std::optional<saul::host::tune::StepFigures> predicted;
  for (int k = 10; k <= 20; k += 2) {
    const float scale = static_cast<float>(k) / 10.0F;
    const saul::saulcan::PidGains g{kShippedKp * scale, kShippedKi * scale, kShippedKd * scale};
    const auto r = run(g, o.seed, 20.0, true, file);
    if (judge(scale, g, r, "did not balance the 20 s")) {
      best = scale;
      predicted = r->step->figures;
    }
  }
  if (!best) {
    std::remove(file.c_str());
    fmt::print("no answer: no scale met the overshoot and oscillation limits\n");
    return kTimeout;
  }
  const saul::saulcan::PidGains proposed{kShippedKp * *best, kShippedKi * *best, kShippedKd * *best};
  const saul::saulcan::PidGains shipped{kShippedKp, kShippedKi, kShippedKd};
  double rms_proposed = 0, rms_shipped = 0;
  std::uint32_t held = 0;
  for (std::uint32_t seed = 1; seed <= o.verify_seeds; ++seed) {
    const auto a = run(proposed, seed, 60.0, false, file);
    const auto b = run(shipped, seed, 60.0, false, file);
    if (a) {
      ++held;
      rms_proposed += a->pitch_rms_deg;
    }
    if (b) rms_shipped += b->pitch_rms_deg;
    std::fprintf(stderr, "\rverifying: seed %u of %u", seed, o.verify_seeds);
  }
  std::fprintf(stderr, "\n");
  std::remove(file.c_str());
  const double n = o.verify_seeds > 0 ? o.verify_seeds : 1;
  fmt::print("verification: held 60 s on {} of {} seeds; mean pitch RMS {:.4f} deg (shipped {:.4f} deg)\n", held,
             o.verify_seeds, rms_proposed / n, rms_shipped / n);
  if (held != o.verify_seeds || !(rms_proposed < rms_shipped)) {
    fmt::print("no answer: x{:.1f} did not pass the verification\n", *best);
    return kTimeout;
  }
  fmt::print("proposed: Kp {:g} Ki {:g} Kd {:g}  (predicted: overshoot {:.1f} %, rise {:.3f} s, settling {})\n",
             proposed.kp, proposed.ki, proposed.kd, predicted->overshoot_pct, predicted->rise_time_s,
             settling_of(*predicted));
  fmt::print("not applied: send them with 'saulctl pid {:g} {:g} {:g}' when you choose to\n", proposed.kp, proposed.ki,
             proposed.kd);
  return kOk;
}

}  // namespace

void add_tune_auto_command(CLI::App& tune, Runner& run) {
  auto [cmd, o] = add_verb<TuneAutoOptions>(
      tune, run, "auto",
      "Propose balance gains from experiments on the simulated or the armed live robot (never applied)", run_tune_auto);
  cmd->add_flag("--sim", o->sim, "run the experiment on the simulated robot, in this process, on simulated time");
  cmd->add_option("--seed", o->seed, "noise seed of the experiment")->capture_default_str();
  cmd->add_option("--verify-seeds", o->verify_seeds, "verify on seeds 1..N, 60 s each")
      ->check(CLI::Range(1U, 100U))
      ->capture_default_str();
  cmd->add_option("--console-balance", o->console_balance, "the live robot's BALANCE console port, e.g. /dev/ttyACM1");
  cmd->add_flag("--yes", o->yes, "run the plan on the live robot (armed in BALANCE beforehand; its gains restored after)");
  add_duration_option(cmd, o->per_set, "live: the chirp traced per gain set (10 s to 20 s)")->capture_default_str();
  cmd->footer("\nExamples:\n"
              "  saulctl tune auto --sim                 the experiment on seed 1, verified on seeds 1-20\n"
              "  saulctl tune auto --sim --seed 4 --verify-seeds 5\n"
              "  saulctl tune auto --console-balance /dev/ttyACM1         the live robot: prints the plan, sends nothing\n"
              "  saulctl tune auto --console-balance /dev/ttyACM1 --yes   runs it: the robot armed in BALANCE on its tether\n"
              "\nWithout --sim nothing is sent unless --yes is given. With --yes the robot must already be armed in BALANCE\n"
              "with its speed cap at 50 % to 90 % (motion needs your intent: this never arms, and the cap moves only\n"
              "while disarmed); its gains are read, each scaled set is sent with 'pid' and acknowledged (printed as it is\n"
              "sent), a chirp is traced per set, and the robot's own gains are restored and read back at the end, on\n"
              "Ctrl-C and on any error. The proposal is printed, never applied.\n"
              "\nExit codes: 0 gains proposed (or the live plan printed), 1 refused (not armed in BALANCE, or the speed cap\n"
              "below 50 %), interrupted or the gains not restored, 2 usage, 3 no gains passed (or no answer from BALANCE).\n");
}

}  // namespace saulctl
