#include "saulproto/host/report/format.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <string_view>
#include <type_traits>
#include <variant>

#include "saulproto/core/signals_pride.hpp"

namespace saul::host {
namespace {

using signals::Kind;
using signals::MessageDesc;
using signals::Text;

// ---- key, value and its form from core/signals ---------------------------------------------------------------------

// The unit as text shows it: the descriptions' ASCII units as their symbols.
std::string_view unit_symbol(std::string_view unit) {
  if (unit == "deg") return "\u00B0";       // °
  if (unit == "degC") return "\u00B0C";     // °C
  if (unit == "us") return "\u00B5s";       // µs
  return unit;
}

/// raw's physical value times 10^k, exact in integers for a decimal resolution k = text_decimals(s) >= 0.
std::int64_t scaled_by_ten_k(const signals::SignalDesc& s, std::int64_t raw, int k, std::int64_t& ten_k) {
  ten_k = 1;
  for (int i = 0; i < k; ++i) ten_k *= 10;
  return raw * (std::int64_t{s.scale_num} * ten_k / s.scale_den) + std::llround(s.offset * static_cast<double>(ten_k));
}

void append_int(std::string& out, std::int64_t v) {
  char tmp[24];
  const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
  out.append(tmp, r.ptr);
}

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


std::string raw_key(const signals::SignalDesc& s) { return std::string(s.name) + "_raw"; }

void append_json_string(std::string& out, std::string_view s) {
  bool plain = true;  // printable ASCII without '"' or '\\': copied as it is (nearly always)
  for (char c : s) plain = plain && c >= 0x20 && c <= 0x7E && c != '"' && c != '\\';
  if (!plain) return out.append(json_line(nlohmann::json(std::string(s)))), void();
  out += '"';
  out.append(s);
  out += '"';
}

namespace {

// ---- the JSON values, as nlohmann writes numbers -----------------------------------------------------------------

void append_json_double(std::string& out, double x) {
  if (!std::isfinite(x)) return out.append("null"), void();
  char tmp[64];
  out.append(tmp, nlohmann::detail::to_chars(tmp, tmp + sizeof tmp, x));
}

/// A scaled wire integer's physical value as JSON holds it: the same number text prints, as the double nearest to
/// that exact decimal (1234 x 1/100 -> 12.34), or as an integer where text shows whole units (the CRSF RC
/// channels' microseconds, rounded down).
void append_json_physical(std::string& out, const signals::SignalDesc& s, std::int64_t raw) {
  const int k = signals::text_decimals(s);
  if (k < 0) return append_int(out, static_cast<std::int64_t>(std::floor(signals::raw_to_physical(s, raw))));
  std::int64_t ten_k = 1;
  const std::int64_t scaled = scaled_by_ten_k(s, raw, k, ten_k);
  if (k == 0) return append_int(out, scaled);
  // Both exact in a double (|scaled| < 2^53), so the division is the double nearest to the decimal text shows.
  append_json_double(out, static_cast<double>(scaled) / static_cast<double>(ten_k));
}

void append_json_value(std::string& out, const signals::SignalDesc& s, std::int64_t raw, std::string_view chars) {
  if (s.kind == Kind::string) return append_json_string(out, chars);
  switch (s.text) {
    case Text::raw:
      if (s.kind == Kind::float32)
        return append_json_double(out, static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(raw))));
      return append_int(out, raw);
    case Text::name:
      if (const char* name = signals::value_name(s, raw)) return append_json_string(out, name);
      return append_int(out, raw);
    case Text::physical: return append_json_double(out, signals::raw_to_physical(s, raw));
    case Text::physical_int: return append_int(out, std::llround(signals::raw_to_physical(s, raw)));
  }
  append_int(out, raw);
}

// ---- a message's values, read once --------------------------------------------------------------------------------

/// The most signals a message has (the CRSF subset RC channels: 3 + 32); layout_of() holds every description to it.
constexpr std::size_t kMaxSignals = 35;

/// The value of each signal of a message (present: the frame carries it; a multiplexed one may be absent). Only
/// the message's own signals are set (read_wire, read_fields): a CAN message's few, not all kMaxSignals.
struct Reading {
  bool present;
  std::int64_t raw;
  std::string_view chars;  ///< a string signal's characters
};
using Readings = std::array<Reading, kMaxSignals>;

/// signals::read(...).value_or(0), with whole bytes in the payload read a byte at a time (most signals: decode's
/// speed on payloads that never repeat).
std::int64_t read_number(const MessageDesc& d, const signals::SignalDesc& s, const signals::Wire& wire) {
  const std::size_t n = s.length / 8u;
  const bool le = s.order == signals::ByteOrder::little_endian;
  if (s.place == signals::Place::payload && s.length % 8 == 0 && n >= 1 && n <= 7 && s.start_bit % 8 == (le ? 0 : 7) &&
      s.start_bit / 8u + n <= wire.payload.size()) {
    const std::uint8_t* b = wire.payload.data() + s.start_bit / 8u;
    std::uint64_t u = 0;
    for (std::size_t i = 0; i < n; ++i) u |= std::uint64_t{b[i]} << (8 * (le ? i : n - 1 - i));
    if (s.kind == Kind::signed_int && ((u >> (s.length - 1)) & 1U) != 0) u |= ~std::uint64_t{0} << s.length;
    return static_cast<std::int64_t>(u);
  }
  return signals::read(d, s, wire).value_or(0);
}

/// Every signal's value in the message's bytes.
Readings read_wire(const MessageDesc& d, const signals::Wire& wire) {
  Readings r;
  const auto mux = signals::mux_of(d, wire);
  for (std::size_t i = 0; i < d.signals.size(); ++i) {
    const auto& s = d.signals[i];
    r[i] = {signals::present(s, mux), 0, {}};
    if (!r[i].present) continue;
    if (s.kind == Kind::string) {
      r[i].chars = signals::read_string(s, wire.payload).value_or("");
    } else {
      r[i].raw = read_number(d, s, wire);
    }
  }
  return r;
}

// A CRSF or Pride message reaches the formatter without its bytes (the serial decoders hand on the typed message),
// so its fields() give the values, each under the signal whose struct field it is (in the description's order; a
// CRSF subset frame's channels skip the ones it does not carry), turned back into the description's integers
// (exactly: the physical values are the integers' own) and then shown exactly as the bytes would be.
template <class M>
Readings read_fields(const MessageDesc& d, const M& m) {
  Readings r;
  for (std::size_t i = 0; i < d.signals.size(); ++i) r[i] = {false, 0, {}};
  std::size_t next = 0;
  m.fields([&](const char* field, const auto& value) {
    using T = std::decay_t<decltype(value)>;
    std::size_t i = next;
    while (i < d.signals.size() && std::string_view(d.signals[i].field) != field) ++i;
    if (i == d.signals.size()) return;  // never: test_signals.cpp pairs every field with its signal
    next = i + 1;
    const auto& s = d.signals[i];
    Reading& v = r[i];
    v.present = true;
    if constexpr (std::is_same_v<T, const char*>) {
      v.chars = value;
    } else if constexpr (std::is_floating_point_v<T>) {
      v.raw = signals::physical_to_raw(s, static_cast<double>(value));
    } else {
      const auto n = static_cast<std::int64_t>(value);
      v.raw = s.text == Text::physical_int ? signals::physical_to_raw(s, static_cast<double>(n)) : n;
    }
  });
  return r;
}

// ---- what a message's lines repeat, made once per description -----------------------------------------------------

struct Layout {
  std::vector<std::string> text_keys;  ///< " name=" per signal
  std::string type_value;              ///< the message's name as a JSON string
  struct Member {
    std::string prefix;  ///< "\"key\":"
    int signal = -1;     ///< index into the description's signals; -1: "type"
    bool raw = false;    ///< a scaled wire integer's integer (raw_key()), not its physical value
  };
  std::vector<Member> members;  ///< by key, sorted as nlohmann sorts an object
  /// The same without what an MCAP topic says, "type" and the signals of the CAN id (MessageFormat::mcap_json).
  std::vector<Member> mcap_members;
};

Layout make_layout(const MessageDesc& d) {
  if (d.signals.size() > kMaxSignals) throw std::logic_error(fmt::format("{} has more than {} signals", d.name, kMaxSignals));
  Layout l;
  append_json_string(l.type_value, d.name);
  // JSON: "type", every signal's name and, for a scaled wire integer, its raw_key() (unique: test_signals_text.cpp)
  l.members.push_back({"type", -1, false});
  for (std::size_t i = 0; i < d.signals.size(); ++i) {
    const auto& s = d.signals[i];
    l.text_keys.push_back(fmt::format(" {}=", s.name));
    l.members.push_back({s.name, static_cast<int>(i), false});
    if (signals::text_in_unit(s)) l.members.push_back({raw_key(s), static_cast<int>(i), true});
  }
  std::sort(l.members.begin(), l.members.end(), [](const auto& a, const auto& b) { return a.prefix < b.prefix; });
  for (auto& m : l.members) {
    std::string key;
    append_json_string(key, m.prefix);
    m.prefix = key + ':';
  }
  for (const auto& m : l.members)
    if (m.signal >= 0 && d.signals[static_cast<std::size_t>(m.signal)].place != signals::Place::can_id)
      l.mcap_members.push_back(m);
  return l;
}

const Layout& layout_of(const MessageDesc& d) {
  static const auto layouts = [] {  // [protocol][message], made on first use (thread-safe)
    std::array<std::vector<Layout>, std::size(signals::kProtocols)> all;
    for (const auto p : signals::kProtocols)
      for (const auto& m : signals::messages(p)) all[static_cast<std::size_t>(p)].push_back(make_layout(m));
    return all;
  }();
  return layouts[static_cast<std::size_t>(d.protocol)][static_cast<std::size_t>(&d - signals::messages(d.protocol).data())];
}

// ---- the renderer ----------------------------------------------------------------------------------------------------

void write_text(std::string& out, const MessageDesc& d, const Readings& r) {
  const Layout& l = layout_of(d);
  out += d.name;
  for (std::size_t i = 0; i < d.signals.size(); ++i) {
    if (!r[i].present) continue;
    out += l.text_keys[i];
    append_value_text(out, d.signals[i], r[i].raw, r[i].chars);
  }
}

/// `mcap`: without what an MCAP topic says (MessageFormat::mcap_json).
void write_json(std::string& out, const MessageDesc& d, const Readings& r, bool mcap = false) {
  const Layout& l = layout_of(d);
  out += '{';
  bool any = false;
  for (const auto& m : mcap ? l.mcap_members : l.members) {
    const auto i = static_cast<std::size_t>(m.signal);
    if (m.signal >= 0 && !r[i].present) continue;  // a multiplexed signal this frame does not carry
    if (any) out += ',';
    any = true;
    out += m.prefix;
    if (m.signal < 0) {
      out += l.type_value;
    } else if (m.raw) {
      append_int(out, r[i].raw);
    } else if (signals::text_in_unit(d.signals[i])) {
      append_json_physical(out, d.signals[i], r[i].raw);
    } else {
      append_json_value(out, d.signals[i], r[i].raw, r[i].chars);
    }
  }
  out += '}';
}

void write(std::string& out, MessageFormat format, const MessageDesc& d, const Readings& r) {
  if (format == MessageFormat::text) return write_text(out, d, r);
  write_json(out, d, r, format == MessageFormat::mcap_json);
}

SignalValues values_of(const MessageDesc& d, const Readings& r) {
  SignalValues out{&d, {}};
  for (std::size_t i = 0; i < d.signals.size(); ++i)
    if (r[i].present) out.values.push_back({&d.signals[i], r[i].raw, std::string(r[i].chars)});
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

/// with(description, readings) of a message.
template <class With>
auto render(const BusMessage& message, With&& with) {
  const CanFrame f = encode_bus_message(message);
  const MessageDesc& d = *signals::find_can(f.id, f.extended);  // every bus message is described (test_signals)
  return with(d, read_wire(d, signals::Wire{f.id, f.payload()}));
}
template <class With>
auto render(const interboard::Message& message, With&& with) {
  const MessageDesc& d =
      *signals::find(signals::Protocol::interboard, static_cast<std::uint8_t>(interboard::type_of(message)));
  const InterboardWire w = interboard_wire(message);
  return with(d, read_wire(d, w.wire));
}
template <class With>
auto render(const crsf::Message& message, With&& with) {
  const MessageDesc& d = *signals::find(signals::Protocol::crsf, static_cast<std::uint8_t>(crsf::type_of(message)));
  return std::visit([&](const auto& m) { return with(d, read_fields(d, m)); }, message);
}
template <class With>
auto render(const pride::Message& message, With&& with) {
  const MessageDesc& d = *signals::find(signals::Protocol::pride, signals::of_pride::id_of(pride::direction_of(message)));
  return std::visit([&](const auto& m) { return with(d, read_fields(d, m)); }, message);
}

template <class Message>
std::string describe_any(const Message& message) {
  return render(message, [](const MessageDesc& d, const Readings& r) {
    std::string s;
    write_text(s, d, r);
    return s;
  });
}
template <class Message>
nlohmann::json json_any(const Message& message) {
  return render(message, [](const MessageDesc& d, const Readings& r) {
    std::string s;
    write_json(s, d, r);
    return nlohmann::json::parse(s);
  });
}
template <class Message>
SignalValues values_any(const Message& message) {
  return render(message, [](const MessageDesc& d, const Readings& r) { return values_of(d, r); });
}

}  // namespace

void append_message(std::string& out, MessageFormat format, const MessageDesc& message, const signals::Wire& wire) {
  write(out, format, message, read_wire(message, wire));
}

SignalValues signal_values(const BusMessage& message) { return values_any(message); }
SignalValues signal_values(const interboard::Message& message) { return values_any(message); }
SignalValues signal_values(const crsf::Message& message) { return values_any(message); }
SignalValues signal_values(const pride::Message& message) { return values_any(message); }
std::string describe(const BusMessage& message) { return describe_any(message); }
std::string describe(const interboard::Message& message) { return describe_any(message); }
std::string describe(const crsf::Message& message) { return describe_any(message); }
std::string describe(const pride::Message& message) { return describe_any(message); }
nlohmann::json to_json(const BusMessage& message) { return json_any(message); }
nlohmann::json to_json(const interboard::Message& message) { return json_any(message); }
nlohmann::json to_json(const crsf::Message& message) { return json_any(message); }
nlohmann::json to_json(const pride::Message& message) { return json_any(message); }

}  // namespace saul::host
