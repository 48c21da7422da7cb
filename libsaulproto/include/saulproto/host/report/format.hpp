// Text and JSON of decoded messages: one renderer, append_message(). Every message prints from its description
// (core/signals.hpp), each signal under its one name (docs/cli.md) as the wire integer, its value name or its
// physical value; a scaled wire integer in its unit ("pitch=12.34°"; JSON "pitch":12.34 and "pitch_raw":1234).
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

/// A signal's value as text shows it ("1", "BALANCE", "0.5", "12.34°"), written at `w` (room for 64 characters,
/// or chars.size(): a string signal's text); returns its end.
char* write_value_text(char* w, const signals::SignalDesc& s, std::int64_t raw, std::string_view chars);

/// The JSON key of a scaled wire integer's integer: "pitch_raw" (1234) beside "pitch" (12.34).
std::string raw_key(const signals::SignalDesc& s);

/// THE renderer (describe(), to_json(), decode's lines and MCAP's messages all come from it), for a message's
/// bytes, appended to `out`: text "velocity_cmd speed_mmps=1000 steer_mrad=-500", or JSON with keys sorted as
/// nlohmann sorts them; mcap_json without what an MCAP topic says ("type", signals of the CAN id). O(message size).
enum class MessageFormat : std::uint8_t { text, json, mcap_json };
void append_message(std::string& out, MessageFormat format, const signals::MessageDesc& message,
                    const signals::Wire& wire);
/// The same written at `w`, which has room for message_chars_max(message) characters; returns its end.
char* write_message(char* w, MessageFormat format, const signals::MessageDesc& message, const signals::Wire& wire);
std::size_t message_chars_max(const signals::MessageDesc& message);

/// `s` copied to `w`; returns its end.
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

/// `j` as one line of JSON, each byte that is not UTF-8 (a file or interface name from a file) as U+FFFD, where
/// dump() would throw.
inline std::string json_line(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace saul::host
