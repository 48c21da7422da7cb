#include "saulproto/host/report/signal_rows.hpp"

#include "saulproto/host/report/format.hpp"  // csv_quote

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace saul::host {

namespace {

// A number signal's one value: a named value or a bit set as its integer, everything else physical.
double row_value(const signals::SignalDesc& s, std::int64_t raw) {
  const bool as_integer = s.kind != signals::Kind::float32 && (s.text == signals::Text::name || !s.values.empty());
  return as_integer ? static_cast<double>(raw) : signals::raw_to_physical(s, raw);
}

// The signal of m that `name` names, and whether it names its wire integer (name_raw); nullptr for none.
const signals::SignalDesc* named_signal(const signals::MessageDesc& m, std::string_view name, bool& raw) {
  for (const auto& s : m.signals) {
    if (s.kind == signals::Kind::string) continue;
    if (name == s.name) {
      raw = false;
      return &s;
    }
    if (signals::text_in_unit(s) && name == raw_key(s)) {
      raw = true;
      return &s;
    }
  }
  return nullptr;
}

}  // namespace

std::vector<SignalRow> signal_rows(const SignalValues& values) {
  std::vector<SignalRow> rows;
  if (values.message == nullptr) return rows;
  rows.reserve(values.values.size());
  for (const auto& v : values.values) {
    const auto& s = *v.signal;
    if (s.kind == signals::Kind::string) continue;
    rows.push_back({s.name, row_value(s, v.raw), s.unit});
  }
  return rows;
}

std::optional<NamedValue> signal_value(const SignalValues& values, std::string_view name) {
  if (values.message == nullptr) return std::nullopt;
  bool raw = false;
  const signals::SignalDesc* s = named_signal(*values.message, name, raw);
  if (s == nullptr) return std::nullopt;
  for (const auto& v : values.values) {
    if (v.signal != s) continue;
    NamedValue out;
    out.number = raw ? static_cast<double>(v.raw) : row_value(*s, v.raw);
    const char* value_name = raw || s->value_bits ? nullptr : signals::value_name(*s, v.raw);
    out.text = value_name != nullptr ? std::string(value_name) : fmt::format("{}", out.number);
    return out;
  }
  return std::nullopt;  // a multiplexed signal this frame does not carry
}

bool has_signal(const signals::MessageDesc& m, std::string_view name) {
  bool raw = false;
  return named_signal(m, name, raw) != nullptr;
}

std::vector<std::string> signal_names(const signals::MessageDesc& m) {
  std::vector<std::string> names;
  for (const auto& s : m.signals) {
    if (s.kind == signals::Kind::string) continue;
    names.emplace_back(s.name);
    if (signals::text_in_unit(s)) names.push_back(raw_key(s));
  }
  return names;
}

std::string unknown_signal_error(std::string_view message_name, const signals::MessageDesc* m, std::string_view name) {
  if (m == nullptr)
    return fmt::format("{} has no signal description, so no signal '{}' (docs/cli.md, \"Signal names and units\")",
                       message_name, name);
  return fmt::format("{} has no signal '{}'; its signals: {}", message_name, name, fmt::join(signal_names(*m), ", "));
}

std::string long_csv_rows(std::string_view time, std::string_view interface, std::string_view id,
                          const SignalValues& values) {
  std::string out;
  const std::string lead = fmt::format("{},{},{},{},", time, csv_quote(interface), id,
                                       values.message != nullptr ? values.message->name : "");
  for (const auto& r : signal_rows(values)) out += fmt::format("{}{},{},{}\n", lead, r.signal, r.value, r.unit);
  return out;
}

}  // namespace saul::host
