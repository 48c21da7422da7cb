#include "saulproto/host/report/signal_rows.hpp"

#include <fmt/format.h>


namespace saul::host {

std::vector<SignalRow> signal_rows(const SignalValues& values) {
  std::vector<SignalRow> rows;
  if (values.message == nullptr) return rows;
  rows.reserve(values.values.size());
  for (const auto& v : values.values) {
    const auto& s = *v.signal;
    if (s.kind == signals::Kind::string) continue;
    const bool as_integer = s.kind != signals::Kind::float32 && (s.text == signals::Text::name || !s.values.empty());
    rows.push_back({s.name, as_integer ? static_cast<double>(v.raw) : signals::raw_to_physical(s, v.raw), s.unit});
  }
  return rows;
}

namespace {
// A field that needs quoting in CSV: an interface or link name with a comma or a quote.
std::string csv_field(std::string_view s) {
  if (s.find_first_of(",\"\n") == std::string_view::npos) return std::string(s);
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + '"';
}
}  // namespace

std::string long_csv_rows(std::string_view time, std::string_view interface, std::string_view id,
                          const SignalValues& values) {
  std::string out;
  const std::string lead = fmt::format("{},{},{},{},", time, csv_field(interface), id,
                                       values.message != nullptr ? values.message->name : "");
  for (const auto& r : signal_rows(values)) out += fmt::format("{}{},{},{}\n", lead, r.signal, r.value, r.unit);
  return out;
}

}  // namespace saul::host
