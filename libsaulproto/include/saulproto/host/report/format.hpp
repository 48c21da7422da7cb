// Text and JSON renderings of decoded messages, for saulctl and for logs.
//
// SAUL, VESC, CRSF and inter-board messages print from their description (core/signals.hpp): JSON has each
// signal's key and its value as the wire integer, its value name or its physical value, as the description says,
// and a scaled wire integer (signals::text_in_unit) also as its physical value under physical_key()
// ("pitch_x100": 1234 and "pitch_deg": 12.34); text shows such a value only in its unit, under the signal's name
// (pitch_x100 1234 -> "pitch=12.34°", docs/cli.md). Any other
// message type with kName and fields(visitor) (Pride) prints its fields(), so it needs no change here either.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/crsf.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/pride.hpp"
#include "saulproto/core/result.hpp"
#include "saulproto/core/signals.hpp"

namespace saul::host {

/// One signal of a decoded message: its description and its wire value (the characters, for a string).
struct SignalValue {
  const signals::SignalDesc* signal = nullptr;
  std::int64_t raw = 0;
  std::string text;
};
/// The signals a message carries, in order (multiplexed signals this frame does not carry left out), as the
/// description reads them. message is nullptr for a message type without a description.
struct SignalValues {
  const signals::MessageDesc* message = nullptr;
  std::vector<SignalValue> values;
};
SignalValues signal_values(const BusMessage& message);
SignalValues signal_values(const interboard::Message& message);
SignalValues signal_values(const crsf::Message& message);

/// "velocity_cmd speed_mmps=1000 steer_mrad=-500", "telemetry_a pitch=12.34° pid_out=120 speed_mmps=400 state=BALANCE"
/// A scaled wire integer as text shows it (signals::text_in_unit): "12.34°", "39.876V"; the one formatter of
/// such values, shared by describe() and the fast emitter (fast_emit.hpp). The key text shows then is the signal's
/// name (SignalDesc::name, "pitch"), not its wire key ("pitch_x100").
std::string physical_text(const signals::SignalDesc& s, std::int64_t raw);
/// The same, appended to `out` (no allocation beyond out's growth).
void append_physical_text(std::string& out, const signals::SignalDesc& s, std::int64_t raw);

/// A signal's value as text shows it, appended to `out`: the wire integer, its value name, its physical value
/// (fmt's "{:g}", written directly when it is an exact short decimal) or, for a scaled wire integer, its
/// physical value with its unit (append_physical_text). `chars` is a string signal's text. The one text formatter
/// of values: describe() and the fast emitter (fast_emit.hpp) both write with it.
void append_value_text(std::string& out, const signals::SignalDesc& s, std::int64_t raw, std::string_view chars);

/// The JSON key of a scaled wire integer's physical value: the signal's name and its unit as a word, lower case,
/// '/' dropped ("pitch" in deg -> "pitch_deg", "battery" in V -> "battery_v", "ch1" in us -> "ch1_us", km/h ->
/// "kmh"). tests/unit/test_signals_text.cpp holds it unique within each message.
std::string physical_key(const signals::SignalDesc& s);

/// A scaled wire integer's physical value as JSON holds it: the same number physical_text() prints, as the double
/// nearest to that exact decimal (1234 x 1/100 -> 12.34), or as an integer where text shows whole units (the CRSF
/// RC channels' microseconds, rounded down). One function, so the slow and the fast JSON writers agree.
struct PhysicalNumber {
  bool integral = false;
  std::int64_t whole = 0;  ///< when integral
  double value = 0;        ///< otherwise
};
PhysicalNumber physical_number(const signals::SignalDesc& s, std::int64_t raw);

std::string describe(const BusMessage& message);
std::string describe(const interboard::Message& message);
std::string describe(const crsf::Message& message);
std::string describe(const pride::Message& message);

/// {"type":"velocity_cmd","speed_mmps":1000,"steer_mrad":-500}; {"pitch_deg":12.34,"pitch_x100":1234,...}
nlohmann::json to_json(const BusMessage& message);
nlohmann::json to_json(const interboard::Message& message);
nlohmann::json to_json(const crsf::Message& message);
nlohmann::json to_json(const pride::Message& message);

/// The frame itself: {"id":768,"extended":false,"remote":false,"error":false,"dlc":4,"data":"E8030CFE"}
nlohmann::json frame_to_json(const CanFrame& frame);
/// `j` as one line of JSON. Text from files (a file name, an interface or link name) may hold bytes that are not
/// UTF-8, which nlohmann's dump() refuses with an exception (a decode or stats --json then ended with no output at
/// all): here each such byte becomes U+FFFD and the line stays valid JSON.
inline std::string json_line(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace saul::host
