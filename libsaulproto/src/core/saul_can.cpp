#include "saulproto/core/saul_can.hpp"

#include "saulproto/core/bytes.hpp"
#include "saulproto/core/signals_saul.hpp"

namespace saul::saulcan {
namespace {

CanFrame make(std::uint32_t id, std::uint8_t dlc) noexcept {
  CanFrame f;
  f.id = id;
  f.dlc = dlc;
  return f;
}

// The shape checks every SAUL decoder shares. Returns ok when the payload may be read.
Reason check_shape(const CanFrame& f, std::uint32_t id, std::uint8_t dlc) noexcept {
  if (f.id != id || f.error) return f.error ? Reason::error_frame : Reason::unknown_id;
  if (f.remote) return Reason::remote_frame;
  if (f.extended) return Reason::extended_id;
  if (f.dlc != dlc) return Reason::wrong_dlc;
  return Reason::ok;
}

// The names of values live in the signal tables (signals_saul.hpp), which decode, the DBC and the dissector print.
const char* name_in(std::span<const signals::ValueName> names, std::int64_t value) noexcept {
  for (const auto& v : names)
    if (v.value == value) return v.name;
  return "?";
}

}  // namespace

namespace fault {
const char* bit_name(unsigned bit) noexcept { return name_in(signals::of_saul::kFaultBitNames, bit); }
}  // namespace fault

const char* to_string(Mode mode) noexcept { return name_in(signals::of_saul::kModeNames, static_cast<int>(mode)); }
const char* to_string(RobotState state) noexcept {
  return name_in(signals::of_saul::kRobotStateNames, static_cast<int>(state));
}
const char* to_string(AckResult result) noexcept {
  return name_in(signals::of_saul::kAckResultNames, static_cast<int>(result));
}
const char* to_string(Gain gain) noexcept { return name_in(signals::of_saul::kGainNames, static_cast<int>(gain)); }

CanFrame encode(const VelocityCmd& m) noexcept {
  CanFrame f = make(VelocityCmd::kId, VelocityCmd::kDlc);
  bytes::put_i16le(&f.data[0], m.speed_mmps);
  bytes::put_i16le(&f.data[2], m.steer_mrad);
  return f;
}

CanFrame encode(const PidGain& m) noexcept {
  CanFrame f = make(PidGain::kId, PidGain::kDlc);
  f.data[0] = static_cast<std::uint8_t>(m.index);
  f.data[1] = m.sequence;
  bytes::put_f32le(&f.data[4], m.value);
  return f;
}

CanFrame encode(const ModeCmd& m) noexcept {
  CanFrame f = make(ModeCmd::kId, ModeCmd::kDlc);
  f.data[0] = static_cast<std::uint8_t>(m.mode);
  return f;
}

CanFrame encode(const ConfigCmd& m) noexcept {
  CanFrame f = make(ConfigCmd::kId, ConfigCmd::kDlc);
  bytes::put_u16le(&f.data[0], m.tilt_limit_x100);
  bytes::put_u16le(&f.data[2], m.max_speed_mmps);
  return f;
}

CanFrame encode(const TelemetryA& m) noexcept {
  CanFrame f = make(TelemetryA::kId, TelemetryA::kDlc);
  bytes::put_i16le(&f.data[0], m.pitch_x100);
  bytes::put_i16le(&f.data[2], m.pid_out);
  bytes::put_i16le(&f.data[4], m.speed_mmps);
  f.data[6] = static_cast<std::uint8_t>(m.state);
  return f;
}

CanFrame encode(const TelemetryB& m) noexcept {
  CanFrame f = make(TelemetryB::kId, TelemetryB::kDlc);
  bytes::put_i16le(&f.data[0], m.vesc_l_rpm);
  bytes::put_i16le(&f.data[2], m.vesc_r_rpm);
  bytes::put_u16le(&f.data[4], m.battery_mv);
  f.data[6] = m.faults;
  return f;
}

CanFrame encode(const CommandAck& m) noexcept {
  CanFrame f = make(CommandAck::kId, CommandAck::kDlc);
  f.data[0] = m.command;
  f.data[1] = m.sequence;
  f.data[2] = static_cast<std::uint8_t>(m.result);
  return f;
}

CanFrame encode(const Message& m) noexcept {
  return std::visit([](const auto& msg) { return encode(msg); }, m);
}

Result<VelocityCmd> decode_velocity_cmd(const CanFrame& f) noexcept {
  if (auto r = check_shape(f, VelocityCmd::kId, VelocityCmd::kDlc); r != Reason::ok) return r;
  return VelocityCmd{bytes::get_i16le(&f.data[0]), bytes::get_i16le(&f.data[2])};
}

Result<PidGain> decode_pid_gain(const CanFrame& f) noexcept {
  if (auto r = check_shape(f, PidGain::kId, PidGain::kDlc); r != Reason::ok) return r;
  // Bytes 2..3 are reserved (sent as 0) and ignored on receipt, so a later sender may use them.
  if (f.data[0] > static_cast<std::uint8_t>(Gain::kd)) return Reason::out_of_range;
  // The float is passed on as sent, NaN included: the stager decides, so it can acknowledge the whole set.
  return PidGain{static_cast<Gain>(f.data[0]), f.data[1], bytes::get_f32le(&f.data[4])};
}

Result<ModeCmd> decode_mode_cmd(const CanFrame& f) noexcept {
  if (auto r = check_shape(f, ModeCmd::kId, ModeCmd::kDlc); r != Reason::ok) return r;
  if (f.data[0] > static_cast<std::uint8_t>(Mode::estop)) return Reason::out_of_range;
  return ModeCmd{static_cast<Mode>(f.data[0])};
}

Result<ConfigCmd> decode_config_cmd(const CanFrame& f) noexcept {
  if (auto r = check_shape(f, ConfigCmd::kId, ConfigCmd::kDlc); r != Reason::ok) return r;
  // Range policy (5..25 degrees, speed cap) belongs to the receiver, which acknowledges with a result;
  // the decoder only reports what was sent.
  return ConfigCmd{bytes::get_u16le(&f.data[0]), bytes::get_u16le(&f.data[2])};
}

Result<TelemetryA> decode_telemetry_a(const CanFrame& f) noexcept {
  if (auto r = check_shape(f, TelemetryA::kId, TelemetryA::kDlc); r != Reason::ok) return r;
  if (f.data[6] > static_cast<std::uint8_t>(RobotState::fault)) return Reason::out_of_range;
  return TelemetryA{bytes::get_i16le(&f.data[0]), bytes::get_i16le(&f.data[2]), bytes::get_i16le(&f.data[4]),
                    static_cast<RobotState>(f.data[6])};
}

Result<TelemetryB> decode_telemetry_b(const CanFrame& f) noexcept {
  if (auto r = check_shape(f, TelemetryB::kId, TelemetryB::kDlc); r != Reason::ok) return r;
  return TelemetryB{bytes::get_i16le(&f.data[0]), bytes::get_i16le(&f.data[2]), bytes::get_u16le(&f.data[4]),
                    f.data[6]};
}

Result<CommandAck> decode_command_ack(const CanFrame& f) noexcept {
  if (auto r = check_shape(f, CommandAck::kId, CommandAck::kDlc); r != Reason::ok) return r;
  if (f.data[0] < 0x01 || f.data[0] > 0x03) return Reason::out_of_range;
  if (f.data[2] > static_cast<std::uint8_t>(AckResult::incomplete)) return Reason::out_of_range;
  return CommandAck{f.data[0], f.data[1], static_cast<AckResult>(f.data[2])};
}

Result<Message> decode(const CanFrame& f) noexcept { return decode_as<Message>(f); }
// Flattened: each decoder inlined here. Called, a decoder returns its message through memory, and reading its
// reason back right after stalled on the store (stats of random payloads: 7-10 % of its CPU).
[[gnu::flatten]] Result<DecodedName> decode_name(const CanFrame& f) noexcept { return decode_as<DecodedName>(f); }

}  // namespace saul::saulcan
