// One row per signal of a decoded message, for long tables (saulctl decode --format long): the signal's physical
// name, its value as one number in its unit, and the unit, so DuckDB, pandas or a spreadsheet aggregate a capture
// by signal without parsing strings (docs/captures.md).
#pragma once

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

/// The header and the rows of a message in the long CSV form: "time,interface,id,message,signal,value,unit".
inline constexpr const char* kLongCsvHeader = "time,interface,id,message,signal,value,unit";
/// The CSV lines (each ending in '\n') of one message: id is "" for a serial message, its hex CAN id otherwise.
std::string long_csv_rows(std::string_view time, std::string_view interface, std::string_view id,
                          const SignalValues& values);

}  // namespace saul::host
