#include "saulproto/host/robot/robot_client.hpp"

#include <fmt/format.h>

#include "saulproto/core/dispatch.hpp"

namespace saul::host {

using namespace std::chrono;

const char* to_string(CommandOutcome::Status s) {
  constexpr const char* kNames[] = {"applied", "rejected", "no_answer"};  // in the enum's order
  return kNames[static_cast<std::size_t>(s)];
}

void RobotClient::send_estop() { link_.send(saulcan::encode(saulcan::ModeCmd{saulcan::Mode::estop}), milliseconds(100)); }

namespace {

// Hands every frame received before `deadline` to the observer, then to `done`, until `done` says true.
template <class Done>
void watch(CanLink& link, const RobotClient::Observer& observer, steady_clock::time_point deadline, Done&& done) {
  for (;;) {
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() < 0) return;
    const auto frame = link.receive(left);
    if (!frame) continue;
    if (observer) observer(*frame);
    if (done(*frame)) return;
  }
}

}  // namespace

CommandOutcome RobotClient::wait_for_ack(std::uint8_t command, std::optional<std::uint8_t> sequence,
                                         steady_clock::time_point sent_at, milliseconds timeout) {
  CommandOutcome out;
  watch(link_, observer_, sent_at + timeout, [&](const CanFrame& frame) {
    const auto ack = saulcan::decode_command_ack(frame);
    if (!ack || ack->command != command || (sequence && ack->sequence != *sequence)) return false;
    out.result = ack->result;
    out.status = ack->result == saulcan::AckResult::applied ? CommandOutcome::Status::applied
                                                           : CommandOutcome::Status::rejected;
    out.latency = duration_cast<microseconds>(steady_clock::now() - sent_at);
    return true;
  });
  return out;
}

saulcan::RobotState state_for(saulcan::Mode mode) { return static_cast<saulcan::RobotState>(mode); }

namespace {

const char* way_out(saulcan::RobotState expected, saulcan::RobotState seen) {
  using S = saulcan::RobotState;
  switch (seen) {
    case S::tilt_cutoff: return "it tilted past its limit: stand it upright, disarm, then arm again (3 s button hold)";
    case S::fault: return "a fault is latched: 'saulctl monitor' shows which; clear it, disarm, then arm again";
    case S::estop: return "ESTOP is latched: leaving it needs disarm and a fresh arming";
    case S::off:
      return expected == S::balance || expected == S::manual
                 ? "it fell back to OFF: is it still armed (RC ARM switch up, IO board powered)?"
                 : "";
    default: return "watch it with 'saulctl monitor'";
  }
}

}  // namespace

std::string StateCheck::text() const {
  using R = Result;
  const double ms = static_cast<double>(after.count()) / 1000.0;
  switch (result) {
    case R::confirmed: return fmt::format("robot state {} ({:.0f} ms later in 0x400)", saulcan::to_string(expected), ms);
    case R::differs:
      return fmt::format("acknowledged, but the robot reports {} instead of {}: {}", saulcan::to_string(*seen),
                         saulcan::to_string(expected), way_out(expected, *seen));
    case R::no_telemetry:
      return fmt::format("no 0x400 telemetry within {} ms to show the state (is BALANCE sending? 'saulctl sniff' "
                         "shows the bus)",
                         RobotClient::kStateConfirmTime.count());
  }
  return "";
}

StateCheck RobotClient::confirm_state(saulcan::RobotState expected, milliseconds timeout) {
  StateCheck out;
  out.expected = expected;
  const auto start = steady_clock::now();
  watch(link_, observer_, start + timeout, [&](const CanFrame& frame) {
    const auto a = saulcan::decode_telemetry_a(frame);
    if (!a) return false;
    out.seen = a->state;
    out.after = duration_cast<microseconds>(steady_clock::now() - start);
    return a->state == expected;
  });
  if (out.seen) out.result = out.seen == expected ? StateCheck::Result::confirmed : StateCheck::Result::differs;
  return out;
}

CommandOutcome RobotClient::set_mode(saulcan::Mode mode, milliseconds timeout) {
  const auto t0 = steady_clock::now();
  link_.send(saulcan::encode(saulcan::ModeCmd{mode}), timeout);
  return wait_for_ack(0x02, std::nullopt, t0, timeout);
}

CommandOutcome RobotClient::set_pid(float kp, float ki, float kd, milliseconds timeout) {
  const std::uint8_t seq = ++sequence_;
  const auto t0 = steady_clock::now();
  link_.send(saulcan::encode(saulcan::PidGain{saulcan::Gain::kp, seq, kp}), timeout);
  link_.send(saulcan::encode(saulcan::PidGain{saulcan::Gain::ki, seq, ki}), timeout);
  link_.send(saulcan::encode(saulcan::PidGain{saulcan::Gain::kd, seq, kd}), timeout);
  return wait_for_ack(0x01, seq, t0, timeout);
}

CommandOutcome RobotClient::set_config(std::uint16_t tilt_limit_x100, std::uint16_t max_speed_mmps,
                                       milliseconds timeout) {
  const auto t0 = steady_clock::now();
  link_.send(saulcan::encode(saulcan::ConfigCmd{tilt_limit_x100, max_speed_mmps}), timeout);
  return wait_for_ack(0x03, std::nullopt, t0, timeout);
}

}  // namespace saul::host
