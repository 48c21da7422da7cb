#include "saulproto/host/report/format.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
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

// ---- values, written at a char pointer with room for them (Layout::max_chars) ---------------------------------------

char* put_int(char* w, std::int64_t v) { return std::to_chars(w, w + 24, v).ptr; }

// The unit as text shows it: the descriptions' ASCII units as their symbols.
std::string_view unit_symbol(std::string_view unit) {
  if (unit == "deg") return "\u00B0";       // °
  if (unit == "degC") return "\u00B0C";     // °C
  if (unit == "us") return "\u00B5s";       // µs
  return unit;
}

/// fmt's "{:g}" of raw / den (den a power of ten up to 10^4) written as the exact decimal when it has at most 6
/// significant digits and lies in [1e-4, 1e6), as %g then prints it; nullptr (nothing written) otherwise.
char* put_decimal_g(char* w, std::int64_t raw, std::int32_t den) {
  int places = 0;
  for (std::int32_t d = den; d > 1; d /= 10) {
    if (d % 10 != 0) return nullptr;
    ++places;
  }
  if (places > 4 || raw <= -1'000'000'000'000LL || raw >= 1'000'000'000'000LL) return nullptr;
  std::uint64_t v = raw < 0 ? static_cast<std::uint64_t>(-raw) : static_cast<std::uint64_t>(raw);
  if (v == 0) return put_chars(w, "0");
  if (v / static_cast<std::uint64_t>(den) >= 1'000'000) return nullptr;
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
  if (significant > 6) return nullptr;
  if (raw < 0) *w++ = '-';
  if (n <= places) {
    w = put_chars(w, "0.");
    w = std::fill_n(w, places - n, '0');
    return put_chars(w, std::string_view(digits, static_cast<std::size_t>(n)));
  }
  w = put_chars(w, std::string_view(digits, static_cast<std::size_t>(n - places)));
  if (places > 0) *w++ = '.';
  return put_chars(w, std::string_view(digits + n - places, static_cast<std::size_t>(places)));
}

}  // namespace

std::string raw_key(const signals::SignalDesc& s) { return std::string(s.name) + "_raw"; }

std::string csv_quote(std::string_view s) {
  bool plain = true;
  for (char c : s) plain = plain && c != ',' && c != '"' && c != '\n';  // (find_first_of: a memchr per character)
  if (plain) return std::string(s);
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + '"';
}

std::string c_literal(std::string_view s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c == '\n' ? std::string_view("\\n") : std::string_view(&c, 1);
  }
  return out + '"';
}

namespace {

/// append_json_string() at w (room for 6 characters per byte of s, and 2).
char* put_json_string(char* w, std::string_view s) {
  bool plain = true;  // printable ASCII without '"' or '\\': copied as it is (nearly always)
  for (char c : s) plain = plain && c >= 0x20 && c <= 0x7E && c != '"' && c != '\\';
  if (!plain) return put_chars(w, json_line(nlohmann::json(std::string(s))));
  *w++ = '"';
  w = put_chars(w, s);
  *w++ = '"';
  return w;
}

}  // namespace

void append_json_string(std::string& out, std::string_view s) {
  const std::size_t at = out.size();
  out.resize(at + 6 * s.size() + 2);
  out.resize(static_cast<std::size_t>(put_json_string(out.data() + at, s) - out.data()));
}

namespace {

// ---- the JSON values, as nlohmann writes numbers -----------------------------------------------------------------

char* put_json_double(char* w, double x) {
  if (!std::isfinite(x)) return put_chars(w, "null");
  return nlohmann::detail::to_chars(w, w + 64, x);
}

/// A scaled wire integer's physical value (signals::text_in_unit), exact in integers for a decimal resolution
/// (1234 x 1/100 -> "12.34"), whole units rounded down otherwise: as text with its unit or, `Json`, as JSON holds
/// it (the double nearest to the decimal text, or an integer where text shows whole units).
template <bool Json>
char* put_physical(char* w, const signals::SignalDesc& s, std::int64_t raw) {
  const int k = signals::text_decimals(s);
  if (k < 0) {
    w = put_int(w, static_cast<std::int64_t>(std::floor(signals::raw_to_physical(s, raw))));
    return Json ? w : put_chars(w, unit_symbol(s.unit));
  }
  std::int64_t ten_k = 1;  // the physical value times 10^k, exact in integers
  for (int i = 0; i < k; ++i) ten_k *= 10;
  const std::int64_t scaled =
      raw * (std::int64_t{s.scale_num} * ten_k / s.scale_den) + std::llround(s.offset * static_cast<double>(ten_k));
  if constexpr (Json) {  // both exact in a double (|scaled| < 2^53): the division is the double nearest to the text
    return k == 0 ? put_int(w, scaled) : put_json_double(w, static_cast<double>(scaled) / static_cast<double>(ten_k));
  }
  const std::uint64_t magnitude = scaled < 0 ? 0 - static_cast<std::uint64_t>(scaled) : static_cast<std::uint64_t>(scaled);
  if (scaled < 0) *w++ = '-';
  w = std::to_chars(w, w + 24, magnitude / static_cast<std::uint64_t>(ten_k)).ptr;
  if (k > 0) {  // the fraction, k digits with its leading zeros
    *w++ = '.';
    auto frac = magnitude % static_cast<std::uint64_t>(ten_k);
    for (int i = k - 1; i >= 0; --i, frac /= 10) w[i] = static_cast<char>('0' + frac % 10);
    w += k;
  }
  return put_chars(w, unit_symbol(s.unit));
}

/// A signal's value as text shows it (write_value_text()) or, `Json`, as JSON holds it.
template <bool Json>
char* put_value(char* w, const signals::SignalDesc& s, std::int64_t raw, std::string_view chars) {
  const auto string = [w](std::string_view v) { return Json ? put_json_string(w, v) : put_chars(w, v); };
  const auto real = [w](auto x) {  // (a float32 as text: fmt's {:g} of the float)
    return Json ? put_json_double(w, static_cast<double>(x)) : fmt::format_to(w, FMT_COMPILE("{:g}"), x);
  };
  if (s.kind == Kind::string) return string(chars);
  if (signals::text_in_unit(s)) return put_physical<Json>(w, s, raw);
  switch (s.text) {
    case Text::raw:
      if (s.kind == Kind::float32) return real(std::bit_cast<float>(static_cast<std::uint32_t>(raw)));
      return put_int(w, raw);
    case Text::name:
      if (const char* name = signals::value_name(s, raw)) return string(name);
      return put_int(w, raw);
    case Text::physical:
      if (!Json && s.kind != Kind::float32 && s.scale_num == 1 && s.offset == 0)
        if (char* end = put_decimal_g(w, raw, s.scale_den)) return end;
      return real(signals::raw_to_physical(s, raw));
    case Text::physical_int: return put_int(w, std::llround(signals::raw_to_physical(s, raw)));
  }
  return put_int(w, raw);
}

// ---- a message's values, read once --------------------------------------------------------------------------------

/// The most characters a message's text or JSON may take (Layout::max_chars), for the renderer's stack buffer.
constexpr std::size_t kMaxChars = 16384;
/// The most signals a message has (the CRSF subset RC channels: 3 + 32); layout_of() holds every description to it.
constexpr std::size_t kMaxSignals = 35;

/// The value of each signal of a message (present: the frame carries it). Only the message's own signals are set,
/// not all kMaxSignals.
struct Reading {
  bool present;
  std::int64_t raw;
  const char* chars;  ///< a string signal's characters, chars_size of them (not a string_view, whose constructor
  std::size_t chars_size;  ///< would initialise all kMaxSignals Readings of a message that has a few signals)
  [[nodiscard]] std::string_view text() const { return {chars, chars_size}; }
};
using Readings = std::array<Reading, kMaxSignals>;

/// Every signal's value in the message's bytes.
Readings read_wire(const MessageDesc& d, const signals::Wire& wire) {
  Readings r;
  const auto mux = signals::mux_of(d, wire);
  for (std::size_t i = 0; i < d.signals.size(); ++i) {
    const auto& s = d.signals[i];
    const std::string_view chars = s.kind == Kind::string ? signals::read_string(s, wire.payload).value_or("") : "";
    r[i] = {signals::present(s, mux), 0, chars.data(), chars.size()};
    if (!r[i].present || s.kind == Kind::string) continue;
    // signals::read(), with payload signals straight to read_raw (fewer registers live in this loop: 1/3 faster)
    const bool in_payload = s.place == signals::Place::payload;
    r[i].raw = (in_payload ? signals::read_raw(s, wire.payload) : signals::read(d, s, wire)).value_or(0);
  }
  return r;
}

// A CRSF or Pride message comes without its bytes: its fields() give the values, each under the signal whose struct
// field it is (in order; a CRSF subset frame skips channels), turned back exactly into the description's integers.
template <class M>
Readings read_fields(const MessageDesc& d, const M& m) {
  Readings r;
  for (std::size_t i = 0; i < d.signals.size(); ++i) r[i] = {false, 0, nullptr, 0};
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
      v.chars_size = std::strlen(value);
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
  std::string name;                    ///< the message's name (its length known)
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
  std::size_t max_chars = 0;  ///< the most characters write() writes, in any format
};

Layout make_layout(const MessageDesc& d) {
  if (d.signals.size() > kMaxSignals) throw std::logic_error(fmt::format("{} has more than {} signals", d.name, kMaxSignals));
  Layout l;
  l.name = d.name;
  append_json_string(l.type_value, d.name);
  l.max_chars = 2 * l.type_value.size() + 16;
  // JSON: "type", every signal's name and, for a scaled wire integer, its raw_key() (unique: test_signals_text.cpp)
  l.members.push_back({"type", -1, false});
  for (std::size_t i = 0; i < d.signals.size(); ++i) {
    const auto& s = d.signals[i];
    l.text_keys.push_back(fmt::format(" {}=", s.name));
    l.members.push_back({s.name, static_cast<int>(i), false});
    if (signals::text_in_unit(s)) l.members.push_back({raw_key(s), static_cast<int>(i), true});
    // a value: a number (64 covers them all, with a unit), a JSON string of 6 characters per byte, or a name
    std::size_t value = s.kind == Kind::string ? 6u * s.length + 2 : 64;
    for (const auto& v : s.values) value = std::max(value, 6 * std::strlen(v.name) + 2);
    l.max_chars += l.text_keys.back().size() + 2 * (value + 8 + std::strlen(s.name));  // text, and JSON's 1-2 keys
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
  if (l.max_chars > kMaxChars) throw std::logic_error(fmt::format("{} may take more than {} characters", d.name, kMaxChars));
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

char* write_text(char* w, const MessageDesc& d, const Readings& r) {
  const Layout& l = layout_of(d);
  w = put_chars(w, l.name);
  for (std::size_t i = 0; i < d.signals.size(); ++i) {
    if (!r[i].present) continue;
    w = put_chars(w, l.text_keys[i]);
    w = put_value<false>(w, d.signals[i], r[i].raw, r[i].text());
  }
  return w;
}

/// `mcap`: without what an MCAP topic says (MessageFormat::mcap_json).
char* write_json(char* w, const MessageDesc& d, const Readings& r, bool mcap = false) {
  const Layout& l = layout_of(d);
  *w++ = '{';
  bool any = false;
  for (const auto& m : mcap ? l.mcap_members : l.members) {
    const auto i = static_cast<std::size_t>(m.signal);
    if (m.signal >= 0 && !r[i].present) continue;  // a multiplexed signal this frame does not carry
    if (any) *w++ = ',';
    any = true;
    w = put_chars(w, m.prefix);
    if (m.signal < 0) {
      w = put_chars(w, l.type_value);
    } else if (m.raw) {
      w = put_int(w, r[i].raw);
    } else {
      w = put_value<true>(w, d.signals[i], r[i].raw, r[i].text());
    }
  }
  *w++ = '}';
  return w;
}

/// What write(w) writes (at most kMaxChars), as a string.
template <class Write>
std::string written(Write&& write) {
  std::array<char, kMaxChars> text;
  return std::string(text.data(), write(text.data()));
}

SignalValues values_of(const MessageDesc& d, const Readings& r) {
  SignalValues out{&d, {}};
  for (std::size_t i = 0; i < d.signals.size(); ++i)
    if (r[i].present) out.values.push_back({&d.signals[i], r[i].raw, std::string(r[i].text())});
  return out;
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
  // its wire bytes: the payload of the frame its encoder writes
  std::array<std::uint8_t, interboard::kMaxFrameSize> frame{};
  const auto n = interboard::encode(message, frame);
  const std::size_t size = n ? n.value() : interboard::kOverhead;
  return with(d, read_wire(d, {0, std::span<const std::uint8_t>(frame).subspan(3, size - interboard::kOverhead)}));
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

// What describe() and to_json() render() of a message's readings.
std::string text_of(const MessageDesc& d, const Readings& r) {
  return written([&](char* w) { return write_text(w, d, r); });
}
nlohmann::json json_of(const MessageDesc& d, const Readings& r) {
  return nlohmann::json::parse(written([&](char* w) { return write_json(w, d, r); }));
}

}  // namespace

char* write_value_text(char* w, const signals::SignalDesc& s, std::int64_t raw, std::string_view chars) {
  return put_value<false>(w, s, raw, chars);
}

std::size_t message_chars_max(const MessageDesc& message) { return layout_of(message).max_chars; }

char* write_message(char* w, MessageFormat format, const MessageDesc& message, const signals::Wire& wire) {
  const Readings r = read_wire(message, wire);
  if (format == MessageFormat::text) return write_text(w, message, r);
  return write_json(w, message, r, format == MessageFormat::mcap_json);
}

void append_message(std::string& out, MessageFormat format, const MessageDesc& message, const signals::Wire& wire) {
  std::array<char, kMaxChars> text;  // (written on the stack: no room in `out` zeroed first)
  out.append(text.data(), write_message(text.data(), format, message, wire));
}

SignalValues signal_values(const BusMessage& message) { return render(message, values_of); }
SignalValues signal_values(const interboard::Message& message) { return render(message, values_of); }
SignalValues signal_values(const crsf::Message& message) { return render(message, values_of); }
SignalValues signal_values(const pride::Message& message) { return render(message, values_of); }
std::string describe(const BusMessage& message) { return render(message, text_of); }
std::string describe(const interboard::Message& message) { return render(message, text_of); }
std::string describe(const crsf::Message& message) { return render(message, text_of); }
std::string describe(const pride::Message& message) { return render(message, text_of); }
nlohmann::json to_json(const BusMessage& message) { return render(message, json_of); }
nlohmann::json to_json(const interboard::Message& message) { return render(message, json_of); }
nlohmann::json to_json(const crsf::Message& message) { return render(message, json_of); }
nlohmann::json to_json(const pride::Message& message) { return render(message, json_of); }

}  // namespace saul::host
