// saulctl pride vcu: act as the VCU on the Pride ES link (host/pride_vcu.hpp does the timing, echo and neutral).
#include <fmt/core.h>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/host/robot/pride_vcu.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;

struct PrideOptions {
  std::string port;
  int fb = 0;
  int lr = 0;
  int speed_level = 0;
  std::string duration;
  bool yes = false;
  bool json = false;
};

std::string status_text(const saul::pride::ControllerStatus& s) {
  return fmt::format("error_byte 0x{:02X} ({}) battery {} unknown 0x{:02X}", s.error_byte,
                     s.ready() ? "ready" : s.error() ? "error" : "undocumented", s.battery_charge, s.unknown);
}

void print_report(const PrideOptions& opt, const saul::host::PrideVcu& vcu, bool final) {
  const auto& c = vcu.counters();
  const auto& e = vcu.echo_counters();
  const auto& d = vcu.decoder_counters();
  const auto last = vcu.last_status();
  if (opt.json) {
    nlohmann::json j{{"final", final},
                     {"neutral", vcu.neutral()},
                     {"frames_sent", c.frames_sent},
                     {"missed_slots", c.missed_slots},
                     {"controller_frames", c.controller_frames},
                     {"foreign_vcu_frames", c.foreign_vcu_frames},
                     {"late_echoes", c.late_echoes},
                     {"echo_dropped", e.echoes_dropped},
                     {"echo_mismatches", e.mismatches},
                     {"checksum_errors", d.checksum_errors},
                     {"bytes_skipped", d.bytes_skipped}};
    if (last)
      j["controller"] = {{"error_byte", last->error_byte}, {"ready", last->ready()},
                         {"battery_charge", last->battery_charge}, {"unknown", last->unknown}};
    fmt::print("{}\n", j.dump());
  } else {
    fmt::print("pride{}: sent {} ({}) | controller {} frames, {} | vcu frames heard {} | echo dropped {} mismatches {} "
               "| checksum errors {} skipped {} | missed slots {}\n",
               final ? " (end)" : "", c.frames_sent, vcu.neutral() ? "neutral" : "driving", c.controller_frames,
               last ? status_text(*last) : "no reply yet", c.foreign_vcu_frames, e.echoes_dropped, e.mismatches,
               d.checksum_errors, d.bytes_skipped, c.missed_slots);
  }
  std::fflush(stdout);
}

int run_pride_vcu(const PrideOptions& opt) {
  if (opt.speed_level < 0 || opt.speed_level > saul::pride::VcuCommand::kMaxSpeedLevel || opt.fb < -100 ||
      opt.fb > 100 || opt.lr < -100 || opt.lr > 100)
    throw CLI::ValidationError("pride", "--speed-level must be 0..14 and --fb, --lr -100..100");
  const saul::pride::VcuCommand cmd{.speed_level = static_cast<std::uint8_t>(opt.speed_level),
                                    .forward_back = static_cast<std::int8_t>(opt.fb),
                                    .left_right = static_cast<std::int8_t>(opt.lr)};
  const bool limited = !opt.duration.empty();
  const milliseconds duration = limited ? parse_duration(opt.duration) : milliseconds(0);
  if ((opt.fb != 0 || opt.lr != 0) &&
      !confirm_motion(opt.yes, fmt::format("drive the Pride controller on {} (FB {}, LR {})", opt.port, opt.fb, opt.lr)))
    return kUsage;

  auto port = saul::host::open_serial(opt.port, {.baud = saul::pride::kBaudRate, .parity = saul::host::Parity::even});
  saul::host::PrideVcu vcu(*port, [] { return steady_clock::now(); }, cmd);
  if (!opt.json)
    fmt::print(stderr, "pride: VCU on {} (38400 8E1), FB {} LR {} speed level {}; Ctrl-C stops (neutral first)\n",
               port->path(), opt.fb, opt.lr, opt.speed_level);
  const auto start = steady_clock::now();
  auto next_report = start + milliseconds(200);
  int status = kOk;
  try {
    while (!vcu.finished()) {
      if (!vcu.neutral() && (g_interrupted || (limited && steady_clock::now() - start >= duration))) vcu.begin_neutral();
      vcu.step();
      if (steady_clock::now() >= next_report) {
        print_report(opt, vcu, false);
        next_report += milliseconds(200);
      }
    }
  } catch (const std::exception& e) {
    status = report_error(e);
    // Neutral before leaving, if the port still takes bytes.
    try {
      vcu.begin_neutral();
      while (!vcu.finished()) vcu.step();
    } catch (const std::exception&) {
    }
  }
  print_report(opt, vcu, true);
  return status;
}

}  // namespace

void add_pride_command(CLI::App& app, Runner& run) {
  auto* pride = app.add_subcommand("pride", "The Pride ES wheelchair controller link");
  pride->require_subcommand(1);
  auto [cmd, o] = add_verb<PrideOptions>(
      *pride, run, "vcu", "Act as the VCU: a frame every 5 ms, the controller's replies decoded", run_pride_vcu);
  cmd->add_option("port", o->port, "serial device on the one-wire link (38400 8E1)")->required();
  cmd->add_option("--fb", o->fb, "forward/back, -100..100 (+ forward)")->capture_default_str();
  cmd->add_option("--lr", o->lr, "left/right, -100..100 (+ right)")->capture_default_str();
  cmd->add_option("--speed-level", o->speed_level, "speed setting 0..14")->capture_default_str();
  add_duration_option(cmd, o->duration, "stop after this long; default: until Ctrl-C");
  cmd->add_flag("-y,--yes", o->yes, "confirm motion (FB or LR not 0) without asking");
  cmd->add_flag("--json", o->json, "one JSON object per report (~5 Hz) and at the end");
  cmd->footer(
      "\nSends FE 54 SP FB LR CS every 5 ms on absolute deadlines, drops its own echo, decodes the controller's\n"
      "4A 01 EB BC UN CS frames and prints them about 5 times a second. On Ctrl-C, --duration or an error it sends\n"
      "neutral frames (FB 0, LR 0) for 100 ms before leaving. Motion needs --yes in scripts.\n"
      "\nExamples:\n  saulctl pride vcu /dev/ttyUSB0 --speed-level 2               neutral, watch the controller\n"
      "  saulctl pride vcu /dev/ttyUSB0 --fb 20 --speed-level 2 --duration 2s --yes\n"
      "\nExit codes: 0 ok, 1 port error, 2 usage or not confirmed.\n");
}

}  // namespace saulctl
