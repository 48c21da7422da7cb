// The DBC of the robot's bus (saulproto/host/report/dbc.hpp). Ids, names and value tables come from the core headers, so
// the file names things exactly as saulctl decode does.
#include "saulproto/host/report/dbc.hpp"

#include <fmt/core.h>

#include <cmath>
#include <utility>

#include "saulproto/core/saul_can.hpp"
#include "saulproto/core/vesc.hpp"

namespace saul::host {
namespace {

using namespace saul::saulcan;

constexpr std::uint32_t kDbcExtended = 0x80000000U;  // DBC marks a 29-bit id with bit 31

struct Signal {
  std::string name;
  std::string mux;          ///< "", "M" (the multiplexer) or "m<N>" (present when the multiplexer is N)
  unsigned start = 0;       ///< @1: the least significant bit; @0: the most significant bit (sawtooth numbering)
  unsigned length = 0;
  bool little_endian = true;
  bool is_signed = false;
  double divisor = 1;       ///< physical = raw / divisor (written as factor 1/divisor, exact for the decimal scales)
  std::string unit;
  std::string receiver;
  bool is_float = false;    ///< IEEE float32 (SIG_VALTYPE_ 1)
};

struct Message {
  std::uint32_t dbc_id = 0;
  std::string name;
  unsigned dlc = 0;
  std::string sender;
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

std::string signal_line(const Signal& s) {
  double lo = 0, hi = 0;
  if (!s.is_float) {
    const double raw_lo = s.is_signed ? -std::ldexp(1.0, static_cast<int>(s.length) - 1) : 0.0;
    const double raw_hi = s.is_signed ? std::ldexp(1.0, static_cast<int>(s.length) - 1) - 1
                                      : std::ldexp(1.0, static_cast<int>(s.length)) - 1;
    lo = raw_lo / s.divisor;
    hi = raw_hi / s.divisor;
  }
  return fmt::format(" SG_ {}{} : {}|{}@{}{} ({},0) [{}|{}] \"{}\" {}\n", s.name, s.mux.empty() ? "" : " " + s.mux,
                     s.start, s.length, s.little_endian ? 1 : 0, s.is_signed || s.is_float ? '-' : '+',
                     dbc_number(1.0 / s.divisor), dbc_number(lo), dbc_number(hi), s.unit,
                     s.receiver.empty() ? "Vector__XXX" : s.receiver);
}

// Little-endian integer field of a SAUL frame at byte `byte`.
Signal le(std::string name, unsigned byte, unsigned bits, bool is_signed, double divisor = 1, std::string unit = "",
          std::string receiver = "") {
  Signal s;
  s.name = std::move(name);
  s.start = byte * 8;
  s.length = bits;
  s.is_signed = is_signed;
  s.divisor = divisor;
  s.unit = std::move(unit);
  s.receiver = std::move(receiver);
  return s;
}

// Big-endian (Motorola) signed field of a VESC frame starting at byte `byte`: its MSB is bit 7 of that byte.
Signal be(std::string name, unsigned byte, unsigned bits, double divisor, std::string unit, std::string receiver) {
  Signal s = le(std::move(name), byte, bits, true, divisor, std::move(unit), std::move(receiver));
  s.start = byte * 8 + 7;
  s.little_endian = false;
  return s;
}

std::vector<Message> saul_messages() {
  const std::string orin = "Orin", balance = "BALANCE";
  std::vector<Message> m;
  m.push_back({kVelocityCmdId, "velocity_cmd", 4, orin,
               {le("speed_mmps", 0, 16, true, 1, "mm/s", balance), le("steer_mrad", 2, 16, true, 1, "mrad", balance)},
               "Velocity command, 20 Hz; the BALANCE board stops driving after 500 ms without one."});
  Message gain{kPidGainId, "pid_gain", 8, orin, {}, ""};
  Signal index = le("gain_index", 0, 8, false, 1, "", balance);
  index.mux = "M";
  gain.signals.push_back(index);
  gain.signals.push_back(le("sequence", 1, 8, false, 1, "", balance));
  for (unsigned i = 0; i < 3; ++i) {
    Signal g = le(to_string(static_cast<Gain>(i)), 4, 32, false, 1, "", balance);
    g.mux = fmt::format("m{}", i);
    g.is_float = true;
    gain.signals.push_back(g);
  }
  gain.comment =
      "One PID gain per frame. gain_index (byte 0) is the multiplexer; the gain is a float32 little-endian in bytes "
      "4-7, declared as a multiplexed signal per index (kp m0, ki m1, kd m2) with SIG_VALTYPE_ 1. Bytes 2-3 are "
      "reserved (0). The three gains of one sequence number are applied together (docs/protocol.md 3).";
  m.push_back(gain);
  m.push_back({kModeCmdId, "mode_cmd", 1, orin, {le("mode", 0, 8, false, 1, "", balance)},
               "Mode request; balance and manual are accepted only when the robot is already armed."});
  m.push_back({kConfigCmdId, "config_cmd", 4, orin,
               {le("tilt_limit", 0, 16, false, 100, "deg", balance),
                le("max_speed_mmps", 2, 16, false, 1, "mm/s", balance)},
               "Tilt limit (tilt_limit_x100 on the wire, 5.00 to 25.00 deg) and speed cap."});
  m.push_back({kTelemetryAId, "telemetry_a", 7, balance,
               {le("pitch", 0, 16, true, 100, "deg", orin), le("pid_out", 2, 16, true, 1, "", orin),
                le("speed_mmps", 4, 16, true, 1, "mm/s", orin), le("state", 6, 8, false, 1, "", orin)},
               "Telemetry A, 10 Hz. pitch is pitch_x100 on the wire."});
  Message b{kTelemetryBId, "telemetry_b", 7, balance,
            {le("vesc_l_rpm", 0, 16, true, 1, "rpm", orin), le("vesc_r_rpm", 2, 16, true, 1, "rpm", orin),
             le("battery", 4, 16, false, 1000, "V", orin)},
            "Telemetry B, 10 Hz: mechanical rpm of both wheels, battery (battery_mv on the wire), and the fault "
            "byte (byte 6) as one signal per bit."};
  for (unsigned bit = 0; bit < 8; ++bit) {
    Signal f = le(std::string("fault_") + fault::bit_name(bit), 6, 1, false, 1, "", orin);
    f.start = 48 + bit;
    b.signals.push_back(f);
  }
  m.push_back(b);
  m.push_back({kCommandAckId, "command_ack", 3, balance,
               {le("command", 0, 8, false, 1, "", orin), le("sequence", 1, 8, false, 1, "", orin),
                le("result", 2, 8, false, 1, "", orin)},
               "Acknowledgement of one 0x301 set, 0x302 or 0x303; sequence is the 0x301 set's, 0 otherwise."});
  return m;
}

std::vector<Message> vesc_messages(std::uint8_t c) {
  using vesc::Command;
  const std::string me = fmt::format("VESC_{}", c);
  const std::string balance = "BALANCE";
  auto id = [c](Command cmd) { return kDbcExtended | vesc::make_eid(cmd, c); };
  auto name = [c](const char* what) { return fmt::format("vesc_{}_{}", what, c); };
  std::vector<Message> m;
  m.push_back({id(Command::set_rpm), name("set_rpm"), 4, balance, {be("erpm", 0, 32, 1, "rpm", me)},
               fmt::format("SET_RPM to controller {}: electrical rpm (mechanical rpm x pole pairs).", c)});
  m.push_back({id(Command::status_1), name("status_1"), 8, me,
               {be("erpm", 0, 32, 1, "rpm", balance), be("current", 4, 16, 10, "A", balance),
                be("duty", 6, 16, 1000, "", balance)},
               fmt::format("STATUS from controller {}.", c)});
  m.push_back({id(Command::status_2), name("status_2"), 8, me,
               {be("amp_hours", 0, 32, 10000, "Ah", balance), be("amp_hours_charged", 4, 32, 10000, "Ah", balance)},
               fmt::format("STATUS_2 from controller {}.", c)});
  m.push_back({id(Command::status_3), name("status_3"), 8, me,
               {be("watt_hours", 0, 32, 10000, "Wh", balance),
                be("watt_hours_charged", 4, 32, 10000, "Wh", balance)},
               fmt::format("STATUS_3 from controller {}.", c)});
  m.push_back({id(Command::status_4), name("status_4"), 8, me,
               {be("temp_fet", 0, 16, 10, "degC", balance), be("temp_motor", 2, 16, 10, "degC", balance),
                be("current_in", 4, 16, 10, "A", balance), be("pid_pos", 6, 16, 50, "deg", balance)},
               fmt::format("STATUS_4 from controller {}.", c)});
  m.push_back({id(Command::status_5), name("status_5"), 8, me,
               {be("tachometer", 0, 32, 1, "", balance), be("voltage_in", 4, 16, 10, "V", balance)},
               fmt::format("STATUS_5 from controller {}: tachometer counts 6 steps per electrical revolution; bytes "
                           "6-7 reserved.", c)});
  m.push_back({id(Command::status_6), name("status_6"), 8, me,
               {be("adc1", 0, 16, 1000, "V", balance), be("adc2", 2, 16, 1000, "V", balance),
                be("adc3", 4, 16, 1000, "V", balance), be("ppm", 6, 16, 1000, "", balance)},
               fmt::format("STATUS_6 from controller {}.", c)});
  return m;
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    out += ch;
  }
  return out + '"';
}

}  // namespace

std::string make_dbc(const DbcOptions& options) {
  std::vector<Message> messages = saul_messages();
  std::string nodes = "Orin BALANCE";
  for (const auto c : options.vesc_controllers) {
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
    for (const auto& s : msg.signals) out += signal_line(s);
    out += "\n";
  }

  out += "\nCM_ " + quoted(
      "SAUL-TEE robot bus, 500 kbit/s (written by saulctl dbc; docs/protocol.md sections 3 and 6). SAUL frames: "
      "11-bit ids, little-endian. VESC frames: 29-bit ids (bit 31 set here, as DBC marks extended ids), "
      "big-endian, id = command << 8 | controller id. 0x301 is multiplexed by gain_index; each gain is a "
      "multiplexed float32 signal (SIG_VALTYPE_ 1).") + ";\n";
  out += "CM_ BU_ Orin \"The robot's host computer (Jetson Orin).\";\n";
  out += "CM_ BU_ BALANCE \"The BALANCE board (ESP32-S3): balance loop, drives the VESCs.\";\n";
  for (const auto c : options.vesc_controllers)
    out += fmt::format("CM_ BU_ VESC_{} \"VESC motor controller id {}{}.\";\n", c, c,
                       c == vesc::kLeftId ? ", left hub motor" : c == vesc::kRightId ? ", right hub motor" : "");
  for (const auto& msg : messages)
    if (!msg.comment.empty()) out += fmt::format("CM_ BO_ {} {};\n", msg.dbc_id, quoted(msg.comment));
  out += fmt::format("CM_ SG_ {} tilt_limit {};\n", kConfigCmdId, quoted("tilt_limit_x100 on the wire"));
  out += fmt::format("CM_ SG_ {} pitch {};\n", kTelemetryAId, quoted("pitch_x100 on the wire"));
  out += fmt::format("CM_ SG_ {} battery {};\n", kTelemetryBId, quoted("battery_mv on the wire"));
  out += "\n";

  // Value tables: the names saulctl decode prints.
  auto values = [&out](std::uint32_t id, const char* signal, const std::vector<std::pair<unsigned, std::string>>& v) {
    out += fmt::format("VAL_ {} {}", id, signal);
    for (auto it = v.rbegin(); it != v.rend(); ++it) out += fmt::format(" {} {}", it->first, quoted(it->second));
    out += " ;\n";
  };
  std::vector<std::pair<unsigned, std::string>> gains, modes, states, results;
  for (unsigned i = 0; i < 3; ++i) gains.emplace_back(i, to_string(static_cast<Gain>(i)));
  for (unsigned i = 0; i < 4; ++i) modes.emplace_back(i, to_string(static_cast<Mode>(i)));
  for (unsigned i = 0; i < 6; ++i) states.emplace_back(i, to_string(static_cast<RobotState>(i)));
  for (unsigned i = 0; i < 4; ++i) results.emplace_back(i, to_string(static_cast<AckResult>(i)));
  values(kPidGainId, "gain_index", gains);
  values(kModeCmdId, "mode", modes);
  values(kTelemetryAId, "state", states);
  values(kCommandAckId, "command", {{1, "pid_gain"}, {2, "mode_cmd"}, {3, "config_cmd"}});
  values(kCommandAckId, "result", results);
  out += "\n";
  for (const auto& msg : messages)
    for (const auto& s : msg.signals)
      if (s.is_float) out += fmt::format("SIG_VALTYPE_ {} {} : 1;\n", msg.dbc_id, s.name);
  return out;
}

}  // namespace saul::host
