// saulctl drive: stream 0x300 velocity commands at 20 Hz; always end with a zero-speed command.
#include <fmt/core.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/core/saul_can.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;

struct DriveOptions {
  std::string link;
  int speed = 0;
  int steer = 0;
  std::string duration;
  int speed_cap = 500;
  bool yes = false;
  bool json = false;
};

constexpr milliseconds kPeriod{50};  // 20 Hz, the rate the system reference gives for 0x300

int run_drive(const DriveOptions& opt) {
  if (std::abs(opt.speed) > opt.speed_cap)
    throw CLI::ValidationError("--speed", fmt::format("{} mm/s is above the cap of {} mm/s; raise it explicitly "
                                                      "with --speed-cap if the robot is tethered",
                                                      opt.speed, opt.speed_cap));
  const auto spec = resolve_link(opt.link);
  const bool limited = !opt.duration.empty();
  const milliseconds duration = limited ? parse_duration(opt.duration) : milliseconds(0);
  if (!confirm_motion(opt.yes, fmt::format("drive at {} mm/s, steer {} mrad on {}", opt.speed, opt.steer, spec.text())))
    return kUsage;
  auto link = saul::host::open_can_link(spec);

  const auto cmd = saul::saulcan::encode(
      saul::saulcan::VelocityCmd{static_cast<std::int16_t>(opt.speed), static_cast<std::int16_t>(opt.steer)});
  const auto stop = saul::saulcan::encode(saul::saulcan::VelocityCmd{0, 0});
  std::uint64_t sent = 0;
  std::optional<saul::saulcan::TelemetryA> last_a;
  int status = kOk;
  std::string why = "duration reached";
  const auto start = steady_clock::now();
  try {
    // Absolute deadlines (start + k * period): a late wake-up does not shift every later frame.
    for (std::int64_t k = 0;; ++k) {
      const auto due = start + k * kPeriod;
      if (limited && due - start >= duration) break;
      while (!g_interrupted) {
        const auto left = duration_cast<milliseconds>(due - steady_clock::now());
        if (left.count() <= 0) break;
        if (auto f = link->receive(left)) {
          if (auto a = saul::saulcan::decode_telemetry_a(*f)) last_a = *a;
        }
      }
      if (g_interrupted) {
        why = "interrupted";
        break;
      }
      link->send(cmd, kPeriod);
      ++sent;
      if (!opt.json && k % 20 == 0 && last_a)
        fmt::print(stderr, "drive: {} frames sent; robot {} pitch {:.2f} deg speed {} mm/s\n", sent,
                   saul::saulcan::to_string(last_a->state), last_a->pitch_x100 / 100.0, last_a->speed_mmps);
    }
  } catch (const std::exception& e) {
    say("{}", e.what());
    why = "error";
    status = kFailure;
  }
  bool stopped = false;
  try {
    link->send(stop, milliseconds(200));
    stopped = true;
  } catch (const std::exception& e) {
    say("could not send the zero-speed command: {}; the robot stops by its 500 ms Orin timeout", e.what());
    status = kFailure;
  }
  if (opt.json) {
    nlohmann::json j{{"command", "drive"},  {"link", link->name()}, {"frames_sent", sent},
                     {"speed_mmps", opt.speed}, {"steer_mrad", opt.steer}, {"ended", why}, {"zero_sent", stopped}};
    fmt::print("{}\n", j.dump());
  } else {
    fmt::print("drive: {} velocity frames at 20 Hz, then zero speed{} ({})\n", sent, stopped ? "" : " FAILED", why);
  }
  return status;
}

}  // namespace

void add_drive_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<DriveOptions>(
      app, run, "drive", "Stream velocity commands (0x300, 20 Hz); zero speed on exit", run_drive);
  add_link_option(cmd, o->link);
  cmd->add_option("--speed", o->speed, "mm/s, + forward")->required();
  cmd->add_option("--steer", o->steer, "mrad, + left")->capture_default_str();
  add_duration_option(cmd, o->duration, "how long; default: until Ctrl-C");
  cmd->add_option("--speed-cap", o->speed_cap, "refuse |speed| above this many mm/s")->capture_default_str();
  cmd->add_flag("-y,--yes", o->yes, "confirm without asking (scripts)");
  cmd->add_flag("--json", o->json, "one JSON summary at the end");
  cmd->footer(
      "\nThe motors can move: saulctl asks on a terminal and needs --yes in scripts. On Ctrl-C, at the end, or on a\n"
      "link error it sends speed 0 before leaving.\n"
      "\nExamples:\n  saulctl drive --link can0 --speed 200 --duration 3s\n"
      "  saulctl drive --link slcan:/dev/ttyACM0 --speed 0 --steer 300 --duration 1s --yes\n");
}

}  // namespace saulctl
