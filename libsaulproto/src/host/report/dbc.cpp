// The DBC of the robot's bus: messages, signals and value tables written out from the core's description
// (core/signals.hpp), so names and scales are decode's; only the comments and the choice of VESC frames are its own.
#include "saulproto/host/report/dbc.hpp"

#include <fmt/core.h>

#include <cmath>
#include <string_view>
#include <utility>
#include <vector>

#include "saulproto/core/saul_can.hpp"
#include "saulproto/core/signals.hpp"
#include "saulproto/core/vesc.hpp"
#include "saulproto/host/report/format.hpp"

namespace saul::host {
namespace {

using namespace saul::saulcan;

constexpr std::uint32_t kDbcExtended = 0x80000000U;  // DBC marks a 29-bit id with bit 31

/// A DBC signal: a described signal, or one bit of a byte of named bits (`bit`: unsigned, unscaled, no unit).
struct Signal {
  const signals::SignalDesc* desc = nullptr;
  bool bit = false;
  std::string name;
  unsigned start = 0;  ///< @1: the least significant bit; @0: the most significant bit (sawtooth numbering)
  unsigned length = 0;
  std::string unit;
  /// A scaled signal: factor scale_num / scale_den (for 1 / den: exact for the decimal scales).
  [[nodiscard]] bool scaled() const { return !bit && (desc->scale_num != 1 || desc->scale_den != 1); }
  [[nodiscard]] bool is_float() const { return desc->kind == signals::Kind::float32; }  ///< SIG_VALTYPE_ 1
};

struct Message {
  std::uint32_t dbc_id = 0;
  std::string name;
  unsigned dlc = 0;
  std::string sender;
  std::string receiver;
  std::vector<Signal> signals;
  std::string comment;
};

// Shortest decimal that reads back as the same double, never in exponent form (some DBC tools reject "1e-05").
std::string dbc_number(double v) {
  std::string s = fmt::format("{}", v);
  if (s.find('e') == std::string::npos) return s;
  s = fmt::format("{:.12f}", v);
  while (s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s;
}

// [min|max] is the range the signal's bits can carry, scaled (not the description's valid range: tools that
// check values against it would then refuse frames saulctl decodes).
std::string signal_line(const Signal& s, const std::string& receiver) {
  const signals::SignalDesc& d = *s.desc;
  const bool is_signed = !s.bit && d.kind == signals::Kind::signed_int;
  const std::int32_t num = s.bit ? 1 : d.scale_num;
  const std::int32_t den = s.bit ? 1 : d.scale_den;
  double lo = 0, hi = 0;
  if (!s.is_float()) {
    const double raw_lo = is_signed ? -std::ldexp(1.0, static_cast<int>(s.length) - 1) : 0.0;
    const double raw_hi = is_signed ? std::ldexp(1.0, static_cast<int>(s.length) - 1) - 1
                                    : std::ldexp(1.0, static_cast<int>(s.length)) - 1;
    lo = raw_lo * num / den + d.offset;
    hi = raw_hi * num / den + d.offset;
  }
  // "", "M" (the multiplexer) or "m<N>" (present when the multiplexer is N)
  const std::string mux = d.mux == signals::Mux::multiplexer   ? " M"
                          : d.mux == signals::Mux::multiplexed ? fmt::format(" m{}", d.mux_value)
                                                               : "";
  const double factor = num == 1 ? 1.0 / den : static_cast<double>(num) / den;
  return fmt::format(" SG_ {}{} : {}|{}@{}{} ({},{}) [{}|{}] \"{}\" {}\n", s.name, mux, s.start, s.length,
                     d.order == signals::ByteOrder::little_endian ? 1 : 0, is_signed || s.is_float() ? '-' : '+',
                     dbc_number(factor), dbc_number(d.offset), dbc_number(lo), dbc_number(hi), s.unit,
                     receiver.empty() ? "Vector__XXX" : receiver);
}

// The DBC's own choices where it departs from the description:
// - pid_out has no unit in the DBC (the description, the plot and docs/protocol.md say permille); kept so, since
//   files made by earlier versions are in use and tools key on the unit text.
std::string dbc_unit(const signals::MessageDesc& m, const signals::SignalDesc& s) {
  if (m.protocol == signals::Protocol::saul_can && std::string_view(s.name) == "pid_out") return "";
  return s.unit;
}

// The DBC signals of one described signal: itself; a byte of named bits one 1-bit signal per bit ("fault_rc_loss");
// a signal in the CAN id (the VESC controller) none, since every controller has its own messages here.
void add_signals(const signals::MessageDesc& m, const signals::SignalDesc& d, std::vector<Signal>& out) {
  if (d.place != signals::Place::payload) return;
  if (!d.value_bits) {
    out.push_back({&d, false, d.name, d.start_bit, d.length, dbc_unit(m, d)});
    return;
  }
  for (const auto& bit : d.values) {
    const unsigned start = d.start_bit + static_cast<unsigned>(bit.value);
    out.push_back({&d, true, fmt::format("{}_{}", d.name, bit.name), start, 1, ""});
  }
}

Message message_of(const signals::MessageDesc& m, std::uint32_t dbc_id, std::string name, std::string sender,
                   std::string receiver, std::string comment) {
  Message msg{dbc_id, std::move(name), m.length, std::move(sender), std::move(receiver), {}, std::move(comment)};
  for (const auto& d : m.signals) add_signals(m, d, msg.signals);
  return msg;
}

// Comments of the SAUL frames, by id.
std::string saul_comment(std::uint32_t id) {
  switch (id) {
    case kVelocityCmdId: return "Velocity command, 20 Hz; the BALANCE board stops driving after 500 ms without one.";
    case kPidGainId:
      return "One PID gain per frame. gain (byte 0) is the multiplexer; the gain is a float32 little-endian in "
             "bytes 4-7, declared as a multiplexed signal per index (kp m0, ki m1, kd m2) with SIG_VALTYPE_ 1. Bytes "
             "2-3 are reserved (0). The three gains of one sequence number are applied together (docs/protocol.md "
             "3).";
    case kModeCmdId: return "Mode request; balance and manual are accepted only when the robot is already armed.";
    case kConfigCmdId: return "Tilt limit (5.00 to 25.00 deg; its wire integer, 0.01 deg, is tilt_limit_raw in decode --json) and speed "
                              "cap.";
    case kTelemetryAId: return "Telemetry A, 10 Hz. pitch in 0.01 deg on the wire (pitch_raw in decode --json).";
    case kTelemetryBId:
      return "Telemetry B, 10 Hz: mechanical rpm of both wheels, battery (mV on the wire: battery_raw in decode --json), and the fault byte "
             "(byte 6) as one signal per bit.";
    case kCommandAckId:
      return "Acknowledgement of one 0x301 set, 0x302 or 0x303; sequence is the 0x301 set's, 0 otherwise.";
    default: return "";
  }
}

// The VESC frames the robot uses, per controller: SET_RPM (BALANCE drives the wheels with it) and the status
// frames, with their comments ("{}" is the controller id). The other commands, PING and PONG are left out.
struct VescEntry {
  vesc::Command command;
  const char* comment;
};
constexpr VescEntry kVescInDbc[] = {
    {vesc::Command::set_rpm, "SET_RPM to controller {}: electrical rpm (mechanical rpm x pole pairs)."},
    {vesc::Command::status_1, "STATUS from controller {}."},
    {vesc::Command::status_2, "STATUS_2 from controller {}."},
    {vesc::Command::status_3, "STATUS_3 from controller {}."},
    {vesc::Command::status_4, "STATUS_4 from controller {}."},
    {vesc::Command::status_5,
     "STATUS_5 from controller {}: tachometer counts 6 steps per electrical revolution; bytes 6-7 reserved."},
    {vesc::Command::status_6, "STATUS_6 from controller {}."},
};

std::vector<Message> vesc_messages(std::uint8_t c) {
  // The description's node "VESC" is the controller the id names: VESC_<id> here.
  const auto node = [c](const char* n) { return std::string_view(n) == "VESC" ? fmt::format("VESC_{}", c) : n; };
  std::vector<Message> out;
  for (const auto& e : kVescInDbc) {
    const auto* m = signals::find(signals::Protocol::vesc_can, static_cast<std::uint32_t>(e.command));
    out.push_back(message_of(*m, kDbcExtended | vesc::make_eid(e.command, c), fmt::format("{}_{}", m->name, c),
                             node(m->sender), node(m->receiver), fmt::format(fmt::runtime(e.comment), c)));
  }
  return out;
}

}  // namespace

std::string make_dbc() {
  constexpr std::uint8_t kVescControllers[] = {vesc::kLeftId, vesc::kRightId};
  std::vector<Message> messages;
  for (const auto& m : signals::messages(signals::Protocol::saul_can))
    messages.push_back(message_of(m, m.id, m.name, m.sender, m.receiver, saul_comment(m.id)));
  std::string nodes = "Orin BALANCE";
  for (const auto c : kVescControllers) {
    auto v = vesc_messages(c);
    messages.insert(messages.end(), v.begin(), v.end());
    nodes += fmt::format(" VESC_{}", c);
  }

  std::string out;
  out += "VERSION \"\"\n\n\n";
  out += "NS_ :\n\tNS_DESC_\n\tCM_\n\tBA_DEF_\n\tBA_\n\tVAL_\n\tBA_DEF_DEF_\n\tVAL_TABLE_\n\tSIG_VALTYPE_\n\n";
  out += "BS_:\n\n";
  out += "BU_: " + nodes + "\n\n";
  for (const auto& msg : messages) {
    out += fmt::format("BO_ {} {}: {} {}\n", msg.dbc_id, msg.name, msg.dlc, msg.sender);
    for (const auto& s : msg.signals) out += signal_line(s, msg.receiver);
    out += "\n";
  }

  out += "\nCM_ " + c_literal(
      "SAUL-TEE robot bus, 500 kbit/s (written by saulctl dbc; docs/protocol.md sections 3 and 6). SAUL frames: "
      "11-bit ids, little-endian. VESC frames: 29-bit ids (bit 31 set here, as DBC marks extended ids), "
      "big-endian, id = command << 8 | controller id. 0x301 is multiplexed by gain; each gain is a "
      "multiplexed float32 signal (SIG_VALTYPE_ 1).") + ";\n";
  out += "CM_ BU_ Orin \"The robot's host computer (Jetson Orin).\";\n";
  out += "CM_ BU_ BALANCE \"The BALANCE board (ESP32-S3): balance loop, drives the VESCs.\";\n";
  for (const auto c : kVescControllers)
    out += fmt::format("CM_ BU_ VESC_{} \"VESC motor controller id {}{}.\";\n", c, c,
                       c == vesc::kLeftId ? ", left hub motor" : c == vesc::kRightId ? ", right hub motor" : "");
  for (const auto& msg : messages)
    if (!msg.comment.empty()) out += fmt::format("CM_ BO_ {} {};\n", msg.dbc_id, c_literal(msg.comment));
  // Per signal: a scaled one whose wire integer saulctl's JSON keeps gets that integer's key as its comment; value
  // tables, the names saulctl decode prints (descending, as DBC editors write them); float32 signals' value type.
  std::string comments, tables, types;
  for (const auto& msg : messages)
    for (const auto& s : msg.signals) {
      if (s.scaled() && s.desc->text == signals::Text::raw)
        comments += fmt::format("CM_ SG_ {} {} {};\n", msg.dbc_id, s.name, c_literal(raw_key(*s.desc) + " on the wire"));
      if (!s.bit && !s.desc->values.empty()) {
        tables += fmt::format("VAL_ {} {}", msg.dbc_id, s.name);
        for (auto it = s.desc->values.rbegin(); it != s.desc->values.rend(); ++it)
          tables += fmt::format(" {} {}", it->value, c_literal(it->name));
        tables += " ;\n";
      }
      if (s.is_float()) types += fmt::format("SIG_VALTYPE_ {} {} : 1;\n", msg.dbc_id, s.name);
    }
  return out + comments + "\n" + tables + "\n" + types;
}

}  // namespace saul::host
