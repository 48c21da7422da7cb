// saulctl mode / estop / pid / config: one command frame (or set), then its 0x402 acknowledgement.
#include <fmt/core.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/host/robot/robot_client.hpp"

namespace saulctl {
namespace {

using saul::host::CommandOutcome;
using namespace std::chrono;

struct CommandOptions {
  std::string link;
  std::string timeout = "1s";
  bool json = false;
  bool yes = false;
  std::string mode;
  std::vector<double> gains;
  double tilt_limit = -1;
  int max_speed = -1;
};

std::string hint_for(saul::saulcan::AckResult r, std::uint8_t command) {
  using saul::saulcan::AckResult;
  switch (r) {
    case AckResult::applied: return "";
    case AckResult::out_of_range:
      return command == 0x01 ? "gains must be finite and not negative"
                             : "tilt limit must be 5..25 deg and max speed within the current cap";
    case AckResult::not_allowed: return "the robot must be armed first (3 s button hold while upright, or console 'arm')";
    case AckResult::incomplete: return "the three gains did not all arrive within 100 ms; check bus load and retry";
  }
  return "";
}

/// Says how `command` went; for a mode change that was applied, first waits for the 0x400 to show `expected`.
int report(const CommandOptions& opt, const std::string& what, saul::host::RobotClient& client,
           const saul::host::CanLink& link, const CommandOutcome& out, std::uint8_t command, milliseconds timeout,
           double written_ms = -1, std::optional<saul::saulcan::RobotState> expected = std::nullopt) {
  using saul::host::StateCheck;
  std::optional<StateCheck> state;
  if (expected && out.status == CommandOutcome::Status::applied) state = client.confirm_state(*expected);
  const double ms = static_cast<double>(out.latency.count()) / 1000.0;
  const bool differs = state && state->result == StateCheck::Result::differs;
  if (opt.json) {
    nlohmann::json j{{"command", what}, {"link", link.name()}};
    if (const auto how = link.sharing(); !how.empty()) j["shared"] = how;
    if (written_ms >= 0) j["written_ms"] = written_ms;
    j["status"] = saul::host::to_string(out.status);
    if (out.status != CommandOutcome::Status::no_answer) {
      j["result"] = saul::saulcan::to_string(out.result);
      j["latency_ms"] = ms;
    }
    if (state) {
      j["state"] = {{"expected", saul::saulcan::to_string(state->expected)},
                    {"seen", state->seen ? saul::saulcan::to_string(*state->seen) : nullptr},
                    {"result", state->result == StateCheck::Result::confirmed ? "confirmed"
                               : differs                                      ? "differs"
                                                                              : "no_telemetry"},
                    {"after_ms", static_cast<double>(state->after.count()) / 1000.0}};
      if (state->result != StateCheck::Result::confirmed) j["state"]["note"] = state->text();
    }
    fmt::print("{}\n", j.dump());
  } else if (out.status == CommandOutcome::Status::applied) {
    const bool confirmed = state && state->result == StateCheck::Result::confirmed;
    fmt::print("{}: applied ({:.1f} ms){}\n", what, ms, confirmed ? "; " + state->text() : "");
    if (state && !confirmed) say("{}: {}", what, state->text());
  } else if (out.status == CommandOutcome::Status::rejected) {
    say("{}: {} - {}", what, saul::saulcan::to_string(out.result), hint_for(out.result, command));
  } else {
    say("{}: no acknowledgement within {} ms on {} (is the BALANCE board powered and on the bus? "
        "'saulctl sniff' shows the traffic)",
        what, timeout.count(), link.name());
  }
  if (out.status == CommandOutcome::Status::applied) return differs ? kFailure : kOk;
  return out.status == CommandOutcome::Status::rejected ? kFailure : kTimeout;
}

int run_mode(const CommandOptions& opt) {
  static const std::map<std::string, saul::saulcan::Mode> kModes = {{"off", saul::saulcan::Mode::off},
                                                                     {"balance", saul::saulcan::Mode::balance},
                                                                     {"manual", saul::saulcan::Mode::manual},
                                                                     {"estop", saul::saulcan::Mode::estop}};
  const auto mode = kModes.at(opt.mode);
  const bool moves = mode == saul::saulcan::Mode::balance || mode == saul::saulcan::Mode::manual;
  const auto spec = resolve_link(opt.link);
  if (moves && !confirm_motion(opt.yes, "send mode " + opt.mode + " on " + spec.text())) return kUsage;
  const auto timeout = parse_duration(opt.timeout);
  auto link = saul::host::open_can_link(spec);
  saul::host::RobotClient client(*link);
  if (mode == saul::saulcan::Mode::estop) client.send_estop();
  const auto out = mode == saul::saulcan::Mode::estop
                       ? client.wait_for_ack(0x02, std::nullopt, steady_clock::now(), timeout)
                       : client.set_mode(mode, timeout);
  return report(opt, "mode " + opt.mode, client, *link, out, 0x02, timeout, -1, saul::host::state_for(mode));
}

int run_estop(const CommandOptions& opt) {
  // No confirmation, no delay: open (or join the saulctl that holds the adapter), send, then report whether
  // BALANCE acknowledged. The frame's way out is timed: command start -> the write to the adapter (measured by the
  // owner when the link is shared).
  const auto started = steady_clock::now();
  const auto timeout = parse_duration(opt.timeout);
  auto link = saul::host::open_can_link(resolve_link(opt.link));
  saul::host::RobotClient client(*link);
  const auto t0 = steady_clock::now();
  client.send_estop();
  const double open_ms = duration<double, std::milli>(t0 - started).count();
  const double send_ms = static_cast<double>(link->stats().last_send_ns) / 1e6;
  if (!opt.json) {
    const auto how = link->sharing();
    fmt::print(stderr, "estop: written to the adapter {:.2f} ms after the command started ({:.2f} ms opening, "
                       "{:.2f} ms sending{})\n",
               open_ms + send_ms, open_ms, send_ms, how.empty() ? "" : "; " + how);
  }
  const auto out = client.wait_for_ack(0x02, std::nullopt, t0, timeout);
  return report(opt, "estop", client, *link, out, 0x02, timeout, open_ms + send_ms, saul::saulcan::RobotState::estop);
}

int run_pid(const CommandOptions& opt) {
  for (double g : opt.gains)
    if (!std::isfinite(g) || g < 0) throw CLI::ValidationError("gains", "gains must be finite and not negative");
  const auto timeout = parse_duration(opt.timeout);
  auto link = saul::host::open_can_link(resolve_link(opt.link));
  saul::host::RobotClient client(*link);
  const auto out = client.set_pid(static_cast<float>(opt.gains[0]), static_cast<float>(opt.gains[1]),
                                  static_cast<float>(opt.gains[2]), timeout);
  return report(opt, fmt::format("pid kp={:g} ki={:g} kd={:g} (set {})", opt.gains[0], opt.gains[1], opt.gains[2],
                                 client.last_sequence()),
                client, *link, out, 0x01, timeout);
}

int run_config(const CommandOptions& opt) {
  if (opt.tilt_limit < 5.0 || opt.tilt_limit > 25.0)
    throw CLI::ValidationError("--tilt-limit", "tilt limit must be 5..25 degrees");
  const auto timeout = parse_duration(opt.timeout);
  auto link = saul::host::open_can_link(resolve_link(opt.link));
  saul::host::RobotClient client(*link);
  const auto tilt = static_cast<std::uint16_t>(std::lround(opt.tilt_limit * 100));
  const auto out = client.set_config(tilt, static_cast<std::uint16_t>(opt.max_speed), timeout);
  return report(opt, fmt::format("config tilt_limit={:.2f} max_speed={}", opt.tilt_limit, opt.max_speed), client,
                *link, out, 0x03, timeout);
}

void common(CLI::App* cmd, CommandOptions& o) {
  add_link_option(cmd, o.link);
  cmd->add_option("--timeout", o.timeout, "how long to wait for the 0x402 acknowledgement")->capture_default_str()->check(duration_check());
  cmd->add_flag("--json", o.json, "one JSON object with the outcome");
}

}  // namespace

void add_command_commands(CLI::App& app, Runner& run) {
  const char* exits =
      "\nExit codes: 0 applied, 1 rejected or error (or, for mode and estop, acknowledged but the robot's 0x400 shows\n"
      "another state), 2 usage or not confirmed, 3 no acknowledgement.\n";
  {
    auto [cmd, o] = add_verb<CommandOptions>(
        app, run, "mode", "Set the robot's mode (0x302) and wait for its acknowledgement", run_mode);
    cmd->add_option("mode", o->mode, "off | balance | manual | estop")
        ->required()
        ->check(CLI::IsMember({"off", "balance", "manual", "estop"}));
    cmd->add_flag("-y,--yes", o->yes, "confirm a mode that can move the motors (balance, manual) without asking");
    common(cmd, *o);
    cmd->footer(std::string("\nbalance and manual can move the motors: saulctl asks on a terminal and needs --yes in "
                            "scripts. They are only accepted when the robot is already armed.\n"
                            "\nExamples:\n  saulctl mode off --link can0\n"
                            "  saulctl mode balance --yes --link slcan:/dev/ttyACM0\n") + exits);
  }
  {
    auto [cmd, o] = add_verb<CommandOptions>(
        app, run, "estop", "Emergency stop: send mode 3 at once, no questions", run_estop);
    common(cmd, *o);
    cmd->footer(std::string("\nSent immediately, never asks. Leaving ESTOP needs disarm and a fresh arming.\n") + exits);
  }
  {
    auto [cmd, o] = add_verb<CommandOptions>(
        app, run, "pid", "Send a PID gain set (three 0x301 frames) and wait for 0x402", run_pid);
    cmd->add_option("gains", o->gains, "KP KI KD")->required()->expected(3);
    common(cmd, *o);
    cmd->footer(std::string("\nThe robot applies all three gains together or none (within 100 ms).\n"
                            "\nExample:\n  saulctl pid 1.5 0.25 0.05 --link can0\n") + exits);
  }
  {
    auto [cmd, o] = add_verb<CommandOptions>(
        app, run, "config", "Send tilt limit and max speed (0x303) and wait for 0x402", run_config);
    cmd->add_option("--tilt-limit", o->tilt_limit, "tilt cutoff in degrees, 5..25")->required();
    cmd->add_option("--max-speed", o->max_speed, "speed limit in mm/s (cannot raise the speed cap)")
        ->required()
        ->check(CLI::Range(0, 65535));
    common(cmd, *o);
    cmd->footer(std::string("\nExample:\n  saulctl config --tilt-limit 20 --max-speed 800 --link can0\n") + exits);
  }
}

}  // namespace saulctl
