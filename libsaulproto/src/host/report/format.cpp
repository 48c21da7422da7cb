#include "saulproto/host/report/format.hpp"

#include <fmt/format.h>

#include <array>
#include <bit>
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

// A scaled wire integer's physical value and unit (signals::text_in_unit): exact in integers for a decimal
// resolution (1234 x 1/100 -> "12.34"), whole units rounded down otherwise. Also the fast emitter's (fast_emit.cpp).
std::string physical_text(const signals::SignalDesc& s, std::int64_t raw) {
  const int k = signals::text_decimals(s);
  std::string number;
  if (k < 0) {
    number = fmt::format("{}", static_cast<std::int64_t>(std::floor(signals::raw_to_physical(s, raw))));
  } else {
    std::int64_t ten_k = 1;
    const std::int64_t scaled = scaled_by_ten_k(s, raw, k, ten_k);
    const std::uint64_t magnitude = scaled < 0 ? 0 - static_cast<std::uint64_t>(scaled) : static_cast<std::uint64_t>(scaled);
    const auto whole = magnitude / static_cast<std::uint64_t>(ten_k);
    const auto frac = magnitude % static_cast<std::uint64_t>(ten_k);
    number = k == 0 ? fmt::format("{}{}", scaled < 0 ? "-" : "", whole)
                    : fmt::format("{}{}.{:0{}}", scaled < 0 ? "-" : "", whole, frac, k);
  }
  return number + std::string(unit_symbol(s.unit));
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

// The value as text: the wire integer, its name, or its physical value (SignalDesc::text); a scaled wire
// integer as its physical value with its unit (signals::text_in_unit).
std::string text_of(const SignalValue& v) {
  const auto& s = *v.signal;
  if (s.kind == Kind::string) return v.text;
  if (signals::text_in_unit(s)) return physical_text(s, v.raw);
  switch (s.text) {
    case Text::raw:
      if (s.kind == Kind::float32) return fmt::format("{:g}", std::bit_cast<float>(static_cast<std::uint32_t>(v.raw)));
      return fmt::format("{}", v.raw);
    case Text::name:
      if (const char* name = signals::value_name(s, v.raw)) return name;
      return fmt::format("{}", v.raw);
    case Text::physical: return fmt::format("{:g}", signals::raw_to_physical(s, v.raw));
    case Text::physical_int: return fmt::format("{}", std::llround(signals::raw_to_physical(s, v.raw)));
  }
  return fmt::format("{}", v.raw);
}

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
    s += text_of(v);
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
