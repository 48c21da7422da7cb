// saulctl monitor: the robot's telemetry at a glance, redrawn in place (or one JSON line per update).
#include <fmt/core.h>
#include <unistd.h>

#include <deque>
#include <map>
#include <memory>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/link/socketcan.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;
namespace sc = saul::saulcan;

struct MonitorOptions {
  std::string link;
  std::string duration;
  bool json = false;
  bool listen_only = false;
};

// Frames per second per id over the last second: timestamps of recent frames.
class RateMeter {
 public:
  void add(std::uint32_t key, steady_clock::time_point t) { seen_[key].push_back(t); }
  double rate(std::uint32_t key, steady_clock::time_point now) {
    auto& q = seen_[key];
    while (!q.empty() && now - q.front() > seconds(1)) q.pop_front();
    return static_cast<double>(q.size());
  }

 private:
  std::map<std::uint32_t, std::deque<steady_clock::time_point>> seen_;
};

std::string fault_names(std::uint8_t faults) {
  if (faults == 0) return "none";
  std::string s;
  for (unsigned b = 0; b < 8; ++b)
    if (faults & (1U << b)) s += (s.empty() ? "" : ",") + std::string(sc::fault::bit_name(b));
  return s;
}

std::string age(std::optional<steady_clock::time_point> t, steady_clock::time_point now) {
  if (!t) return "never";
  return fmt::format("{:.0f} ms ago", duration<double, std::milli>(now - *t).count());
}

int run_monitor(const MonitorOptions& opt) {
  const auto spec = resolve_link(opt.link);
  auto link = saul::host::open_can_link(spec, opt.listen_only);
  const bool limited = !opt.duration.empty();
  const milliseconds limit = limited ? parse_duration(opt.duration) : milliseconds(0);
  const bool tty = ::isatty(STDOUT_FILENO) && !opt.json;
  std::optional<sc::TelemetryA> a;
  std::optional<sc::TelemetryB> b;
  std::optional<steady_clock::time_point> a_at, b_at, vel_at;
  std::optional<sc::VelocityCmd> vel;
  std::string last_error;
  RateMeter rates;
  const auto start = steady_clock::now();
  auto next_draw = start;
  int status = kOk;
  try {
    while (!g_interrupted) {
      const auto now = steady_clock::now();
      if (limited && now - start >= limit) break;
      const auto f = link->receive(milliseconds(50));
      const auto t = steady_clock::now();
      bool updated = false;
      if (f) {
        rates.add(f->error ? 0xFFFFFFFF : f->id, t);
        if (f->error) last_error = saul::host::describe_error_frame(*f);
        if (auto m = sc::decode_telemetry_a(*f)) { a = *m; a_at = t; updated = true; }
        if (auto m = sc::decode_telemetry_b(*f)) { b = *m; b_at = t; updated = true; }
        if (auto m = sc::decode_velocity_cmd(*f)) { vel = *m; vel_at = t; }
      }
      if (opt.json) {
        if (updated && a && b) {
          nlohmann::json j{{"state", sc::to_string(a->state)},
                           {"pitch_deg", a->pitch_x100 / 100.0},
                           {"pid_out", a->pid_out},
                           {"speed_mmps", a->speed_mmps},
                           {"vesc_l_rpm", b->vesc_l_rpm},
                           {"vesc_r_rpm", b->vesc_r_rpm},
                           {"battery_v", b->battery_mv / 1000.0},
                           {"faults", fault_names(b->faults)},
                           {"rate_400_hz", rates.rate(0x400, t)},
                           {"rate_401_hz", rates.rate(0x401, t)}};
          fmt::print("{}\n", j.dump());
          std::fflush(stdout);
        }
        continue;
      }
      if (t < next_draw) continue;
      next_draw = t + milliseconds(200);
      const auto s = link->stats();
      std::string screen;
      screen += fmt::format("SAUL-TEE on {}   bus {}   rx {} tx {} dropped {} error frames {}\n", link->name(),
                            saul::host::to_string(s.state), s.rx_frames, s.tx_frames, s.rx_dropped, s.error_frames);
      if (a) {
        screen += fmt::format("state  {:<12} pitch {:+7.2f} deg   pid_out {:+5}   speed {:+6} mm/s   ({}, {:.0f} Hz)\n",
                              sc::to_string(a->state), a->pitch_x100 / 100.0, a->pid_out, a->speed_mmps, age(a_at, t),
                              rates.rate(0x400, t));
      } else {
        screen += "state  no telemetry A (0x400) yet\n";
      }
      if (b) {
        screen += fmt::format("wheels L {:+6} R {:+6} rpm   battery {:5.2f} V   faults {}   ({}, {:.0f} Hz)\n",
                              b->vesc_l_rpm, b->vesc_r_rpm, b->battery_mv / 1000.0, fault_names(b->faults),
                              age(b_at, t), rates.rate(0x401, t));
      } else {
        screen += "wheels no telemetry B (0x401) yet\n";
      }
      screen += fmt::format("orin   velocity cmd {} ({:.0f} Hz, {})\n",
                            vel ? fmt::format("{} mm/s {} mrad", vel->speed_mmps, vel->steer_mrad) : std::string("-"),
                            rates.rate(0x300, t), age(vel_at, t));
      if (!last_error.empty()) screen += "last bus error: " + last_error + "\n";
      if (tty) {
        fmt::print("\x1b[H\x1b[2J{}", screen);
      } else {
        fmt::print("{}\n", screen);
      }
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    status = report_link_error(e);
  }
  return status;
}

}  // namespace

void add_monitor_command(CLI::App& app, Runner& run) {
  auto o = std::make_shared<MonitorOptions>();
  auto* cmd = app.add_subcommand("monitor", "Live telemetry view: state, pitch, speeds, battery, faults, rates");
  add_link_option(cmd, o->link);
  cmd->add_option("--duration", o->duration, "stop after this long (default: until Ctrl-C)");
  cmd->add_flag("--json", o->json, "one JSON line per telemetry update instead of the screen");
  cmd->add_flag("--listen-only", o->listen_only, "slcan: open the adapter silent");
  cmd->footer("\nExamples:\n  saulctl monitor --link can0\n  saulctl monitor --json --duration 10s --link slcan:/dev/ttyACM0 > run.jsonl\n");
  cmd->callback([o, &run] {
    run = [o]() -> int {
      install_signal_handlers();
      try {
        return run_monitor(*o);
      } catch (const CLI::ValidationError& e) {
        fmt::print(stderr, "saulctl: {}\n", e.what());
        return kUsage;
      } catch (const std::exception& e) {
        return report_link_error(e);
      }
    };
  });
}

}  // namespace saulctl
