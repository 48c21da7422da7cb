// Per signal over a capture: how many values, their mean, least and greatest, in the signal's physical unit
// (`saulctl stats --signals`). The values are exactly the long CSV's (signal_rows.hpp: a scaled integer in its
// unit, a named value as its integer), so a query engine's aggregate over `decode --format long` equals this
// (tests/cli/long_csv.py holds DuckDB to it).
//
// Memory grows with the number of distinct (message, signal) pairs only, a few hundred for the robot's
// descriptions; each add() costs one decode of the message and a map lookup per signal.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <string>
#include <utility>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/report/format.hpp"

namespace saul::host {

class SignalStats {
 public:
  /// A CAN frame: decoded, and its signals counted when it decodes to a described message.
  void add(const CanFrame& frame);
  /// The signals of a decoded message (nothing for message == nullptr).
  void add(const SignalValues& values);

  struct Signal {
    std::uint64_t count = 0;
    double sum = 0;
    double min = 0;
    double max = 0;
    std::string unit;
    [[nodiscard]] double mean() const { return count ? sum / static_cast<double>(count) : 0; }
  };
  /// By (message, signal) name, in that order: what `order by message, signal` gives.
  [[nodiscard]] const std::map<std::pair<std::string, std::string>, Signal>& signals() const { return signals_; }

  /// A table, one line per signal: message, signal, count, mean, min, max, unit (empty when nothing decoded).
  [[nodiscard]] std::string text() const;
  /// [{"message","signal","count","mean","min","max","unit"}, ...]
  [[nodiscard]] nlohmann::json json() const;

 private:
  std::map<std::pair<std::string, std::string>, Signal> signals_;
};

}  // namespace saul::host
