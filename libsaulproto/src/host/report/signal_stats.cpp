#include "saulproto/host/report/signal_stats.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/report/signal_rows.hpp"

namespace saul::host {

void SignalStats::add(const CanFrame& frame) {
  const auto result = decode_bus_frame(frame);
  if (result) add(signal_values(result.value()));
}

void SignalStats::add(const SignalValues& values) {
  if (values.message == nullptr) return;
  for (const SignalRow& row : signal_rows(values)) {
    Signal& s = signals_[{values.message->name, row.signal}];
    if (s.count == 0) {
      s.min = s.max = row.value;
      s.unit = row.unit;
    }
    ++s.count;
    s.sum += row.value;
    s.min = std::min(s.min, row.value);
    s.max = std::max(s.max, row.value);
  }
}

std::string SignalStats::text() const {
  if (signals_.empty()) return {};
  std::string out = fmt::format("{:<22} {:<16} {:>9} {:>14} {:>14} {:>14}  {}\n", "message", "signal", "count", "mean",
                                "min", "max", "unit");
  for (const auto& [key, s] : signals_)
    out += fmt::format("{:<22} {:<16} {:>9} {:>14.6g} {:>14.6g} {:>14.6g}  {}\n", key.first, key.second, s.count,
                       s.mean(), s.min, s.max, s.unit);
  return out;
}

nlohmann::json SignalStats::json() const {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [key, s] : signals_)
    list.push_back({{"message", key.first},
                    {"signal", key.second},
                    {"count", s.count},
                    {"mean", s.mean()},
                    {"min", s.min},
                    {"max", s.max},
                    {"unit", s.unit}});
  return list;
}

}  // namespace saul::host
