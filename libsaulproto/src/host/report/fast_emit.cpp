#include "saulproto/host/report/fast_emit.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/frame_key.hpp"

namespace saul::host {
namespace {

using signals::Kind;
using signals::MessageDesc;
using signals::SignalDesc;
using signals::Text;

enum Outcome : std::uint8_t { kDecoded, kUnknown, kRejected, kErrorFrame };

constexpr char kHex[] = "0123456789ABCDEF";

template <class Buffer>
void put(Buffer& out, std::string_view s) {
  out.append(s.data(), s.data() + s.size());
}
void put(std::string& out, std::string_view s) { out.append(s); }

template <class Buffer, class Int>
void put_int(Buffer& out, Int v) {
  char tmp[24];
  const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
  put(out, std::string_view(tmp, static_cast<std::size_t>(r.ptr - tmp)));
}

/// v right-aligned in `width` characters, padded with `fill` (fmt's "{:010}" and "{:4}" for unsigned values).
void put_padded(fmt::memory_buffer& out, std::uint64_t v, std::size_t width, char fill) {
  char tmp[24];
  const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
  const auto n = static_cast<std::size_t>(r.ptr - tmp);
  for (std::size_t i = n; i < width; ++i) out.push_back(fill);
  out.append(tmp, r.ptr);
}

// ---- JSON values, as format.cpp's json_of() writes them (text values: format.cpp's append_value_text) -----------------------------------------------

/// A JSON string as nlohmann's dump() writes it (printable ASCII copied; anything else through nlohmann).
void json_string(std::string& out, std::string_view s) {
  bool plain = true;
  for (char c : s)
    if (c < 0x20 || c > 0x7E || c == '"' || c == '\\') plain = false;
  if (!plain) {
    out += json_line(nlohmann::json(std::string(s)));
    return;
  }
  out += '"';
  out.append(s);
  out += '"';
}

void json_double(std::string& out, double x) {
  if (!std::isfinite(x)) {
    out += "null";
    return;
  }
  char tmp[64];
  char* end = nlohmann::detail::to_chars(tmp, tmp + sizeof tmp, x);
  out.append(tmp, static_cast<std::size_t>(end - tmp));
}

void json_value(std::string& out, const SignalDesc& s, std::int64_t raw, std::string_view chars) {
  if (s.kind == Kind::string) return json_string(out, chars);
  switch (s.text) {
    case Text::raw:
      if (s.kind == Kind::float32)
        return json_double(out, static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(raw))));
      return put_int(out, raw);
    case Text::name:
      if (const char* name = signals::value_name(s, raw)) return json_string(out, name);
      return put_int(out, raw);
    case Text::physical: return json_double(out, signals::raw_to_physical(s, raw));
    case Text::physical_int:
      return put_int(out, static_cast<std::int64_t>(std::llround(signals::raw_to_physical(s, raw))));
  }
  put_int(out, raw);
}

/// signals::read(...).value_or(0), with whole bytes in the payload read a byte at a time.
std::int64_t read_number(const MessageDesc& d, const SignalDesc& s, const signals::Wire& wire) {
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

/// One signal's value as the description reads it from the (re-encoded) frame.
struct Read {
  bool present = false;
  std::int64_t raw = 0;
  std::string_view chars;
};
Read read_signal(const MessageDesc& d, const SignalDesc& s, const signals::Wire& wire,
                 std::optional<std::int64_t> mux) {
  Read r;
  if (!signals::present(s, mux)) return r;
  r.present = true;
  if (s.kind == Kind::string) {
    r.chars = signals::read_string(s, wire.payload).value_or("");
  } else {
    r.raw = read_number(d, s, wire);
  }
  return r;
}

/// The candump frame text ("300#E8030CFE"), as format_candump_frame writes it.
void frame_text(std::string& out, const CanFrame& f) {
  char t[32];
  std::size_t n = 0;
  const bool wide = f.error || f.extended;
  const std::uint32_t id = f.error ? (f.id | 0x2000'0000U) : f.id;
  for (int shift = wide ? 28 : 8; shift >= 0; shift -= 4) t[n++] = kHex[(id >> shift) & 0xF];
  t[n++] = '#';
  if (f.remote) {
    t[n++] = 'R';
    if (f.dlc) t[n++] = static_cast<char>('0' + f.dlc);
  } else {
    for (std::uint8_t b : f.payload()) {
      t[n++] = kHex[b >> 4];
      t[n++] = kHex[b & 0xF];
    }
  }
  out.append(t, n);
}

const char* bool_text(bool b) { return b ? "true" : "false"; }

}  // namespace

std::string csv_quote(const std::string& s) {
  bool plain = true;
  for (char c : s) plain = plain && c != ',' && c != '"';  // (find_first_of calls memchr once per character)
  if (plain) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + '"';
}

std::string reference_frame_line(DecodeFormat format, std::string_view time_column, std::string_view interface,
                                 const CanFrame& f, bool error_detail) {
  error_detail = error_detail && f.error;
  const auto result = decode_bus_frame(f);
  const std::string_view bare = time_column.substr(1, time_column.size() - 2);
  if (format == DecodeFormat::jsonl) {
    nlohmann::json j;
    j["time"] = bare;
    j["interface"] = interface;
    j["frame"] = frame_to_json(f);
    if (result) {
      j["message"] = to_json(result.value());
    } else {
      j["error"] = to_string(result.reason());
      if (error_detail) j["error_detail"] = describe_error_frame(f);
    }
    return json_line(j);
  }
  if (format == DecodeFormat::csv) {
    std::string name = result ? saul::name_of(result.value()) : std::string("!") + to_string(result.reason());
    std::string fields;
    if (result) {
      fields = describe(result.value());
      fields = fields.substr(std::min(fields.size(), name.size() + 1));
    }
    const std::string raw = format_candump_frame(f);
    return fmt::format("{},{},{:X},{},{},{},{},{},{}", bare, csv_quote(std::string(interface)), f.id, f.extended ? 1 : 0, f.remote ? 1 : 0,
                       f.dlc, raw.substr(raw.find('#') + 1), name, csv_quote(fields));
  }
  std::string what = result ? describe(result.value()) : std::string("!") + to_string(result.reason());
  if (error_detail) what += " " + describe_error_frame(f);
  return fmt::format("{} {} {:<24} {}", time_column, candump_interface(interface), format_candump_frame(f), what);
}

FrameEmitter::FrameEmitter(DecodeFormat format, TimeMode time) : format_(format), time_(time), cache_(1024) {}
FrameEmitter::~FrameEmitter() = default;

void FrameEmitter::time_column(std::uint64_t ns, fmt::memory_buffer& out, bool parens) {
  const std::size_t at = out.size();
  out.resize(at + kTimeColumnMax);
  out.resize(static_cast<std::size_t>(time_chars(ns, out.data() + at, parens) - out.data()));
}

char* FrameEmitter::time_chars(std::uint64_t ns, char* w, bool parens) {
  // "({:010}.{:06})" absolute, "({:>4}.{:06})" relative or delta, as TimeColumn writes it: a time before the first
  // frame's (relative) or the previous one's (delta: the log's times went back) is negative, "(  -0.050000)".
  if (!first_) first_ = ns;
  std::uint64_t shown = ns;
  bool negative = false;
  if (time_ != TimeMode::absolute) {
    const std::uint64_t from = time_ == TimeMode::relative ? *first_ : previous_.value_or(ns);
    negative = ns < from;
    shown = negative ? from - ns : ns - from;
  }
  previous_ = ns;
  const std::uint64_t sec = shown / 1'000'000'000ULL;
  auto usec = static_cast<std::uint32_t>((shown % 1'000'000'000ULL) / 1000);
  if (!seconds_valid_ || sec != seconds_ || negative != seconds_negative_) {  // the same for thousands of frames
    fmt::memory_buffer s;
    if (time_ == TimeMode::absolute) {
      put_padded(s, sec, 10, '0');
    } else {
      fmt::memory_buffer digits;
      if (negative) digits.push_back('-');
      put_padded(digits, sec, 0, ' ');
      for (std::size_t i = digits.size(); i < 4; ++i) s.push_back(' ');
      s.append(digits.data(), digits.data() + digits.size());
    }
    s.push_back('.');
    seconds_text_.assign(s.data(), s.size());
    seconds_ = sec;
    seconds_negative_ = negative;
    seconds_valid_ = true;
  }
  if (parens) *w++ = '(';
  std::memcpy(w, seconds_text_.data(), seconds_text_.size());
  w += seconds_text_.size();
  for (int i = 5; i >= 0; --i) {
    w[i] = static_cast<char>('0' + usec % 10);
    usec /= 10;
  }
  w += 6;
  if (parens) *w++ = ')';
  return w;
}

char* FrameEmitter::stamp_chars(std::uint64_t ns, char* w) {
  const std::uint64_t sec = ns / 1'000'000'000ULL;
  auto rest = static_cast<std::uint32_t>(ns % 1'000'000'000ULL);
  if (sec == 0) return std::to_chars(w, w + kTimeColumnMax, rest).ptr;
  if (!stamp_valid_ || sec != stamp_seconds_) {
    stamp_text_.clear();
    put_int(stamp_text_, sec);
    stamp_seconds_ = sec;
    stamp_valid_ = true;
  }
  std::memcpy(w, stamp_text_.data(), stamp_text_.size());
  w += stamp_text_.size();
  for (int i = 8; i >= 0; --i) {
    w[i] = static_cast<char>('0' + rest % 10);
    rest /= 10;
  }
  return w + 9;
}

const FrameEmitter::Layout& FrameEmitter::layout(const MessageDesc& d) {
  for (const auto& l : layouts_)
    if (l.desc == &d) return l;
  Layout l;
  l.desc = &d;
  l.name = d.name;
  json_string(l.type_value, d.name);
  // As describe_values() in format.cpp: a value shown in its unit is named by the signal's name.
  for (const auto& s : d.signals)
    l.text_keys.push_back(std::string(" ") + (signals::text_in_unit(s) ? s.name : s.key) + "=");
  // JSON: nlohmann's objects are sorted by key; equal keys (and "type") form one group, in the order json_values()
  // in format.cpp sets them: "type", then per signal its key and, for a scaled one, its physical key.
  struct Keyed {
    std::string key;
    Layout::Member member;
  };
  std::vector<Keyed> keyed{{"type", {}}};
  for (std::size_t i = 0; i < d.signals.size(); ++i) {
    const auto& s = d.signals[i];
    keyed.push_back({s.key, {static_cast<int>(i), false}});
    if (signals::text_in_unit(s)) keyed.push_back({physical_key(s), {static_cast<int>(i), true}});
  }
  std::stable_sort(keyed.begin(), keyed.end(), [](const Keyed& a, const Keyed& b) { return a.key < b.key; });
  for (std::size_t k = 0; k < keyed.size(); ++k) {
    if (k == 0 || keyed[k].key != keyed[k - 1].key) {
      l.groups.emplace_back();
      json_string(l.groups.back().prefix, keyed[k].key);
      l.groups.back().prefix += ':';
    }
    l.groups.back().members.push_back(keyed[k].member);
  }
  layouts_.push_back(std::move(l));
  return layouts_.back();
}

// The message part of the line from the description of the re-encoded frame (exactly what signal_values() reads):
// text "name k=v ...", CSV "name,fields", JSON {"k":v,...,"type":"name"} with nlohmann's sorted keys. False when
// the message has no description.
bool FrameEmitter::render_message(const CanFrame& g, std::string& out) {
  const MessageDesc* d = signals::find_can(g.id, g.extended);
  if (d == nullptr) return false;
  const signals::Wire wire{g.id, g.payload()};
  const auto mux = signals::mux_of(*d, wire);
  if (format_ == DecodeFormat::jsonl) {
    const Layout& l = layout(*d);
    out += '{';
    bool any = false;
    for (const auto& group : l.groups) {
      // Equal keys: the last one present wins, as with repeated j[key] = ... in description order.
      const Layout::Member* chosen = nullptr;
      Read value;
      for (const auto& m : group.members) {
        if (m.signal < 0) {
          chosen = &m;
          continue;
        }
        Read r = read_signal(*d, d->signals[static_cast<std::size_t>(m.signal)], wire, mux);
        if (r.present) {
          chosen = &m;
          value = r;
        }
      }
      if (chosen == nullptr) continue;
      if (any) out += ',';
      any = true;
      out += group.prefix;
      if (chosen->signal < 0) {
        out += l.type_value;
        continue;
      }
      const SignalDesc& s = d->signals[static_cast<std::size_t>(chosen->signal)];
      if (!chosen->physical) {
        json_value(out, s, value.raw, value.chars);
      } else if (const PhysicalNumber n = physical_number(s, value.raw); n.integral) {
        put_int(out, n.whole);
      } else {
        json_double(out, n.value);
      }
    }
    out += '}';
    return true;
  }
  // text and CSV: "name key=value ..." (CSV: the name, a comma, then the rest quoted when it needs it)
  const Layout& l = layout(*d);
  out += l.name;
  const std::size_t fields_at = out.size();
  for (std::size_t i = 0; i < d->signals.size(); ++i) {
    const SignalDesc& s = d->signals[i];
    const Read r = read_signal(*d, s, wire, mux);
    if (!r.present) continue;
    out += l.text_keys[i];
    append_value_text(out, s, r.raw, r.chars);
  }
  if (format_ == DecodeFormat::csv) {
    // "name,fields": the space after the name becomes the comma when the fields need no quotes (nearly always)
    bool plain = true;  // (find_first_of would call memchr once per character)
    for (std::size_t i = fields_at; i < out.size(); ++i) plain = plain && out[i] != ',' && out[i] != '"';
    if (out.size() == fields_at) {
      out += ',';
    } else if (plain) {
      out[fields_at] = ',';
    } else {
      const std::string fields = out.substr(fields_at + 1);
      out.resize(fields_at);
      out += ',';
      out += csv_quote(fields);
    }
  }
  return true;
}

void FrameEmitter::render(const CanFrame& f, Entry& e) {
  std::string& out = e.text;
  out.clear();
  const auto result = decode_bus_frame(f);
  if (result) {
    e.outcome = kDecoded;
  } else if (result.reason() == Reason::unknown_id) {
    e.outcome = kUnknown;
  } else if (result.reason() == Reason::error_frame) {
    e.outcome = kErrorFrame;
  } else {
    e.outcome = kRejected;
  }
  const char* name = result ? saul::name_of(result.value()) : nullptr;
  const std::string failure = result ? std::string() : std::string("!") + to_string(result.reason());
  switch (format_) {
    case DecodeFormat::text: {
      // "{:<24} {what}"
      frame_text(out, f);
      if (out.size() < 24) out.append(24 - out.size(), ' ');
      out += ' ';
      if (!result) {
        out += failure;
      } else if (!render_message(encode_bus_message(result.value()), out)) {
        out += describe(result.value());
      }
      break;
    }
    case DecodeFormat::csv: {
      // "{id:X},{ext},{remote},{dlc},{data},{name},{fields}"
      fmt::format_to(std::back_inserter(out), FMT_COMPILE("{:X},{},{},{},"), f.id, f.extended ? 1 : 0,
                     f.remote ? 1 : 0, f.dlc);
      const std::size_t at = out.size();
      frame_text(out, f);
      out.erase(at, out.find('#', at) + 1 - at);
      out += ',';
      if (!result) {
        out += failure;
        out += ',';
      } else if (!render_message(encode_bus_message(result.value()), out)) {
        std::string fields = describe(result.value());
        fields = fields.substr(std::min(fields.size(), std::string_view(name).size() + 1));
        out += name;
        out += ',';
        out += csv_quote(fields);
      }
      break;
    }
    case DecodeFormat::jsonl: {
      // {["error":"reason",]"frame":{"data":..,"remote":b  SPLIT  [,"message":{...}]
      out += '{';
      if (!result) {
        out += "\"error\":";
        json_string(out, to_string(result.reason()));
        out += ',';
      }
      out += "\"frame\":{\"data\":\"";
      char hex[16];
      std::size_t n = 0;
      for (std::uint8_t b : f.payload()) {
        hex[n++] = kHex[b >> 4];
        hex[n++] = kHex[b & 0xF];
      }
      out.append(hex, n);
      out += "\",\"dlc\":";
      put_int(out, unsigned{f.dlc});
      out += ",\"error\":";
      out += bool_text(f.error);
      out += ",\"extended\":";
      out += bool_text(f.extended);
      out += ",\"id\":";
      put_int(out, f.id);
      out += ",\"remote\":";
      out += bool_text(f.remote);
      e.text.push_back('\0');  // the split: the timestamp and the interface go here
      if (result) {
        out += ",\"message\":";
        message_json(result.value(), out);
      }
      break;
    }
  }
}

void FrameEmitter::message_json(const BusMessage& message, std::string& out) {
  if (!render_message(encode_bus_message(message), out)) out += json_line(to_json(message));
}

const FrameEmitter::Entry& FrameEmitter::rendered(const CanFrame& f) {
  const FrameKey key = frame_key(f);
  Entry& e = cache_[key.slot(cache_.size())];
  if (!e.used || e.k1 != key.k1 || e.k2 != key.k2) {
    e.used = true;
    e.k1 = key.k1;
    e.k2 = key.k2;
    render(f, e);
    if (format_ == DecodeFormat::jsonl) e.split = e.text.find('\0');
  }
  return e;
}

void FrameEmitter::add(const CanFrame& f, std::string_view interface, fmt::memory_buffer& out, DecodeCounts& counts) {
  const Entry& e = rendered(f);
  ++counts.frames;
  switch (e.outcome) {
    case kDecoded: ++counts.decoded; break;
    case kUnknown: ++counts.unknown; break;
    case kErrorFrame: ++counts.errors; break;
    default: ++counts.rejected; break;
  }
  const std::uint64_t ns = f.timestamp_ns.value_or(0);
  const bool text = format_ == DecodeFormat::text;
  if (text && interface.empty()) interface = "can0";
  if (interface != interface_) {
    interface_.assign(interface);
    interface_column_ = interface_;
    interface_plain_ = true;
    for (char& c : interface_column_) {
      // text: spaces and controls as '_', as candump's column; JSON: escapes are nlohmann's (reference_frame_line)
      if (text && (static_cast<unsigned char>(c) <= 0x20 || c == 0x7F)) c = '_';
      if (c < 0x20 || c > 0x7E || c == '"' || c == '\\') interface_plain_ = false;
    }
    if (format_ == DecodeFormat::csv) interface_column_ = csv_quote(interface_);  // a ',' or '"' in a name
  }
  // One line in one go: room for all of it, then written in place (no append per column).
  const std::size_t at = out.size();
  out.resize(at + 2 * kTimeColumnMax + interface_column_.size() + e.text.size() + 64);
  char* w = out.data() + at;
  auto copy = [&w](std::string_view s) {
    std::memcpy(w, s.data(), s.size());
    w += s.size();
  };
  if ((format_ == DecodeFormat::jsonl && !interface_plain_) || (f.error && error_detail_)) {
    // JSON escapes (or invalid UTF-8, which nlohmann refuses), or an error frame's detail: the reference does it
    out.resize(at);
    fmt::memory_buffer column;
    time_column(ns, column, true);
    put(out, reference_frame_line(format_, std::string_view(column.data(), column.size()), interface, f,
                                  error_detail_));
    out.push_back('\n');
    return;
  }
  if (format_ == DecodeFormat::jsonl) {
    const std::string_view line = e.text;  // ...,"remote":b  \0  [,"message":{...}]
    copy(line.substr(0, e.split));
    if (f.timestamp_ns) {
      copy(",\"timestamp_ns\":");
      w = stamp_chars(*f.timestamp_ns, w);
    }
    copy("},\"interface\":\"");
    copy(interface_column_);
    *w++ = '"';
    copy(line.substr(e.split + 1));
    copy(",\"time\":\"");
    w = time_chars(ns, w, false);
    copy("\"}");
  } else {
    w = time_chars(ns, w, text);
    *w++ = text ? ' ' : ',';
    copy(interface_column_);
    *w++ = text ? ' ' : ',';
    copy(e.text);
  }
  *w++ = '\n';
  out.resize(static_cast<std::size_t>(w - out.data()));
}

}  // namespace saul::host
