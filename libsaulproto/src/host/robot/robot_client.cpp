#include "saulproto/host/robot/robot_client.hpp"

#include "saulproto/core/dispatch.hpp"

namespace saul::host {

using namespace std::chrono;

const char* to_string(CommandOutcome::Status s) {
  switch (s) {
    case CommandOutcome::Status::applied: return "applied";
    case CommandOutcome::Status::rejected: return "rejected";
    case CommandOutcome::Status::no_answer: return "no_answer";
  }
  return "?";
}

void RobotClient::send_estop() { link_.send(saulcan::encode(saulcan::ModeCmd{saulcan::Mode::estop}), milliseconds(100)); }

CommandOutcome RobotClient::wait_for_ack(std::uint8_t command, std::optional<std::uint8_t> sequence,
                                         steady_clock::time_point sent_at, milliseconds timeout) {
  const auto deadline = sent_at + timeout;
  CommandOutcome out;
  for (;;) {
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() < 0) return out;
    const auto frame = link_.receive(left);
    if (!frame) continue;
    if (observer_) observer_(*frame);
    const auto ack = saulcan::decode_command_ack(*frame);
    if (!ack || ack->command != command) continue;
    if (sequence && ack->sequence != *sequence) continue;
    out.result = ack->result;
    out.status = ack->result == saulcan::AckResult::applied ? CommandOutcome::Status::applied
                                                           : CommandOutcome::Status::rejected;
    out.latency = duration_cast<microseconds>(steady_clock::now() - sent_at);
    return out;
  }
}

CommandOutcome RobotClient::set_mode(saulcan::Mode mode, milliseconds timeout) {
  const auto t0 = steady_clock::now();
  link_.send(saulcan::encode(saulcan::ModeCmd{mode}), timeout);
  return wait_for_ack(0x02, std::nullopt, t0, timeout);
}

CommandOutcome RobotClient::set_pid(float kp, float ki, float kd, milliseconds timeout) {
  if (!sequence_seeded_) {
    // A fresh start value per run: the receiver treats a repeated sequence number as the same set.
    sequence_ = static_cast<std::uint8_t>(duration_cast<milliseconds>(system_clock::now().time_since_epoch()).count());
    sequence_seeded_ = true;
  }
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
