// saulctl tune auto --sim: proposes balance gains from experiments on the simulated robot, and verifies them there
// before showing them. The experiment: the shipped gains scaled together (ratios kept) by 1.0 .. 2.0, each run with
// a 20 s chirp (8 s deconvolution windows) on the seed given and its step response estimated (host/tune/analysis.hpp); the stiffest scale whose
// estimate overshoots under 25 %, shows no oscillation and never falls is proposed, then run 60 s untouched on every
// verification seed against the shipped gains: proposed only when it never falls and its mean pitch RMS is lower.
// Gains are never applied to anything: they are printed (send them with 'saulctl pid'). Without --sim it prints the
// experiment it would run on the live robot and sends nothing; --yes (running it there) is refused for now.
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
#include "saulproto/host/tune/analysis.hpp"
#include "saulproto/host/tune/series.hpp"
#include "saulsim/trace_run.hpp"

namespace saulctl {

namespace {

struct TuneAutoOptions {
  bool sim = false;
  std::string console_balance;  // the live robot's BALANCE console (the plan names it; nothing is opened yet)
  std::uint32_t seed = 1;
  std::uint32_t verify_seeds = 20;
  bool yes = false;
};

constexpr float kShippedKp = 100.0F, kShippedKi = 500.0F, kShippedKd = 3.0F;  // the sim's shipped set (world.cpp)
constexpr double kMaxOvershootPct = 25.0;

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
    e.amplitude_deg = 1.0F;
    e.f0_hz = 0.5F;
    e.f1_hz = 15.0F;
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

/// The live robot: the experiment it would run, printed; nothing is opened or sent. With --yes it refuses: driving a
/// live robot through the experiment is not implemented yet, and nothing may move a motor by accident.
int print_live_plan(const TuneAutoOptions& o) {
  fmt::print("live plan (robot: BALANCE console {}):\n", o.console_balance.empty() ? "not given (--console-balance)" : o.console_balance);
  fmt::print("  gains:      the robot's own (read from its status), scaled together by 1.0 .. 2.0 in steps of 0.2; each\n"
             "              set sent as one PID set (0x301) and its acknowledgement awaited; the robot's gains restored\n"
             "              at the end, and every change printed as it is sent\n");
  fmt::print("  excitation: chirp of {:g} deg on the pitch setpoint, 0.5-15 Hz, 20 s per set (6 sets: 120 s), the loop\n"
             "              traced at 1 kHz on BALANCE's console; the robot armed in BALANCE on its tether beforehand\n",
             1.0);
  fmt::print("  limits:     amplitude at most {:g} deg and {:g} s per excitation (BALANCE refuses more); a set whose\n"
             "              trace shows a fall, an oscillation or an overshoot over {:g} % ends the experiment and the\n"
             "              robot's gains are restored\n",
             saul::trace::kMaxAmplitudeDeg, saul::trace::kMaxDurationS, kMaxOvershootPct);
  if (!o.yes) {
    fmt::print("nothing sent: this is the plan only (--yes would run it on the robot: not implemented yet)\n");
    return kOk;
  }
  say("--yes: running the experiment is not implemented for live robots yet; nothing "
      "was sent (use --sim, or 'tune record --excite' and 'tune report' by hand)");
  return kFailure;
}

int run_tune_auto(const TuneAutoOptions& o) {
  if (!o.sim) return print_live_plan(o);
  fmt::print("experiment: the shipped gains (Kp {} Ki {} Kd {}) scaled together by 1.0 .. 2.0; each scale balances\n"
             "  20 s with a 1 deg chirp (0.5-15 Hz) on seed {}; the stiffest whose estimated step response overshoots\n"
             "  under {:g} % without oscillation is verified: 60 s on seeds 1-{}, never falling, mean pitch RMS below\n"
             "  the shipped gains'. Nothing is applied: the gains are printed for you to send ('saulctl pid').\n",
             kShippedKp, kShippedKi, kShippedKd, o.seed, kMaxOvershootPct, o.verify_seeds);
  const std::string file = (std::filesystem::temp_directory_path() / fmt::format("saulctl-tune-auto-{}.trace",
                                                                                   static_cast<long>(::getpid())))
                               .string();
  std::optional<float> best;
  std::optional<saul::host::tune::StepFigures> predicted;
  for (int k = 10; k <= 20; k += 2) {
    const float scale = static_cast<float>(k) / 10.0F;
    const saul::saulcan::PidGains g{kShippedKp * scale, kShippedKi * scale, kShippedKd * scale};
    const auto r = run(g, o.seed, 20.0, true, file);
    if (!r || !r->step) {
      fmt::print("  x{:.1f}: {}\n", scale, r ? "no step response: " + r->step_reason : "did not balance the 20 s");
      continue;
    }
    const auto& f = r->step->figures;
    const bool good = f.overshoot_pct < kMaxOvershootPct && !r->oscillation;
    fmt::print("  x{:.1f}: Kp {:g} Ki {:g} Kd {:g}: overshoot {:.1f} %, settling {}, pitch RMS {:.3f} deg{}\n", scale,
               g.kp, g.ki, g.kd, f.overshoot_pct,
               f.settling_time_s ? fmt::format("{:.3f} s", *f.settling_time_s) : std::string("none"),
               r->pitch_rms_deg, good ? "" : r->oscillation ? "  (oscillates)" : "  (overshoots too much)");
    if (good) {
      best = scale;
      predicted = f;
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
             predicted->settling_time_s ? fmt::format("{:.3f} s", *predicted->settling_time_s) : std::string("none"));
  fmt::print("not applied: send them with 'saulctl pid {:g} {:g} {:g}' when you choose to\n", proposed.kp, proposed.ki,
             proposed.kd);
  return kOk;
}

}  // namespace

void add_tune_auto_command(CLI::App& tune, Runner& run) {
  auto o = std::make_shared<TuneAutoOptions>();
  auto* cmd = tune.add_subcommand("auto", "Propose balance gains from experiments on the simulated robot (never applied)");
  cmd->add_flag("--sim", o->sim, "run the experiment on the simulated robot, in this process, on simulated time");
  cmd->add_option("--seed", o->seed, "noise seed of the experiment")->capture_default_str();
  cmd->add_option("--verify-seeds", o->verify_seeds, "verify on seeds 1..N, 60 s each")
      ->check(CLI::Range(1U, 100U))
      ->capture_default_str();
  cmd->add_option("--console-balance", o->console_balance, "the live robot's BALANCE console, for the plan");
  cmd->add_flag("--yes", o->yes, "run the plan on the live robot (not implemented yet: refused, nothing sent)");
  cmd->footer("\nExamples:\n"
              "  saulctl tune auto --sim                 the experiment on seed 1, verified on seeds 1-20\n"
              "  saulctl tune auto --sim --seed 4 --verify-seeds 5\n"
              "  saulctl tune auto --console-balance /dev/ttyACM1   the live robot: prints the experiment only, sends nothing\n"
              "\nWithout --sim nothing is sent unless --yes is given, and --yes is refused for now (live runs are not\n"
              "implemented yet). Gains are never applied without saying so: --sim prints them for 'saulctl pid'.\n"
              "\nExit codes: 0 gains proposed (or the live plan printed), 1 --yes on a live robot (refused), 2 usage,\n"
              "3 no gains passed the verification.\n");
  attach_runner(cmd, o, run, run_tune_auto);
}

}  // namespace saulctl
