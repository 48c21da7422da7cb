#include "saulproto/host/report/format.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <string_view>
#include <type_traits>

#include "saulproto/host/capture/candump.hpp"

namespace saul::host {
namespace {

using signals::Kind;
using signals::MessageDesc;
using signals::Text;

// ---- messages without a description (Pride): the struct's own fields() -----------------------------------------

// Enums print by name (found by argument-dependent lookup of to_string in the enum's namespace),
// floats in shortest form, integers as numbers.
template <class T>
std::string text_of(const T& v) {
  if constexpr (std::is_enum_v<T>) {
    return to_string(v);
  } else if constexpr (std::is_floating_point_v<T>) {
    return fmt::format("{:g}", v);
  } else if constexpr (std::is_integral_v<T>) {
    return fmt::format("{}", +v);  // + promotes uint8_t so it prints as a number
  } else {
    return fmt::format("{}", v);
  }
}

template <class T>
nlohmann::json json_of(const T& v) {
  if constexpr (std::is_enum_v<T>) {
    return to_string(v);
  } else if constexpr (std::is_integral_v<T>) {
    return +v;
  } else {
    return v;
  }
}

template <class M>
std::string describe_one(const M& m) {
  std::string s = M::kName;
  m.fields([&](const char* name, const auto& value) {
    s += ' ';
    s += name;
    s += '=';
    s += text_of(value);
  });
  return s;
}

template <class M>
nlohmann::json json_one(const M& m) {
  nlohmann::json j;
  j["type"] = M::kName;
  m.fields([&](const char* name, const auto& value) { j[name] = json_of(value); });
  return j;
}

// ---- described messages: key, value and its form from core/signals ---------------------------------------------

// The unit as text shows it: the descriptions' ASCII units as their symbols.
std::string_view unit_symbol(std::string_view unit) {
  if (unit == "deg") return "\u00B0";       // °
  if (unit == "degC") return "\u00B0C";     // °C
  if (unit == "us") return "\u00B5s";       // µs
  return unit;
}

}  // namespace

namespace {
/// raw's physical value times 10^k, exact in integers for a decimal resolution k = text_decimals(s) >= 0.
std::int64_t scaled_by_ten_k(const signals::SignalDesc& s, std::int64_t raw, int k, std::int64_t& ten_k) {
  ten_k = 1;
  for (int i = 0; i < k; ++i) ten_k *= 10;
  return raw * (std::int64_t{s.scale_num} * ten_k / s.scale_den) + std::llround(s.offset * static_cast<double>(ten_k));
}
}  // namespace

namespace {
void append_int(std::string& out, std::int64_t v) {
  char tmp[24];
  const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
  out.append(tmp, r.ptr);
}
}  // namespace

// A scaled wire integer's physical value and unit (signals::text_in_unit): exact in integers for a decimal
// resolution (1234 x 1/100 -> "12.34"), whole units rounded down otherwise.
void append_physical_text(std::string& out, const signals::SignalDesc& s, std::int64_t raw) {
  const int k = signals::text_decimals(s);
  if (k < 0) {
    append_int(out, static_cast<std::int64_t>(std::floor(signals::raw_to_physical(s, raw))));
  } else {
    std::int64_t ten_k = 1;
    const std::int64_t scaled = scaled_by_ten_k(s, raw, k, ten_k);
    const std::uint64_t magnitude = scaled < 0 ? 0 - static_cast<std::uint64_t>(scaled) : static_cast<std::uint64_t>(scaled);
    if (scaled < 0) out += '-';
    char tmp[24];
    const auto r = std::to_chars(tmp, tmp + sizeof tmp, magnitude / static_cast<std::uint64_t>(ten_k));
    out.append(tmp, r.ptr);
    if (k > 0) {
      // the fraction, k digits with its leading zeros
      auto frac = magnitude % static_cast<std::uint64_t>(ten_k);
      const std::size_t at = out.size() + 1;
      out.append(static_cast<std::size_t>(k) + 1, '0');
      out[at - 1] = '.';
      for (int i = k - 1; i >= 0; --i, frac /= 10) out[at + static_cast<std::size_t>(i)] = static_cast<char>('0' + frac % 10);
    }
  }
  out.append(unit_symbol(s.unit));
}

std::string physical_text(const signals::SignalDesc& s, std::int64_t raw) {
  std::string out;
  append_physical_text(out, s, raw);
  return out;
}

namespace {
/// fmt's "{:g}" (printf's %g: 6 significant digits) of raw / den, for den a power of ten up to 10^4, written as the
/// exact decimal when it has at most 6 significant digits and lies in [1e-4, 1e6): the double nearest to such a
/// decimal rounds back to it at 6 digits, and %g then prints it in fixed notation without trailing zeros. False
/// (nothing written) otherwise.
bool decimal_g(std::string& out, std::int64_t raw, std::int32_t den) {
  int places = 0;
  for (std::int32_t d = den; d > 1; d /= 10) {
    if (d % 10 != 0) return false;
    ++places;
  }
  if (places > 4 || raw <= -1'000'000'000'000LL || raw >= 1'000'000'000'000LL) return false;
  std::uint64_t v = raw < 0 ? static_cast<std::uint64_t>(-raw) : static_cast<std::uint64_t>(raw);
  if (v == 0) {
    out += '0';
    return true;
  }
  if (v / static_cast<std::uint64_t>(den) >= 1'000'000) return false;
  // drop the fraction's trailing zeros
  while (places > 0 && v % 10 == 0) {
    v /= 10;
    --places;
  }
  char digits[24];
  const auto r = std::to_chars(digits, digits + sizeof digits, v);
  auto n = static_cast<int>(r.ptr - digits);
  int significant = n;
  for (int i = n - 1; i > 0 && digits[i] == '0'; --i) --significant;  // an integer's trailing zeros
  if (n <= places) significant = n;                                    // 0.00ddd: the leading zeros do not count
  if (significant > 6) return false;
  if (raw < 0) out += '-';
  if (n <= places) {
    out += "0.";
    out.append(static_cast<std::size_t>(places - n), '0');
    out.append(digits, static_cast<std::size_t>(n));
  } else {
    out.append(digits, static_cast<std::size_t>(n - places));
    if (places > 0) {
      out += '.';
      out.append(digits + n - places, static_cast<std::size_t>(places));
    }
  }
  return true;
}

}  // namespace

void append_value_text(std::string& out, const signals::SignalDesc& s, std::int64_t raw, std::string_view chars) {
  auto it = std::back_inserter(out);
  if (s.kind == Kind::string) return out.append(chars), void();
  if (signals::text_in_unit(s)) return append_physical_text(out, s, raw);
  switch (s.text) {
    case Text::raw:
      if (s.kind == Kind::float32) {
        fmt::format_to(it, FMT_COMPILE("{:g}"), std::bit_cast<float>(static_cast<std::uint32_t>(raw)));
        return;
      }
      return append_int(out, raw);
    case Text::name:
      if (const char* name = signals::value_name(s, raw)) return out.append(name), void();
      return append_int(out, raw);
    case Text::physical:
      if (s.kind != Kind::float32 && s.scale_num == 1 && s.offset == 0 && decimal_g(out, raw, s.scale_den)) return;
      fmt::format_to(it, FMT_COMPILE("{:g}"), signals::raw_to_physical(s, raw));
      return;
    case Text::physical_int: return append_int(out, std::llround(signals::raw_to_physical(s, raw)));
  }
  append_int(out, raw);
}


PhysicalNumber physical_number(const signals::SignalDesc& s, std::int64_t raw) {
  const int k = signals::text_decimals(s);
  PhysicalNumber n;
  if (k < 0) {
    n.integral = true;
    n.whole = static_cast<std::int64_t>(std::floor(signals::raw_to_physical(s, raw)));
    return n;
  }
  std::int64_t ten_k = 1;
  const std::int64_t scaled = scaled_by_ten_k(s, raw, k, ten_k);
  if (k == 0) {
    n.integral = true;
    n.whole = scaled;
    return n;
  }
  // Both exact in a double (|scaled| < 2^53), so the division is the double nearest to the decimal text shows.
  n.value = static_cast<double>(scaled) / static_cast<double>(ten_k);
  return n;
}

std::string physical_key(const signals::SignalDesc& s) {
  std::string key = s.name;
  key += '_';
  for (const char* u = s.unit; *u != '\0'; ++u) {
    if (*u == '/') continue;
    key += static_cast<char>(*u >= 'A' && *u <= 'Z' ? *u - 'A' + 'a' : *u);
  }
  return key;
}

namespace {

nlohmann::json json_of(const SignalValue& v) {
  const auto& s = *v.signal;
  if (s.kind == Kind::string) return v.text;
  switch (s.text) {
    case Text::raw:
      if (s.kind == Kind::float32) return std::bit_cast<float>(static_cast<std::uint32_t>(v.raw));
      return v.raw;
    case Text::name:
      if (const char* name = signals::value_name(s, v.raw)) return name;
      return v.raw;
    case Text::physical: return signals::raw_to_physical(s, v.raw);
    case Text::physical_int: return static_cast<std::int64_t>(std::llround(signals::raw_to_physical(s, v.raw)));
  }
  return v.raw;
}

std::string describe_values(const SignalValues& values) {
  std::string s = values.message->name;
  for (const auto& v : values.values) {
    s += ' ';
    s += signals::text_in_unit(*v.signal) ? v.signal->name : v.signal->key;
    s += '=';
    append_value_text(s, *v.signal, v.raw, v.text);
  }
  return s;
}

nlohmann::json json_values(const SignalValues& values) {
  nlohmann::json j;
  j["type"] = values.message->name;
  for (const auto& v : values.values) {
    j[v.signal->key] = json_of(v);
    if (signals::text_in_unit(*v.signal)) {
      const PhysicalNumber n = physical_number(*v.signal, v.raw);
      j[physical_key(*v.signal)] = n.integral ? nlohmann::json(n.whole) : nlohmann::json(n.value);
    }
  }
  return j;
}

// Every signal present in the frame, read from its bytes.
SignalValues values_from_wire(const MessageDesc& d, const signals::Wire& wire) {
  SignalValues out{&d, {}};
  const auto mux = signals::mux_of(d, wire);
  for (const auto& s : d.signals) {
    if (!signals::present(s, mux)) continue;
    SignalValue v{&s, 0, {}};
    if (s.kind == Kind::string) {
      v.text = std::string(signals::read_string(s, wire.payload).value_or(""));
    } else {
      v.raw = signals::read(d, s, wire).value_or(0);
    }
    out.values.push_back(std::move(v));
  }
  return out;
}

// A CRSF message reaches the formatter without its bytes (the serial decoders hand on the typed message), so
// its fields() give the values, in the description's order, turned back into wire integers (exact: CRSF's
// scales and offsets are integers) and then shown exactly as the bytes would be.
template <class M>
SignalValues values_from_fields(const MessageDesc& d, const M& m) {
  SignalValues out{&d, {}};
  std::size_t i = 0;
  m.fields([&](const char*, const auto& value) {
    using T = std::decay_t<decltype(value)>;
    if (i >= d.signals.size()) return;
    const auto& s = d.signals[i++];
    SignalValue v{&s, 0, {}};
    if constexpr (std::is_same_v<T, const char*>) {
      v.text = value;
    } else if constexpr (std::is_floating_point_v<T>) {
      v.raw = signals::physical_to_raw(s, static_cast<double>(value));
    } else {
      const auto n = static_cast<std::int64_t>(value);
      v.raw = s.text == Text::physical_int ? signals::physical_to_raw(s, static_cast<double>(n)) : n;
    }
    out.values.push_back(std::move(v));
  });
  return out;
}

// The wire bytes of an inter-board message: the payload of the frame its encoder writes.
struct InterboardWire {
  std::array<std::uint8_t, interboard::kMaxFrameSize> frame{};
  signals::Wire wire;
};
InterboardWire interboard_wire(const interboard::Message& m) {
  InterboardWire w;
  const auto n = interboard::encode(m, w.frame);
  const std::size_t size = n ? n.value() : interboard::kOverhead;
  w.wire.payload = std::span<const std::uint8_t>(w.frame).subspan(3, size - interboard::kOverhead);
  return w;
}

}  // namespace

SignalValues signal_values(const BusMessage& message) {
  const CanFrame f = encode_bus_message(message);
  const MessageDesc* d = signals::find_can(f.id, f.extended);
  if (d == nullptr) return {};
  return values_from_wire(*d, signals::Wire{f.id, f.payload()});
}

SignalValues signal_values(const interboard::Message& message) {
  const MessageDesc* d =
      signals::find(signals::Protocol::interboard, static_cast<std::uint8_t>(interboard::type_of(message)));
  if (d == nullptr) return {};
  const InterboardWire w = interboard_wire(message);
  return values_from_wire(*d, w.wire);
}

SignalValues signal_values(const crsf::Message& message) {
  const MessageDesc* d = signals::find(signals::Protocol::crsf, static_cast<std::uint8_t>(crsf::type_of(message)));
  if (d == nullptr) return {};
  return std::visit([d](const auto& m) { return values_from_fields(*d, m); }, message);
}

namespace {
// Described messages through their description; anything else (Pride) through its fields().
template <class Message>
std::string describe_any(const Message& message) {
  if constexpr (requires { signal_values(message); }) {
    if (const auto values = signal_values(message); values.message != nullptr) return describe_values(values);
  }
  return std::visit([](const auto& m) { return describe_one(m); }, message);
}
template <class Message>
nlohmann::json json_any(const Message& message) {
  if constexpr (requires { signal_values(message); }) {
    if (const auto values = signal_values(message); values.message != nullptr) return json_values(values);
  }
  return std::visit([](const auto& m) { return json_one(m); }, message);
}
}  // namespace

std::string describe(const BusMessage& message) { return describe_any(message); }
std::string describe(const interboard::Message& message) { return describe_any(message); }
std::string describe(const crsf::Message& message) { return describe_any(message); }
std::string describe(const pride::Message& message) { return describe_any(message); }
nlohmann::json to_json(const BusMessage& message) { return json_any(message); }
nlohmann::json to_json(const interboard::Message& message) { return json_any(message); }
nlohmann::json to_json(const crsf::Message& message) { return json_any(message); }
nlohmann::json to_json(const pride::Message& message) { return json_any(message); }

nlohmann::json frame_to_json(const CanFrame& frame) {
  nlohmann::json j;
  j["id"] = frame.id;
  j["extended"] = frame.extended;
  j["remote"] = frame.remote;
  j["error"] = frame.error;
  j["dlc"] = frame.dlc;
  std::string hex;
  for (std::uint8_t b : frame.payload()) hex += fmt::format("{:02X}", b);
  j["data"] = hex;
  if (frame.timestamp_ns) j["timestamp_ns"] = *frame.timestamp_ns;
  return j;
}

}  // namespace saul::host
