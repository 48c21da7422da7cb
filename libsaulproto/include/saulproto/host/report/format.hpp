// Text and JSON renderings of decoded messages, for saulctl and for logs: one renderer, append_message().
//
// Every message (SAUL, VESC, CRSF, inter-board, Pride) prints from its description (core/signals.hpp), each signal
// under its one name (docs/cli.md's table): its value as the wire integer, its value name or its physical value,
// as the description says; a scaled wire integer (signals::text_in_unit) in its unit ("pitch=12.34°"; JSON
// "pitch":12.34 and the integer as "pitch_raw":1234).
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
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
/// description reads them. message is nullptr only for what is no message (a CRSF frame that did not decode).
struct SignalValues {
  const signals::MessageDesc* message = nullptr;
  std::vector<SignalValue> values;
};
SignalValues signal_values(const BusMessage& message);
SignalValues signal_values(const interboard::Message& message);
SignalValues signal_values(const crsf::Message& message);
SignalValues signal_values(const pride::Message& message);

/// A signal's value as text shows it, written at `w` (room for 64 characters, or chars.size()); returns its end:
/// the wire integer, its value name, its physical value (fmt's "{:g}", written directly when it is an exact short
/// decimal) or, for a scaled wire integer (signals::text_in_unit), its physical value with its unit ("12.34°",
/// "39.876V"). `chars` is a string signal's text.
char* write_value_text(char* w, const signals::SignalDesc& s, std::int64_t raw, std::string_view chars);

/// The JSON key of a scaled wire integer's integer (signals::text_in_unit), beside its physical value under the
/// signal's name: "pitch_raw" (1234) beside "pitch" (12.34).
std::string raw_key(const signals::SignalDesc& s);

/// THE renderer, for a message's bytes, appended to `out`: text "velocity_cmd speed_mmps=1000 steer_mrad=-500", or
/// its JSON object {"speed_mmps":1000,"steer_mrad":-500,"type":"velocity_cmd"} (keys sorted, as nlohmann writes
/// objects). describe() and to_json() below (CRSF and Pride messages: their structs' values read into the same
/// signals), decode's and sniff's lines (fast_emit.hpp) and MCAP's messages all come from here. O(message size),
/// no allocation beyond out's growth. mcap_json: the JSON object without what an MCAP channel's topic already
/// says (mcap_signals.hpp): no "type", no signal read from the CAN id (a VESC's "controller_id").
enum class MessageFormat : std::uint8_t { text, json, mcap_json };
void append_message(std::string& out, MessageFormat format, const signals::MessageDesc& message,
                    const signals::Wire& wire);
/// The same written at `w`, which has room for message_chars_max(message) characters; returns its end.
char* write_message(char* w, MessageFormat format, const signals::MessageDesc& message, const signals::Wire& wire);
std::size_t message_chars_max(const signals::MessageDesc& message);

/// `s` copied to `w`; returns its end (the renderer writes its text at a pointer with room for it).
inline char* put_chars(char* w, std::string_view s) {
  std::memcpy(w, s.data(), s.size());
  return w + s.size();
}

/// `s` as a C string literal, as DBC, Lua and gnuplot read it: in double quotes, '"' and '\\' escaped with a
/// backslash, a line break as "\\n".
std::string c_literal(std::string_view s);
/// A CSV field: as it is, or in double quotes (inner quotes doubled) when it holds a comma, a quote or a line break.
std::string csv_quote(std::string_view s);

/// `s` as a JSON string with its quotes, as nlohmann's dump() writes it (bytes that are not UTF-8 as U+FFFD).
void append_json_string(std::string& out, std::string_view s);

std::string describe(const BusMessage& message);
std::string describe(const interboard::Message& message);
std::string describe(const crsf::Message& message);
std::string describe(const pride::Message& message);

/// {"type":"velocity_cmd","speed_mmps":1000,"steer_mrad":-500}; {"pitch":12.34,"pitch_raw":1234,...}
nlohmann::json to_json(const BusMessage& message);
nlohmann::json to_json(const interboard::Message& message);
nlohmann::json to_json(const crsf::Message& message);
nlohmann::json to_json(const pride::Message& message);

/// `j` as one line of JSON. Text from files (a file name, an interface or link name) may hold bytes that are not
/// UTF-8, which nlohmann's dump() refuses with an exception (a decode or stats --json then ended with no output at
/// all): here each such byte becomes U+FFFD and the line stays valid JSON.
inline std::string json_line(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace saul::host
