// One row per signal of a decoded message, for long tables (saulctl decode --format long): the signal's physical
// name, its value as one number in its unit, and the unit, so DuckDB, pandas or a spreadsheet aggregate a capture
// by signal without parsing strings (docs/captures.md).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/host/report/format.hpp"

namespace saul::host {

struct SignalRow {
  const char* signal = "";  ///< the physical name (SignalDesc::name): "pitch", "battery", "ch1", "kp"
  double value = 0;         ///< physical value in `unit`; a named value or a bit set as its integer (state 1)
  const char* unit = "";    ///< ASCII, as the descriptions write it: "deg", "V", "us", "mm/s"; "" for none
};

/// The number signals of a described message, in order (strings left out). Empty for no description.
std::vector<SignalRow> signal_rows(const SignalValues& values);

// ---- a signal by its name: plot --field and the bench suites' conditions --------------------------------------

/// A signal's value by its one name (docs/cli.md), as decode --json keys it: "pitch" the physical value (12.34),
/// "pitch_raw" a scaled one's wire integer (1234), "state" a named value's number (1) with its name as text.
struct NamedValue {
  double number = 0;
  std::string text;  ///< the value's name, or the number as fmt writes it
};
/// nullopt when the message has no such signal or this frame does not carry it (a multiplexed one).
std::optional<NamedValue> signal_value(const SignalValues& values, std::string_view name);
/// Whether signal_value() knows `name` for message m.
bool has_signal(const signals::MessageDesc& m, std::string_view name);
/// The names signal_value() takes for m, in order: every number signal, and name_raw after a scaled one.
std::vector<std::string> signal_names(const signals::MessageDesc& m);
/// The one-line error for a name m has not: "telemetry_a has no signal 'pitch_x100'; its signals: pitch,
/// pitch_raw, pid_out, speed_mmps, state". m nullptr: what has no description (an undecoded CRSF frame), with none.
std::string unknown_signal_error(std::string_view message_name, const signals::MessageDesc* m, std::string_view name);

inline constexpr const char* kLongCsvHeader = "time,interface,id,message,signal,value,unit";
/// The CSV lines (each ending in '\n') of one message: id is "" for a serial message, its hex CAN id otherwise.
std::string long_csv_rows(std::string_view time, std::string_view interface, std::string_view id,
                          const SignalValues& values);

}  // namespace saul::host
