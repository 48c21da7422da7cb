// Per signal over a capture (`saulctl stats --signals`): count, mean, min and max of the long CSV's values
// (signal_rows.hpp), so an aggregate over `decode --format long` equals this. Memory grows with the distinct
// (message, signal) pairs only.
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
