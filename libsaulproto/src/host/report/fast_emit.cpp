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

FrameEmitter::FrameEmitter(DecodeFormat format, TimeMode time) : format_(format), time_(time), cache_(1024) {}
FrameEmitter::~FrameEmitter() = default;

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

// The message part of the line: text "name k=v ...", CSV "name,fields", JSON {"k":v,...,"type":"name"}, from the
// frame's bytes (a frame that decodes carries exactly the values its message holds).
void FrameEmitter::render_message(const CanFrame& f, std::string& out) {
  const signals::MessageDesc& d = *signals::find_can(f.id, f.extended);  // it decoded: it is described
  const std::size_t fields_at = out.size() + std::strlen(d.name);
  append_message(out, format_ == DecodeFormat::jsonl ? MessageFormat::json : MessageFormat::text, d,
                 signals::Wire{f.id, f.payload()});
  if (format_ != DecodeFormat::csv) return;
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
  // What an error frame reports, when asked (sniff): "!error_frame bus-off", or an "error_detail" member.
  const std::string detail = f.error && error_detail_ ? describe_error_frame(f) : std::string();
  switch (format_) {
    case DecodeFormat::text: {
      // "{:<24} {what}"
      frame_text(out, f);
      if (out.size() < 24) out.append(24 - out.size(), ' ');
      out += ' ';
      if (result) {
        render_message(f, out);
      } else {
        out += '!';
        out += to_string(result.reason());
      }
      if (!detail.empty()) out += ' ' + detail;
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
      if (result) {
        render_message(f, out);
      } else {
        out += '!';
        out += to_string(result.reason());
        out += ',';
      }
      break;
    }
    case DecodeFormat::jsonl: {
      // {["error":"reason",["error_detail":"...",]]"frame":{"data":..,"remote":b  SPLIT  [,"message":{...}]
      out += '{';
      if (!result) {
        out += "\"error\":";
        append_json_string(out, to_string(result.reason()));
        out += ',';
        if (!detail.empty()) {
          out += "\"error_detail\":";
          append_json_string(out, detail);
          out += ',';
        }
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
        render_message(f, out);
      }
      break;
    }
  }
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
    interface_column_.clear();
    if (format_ == DecodeFormat::jsonl) {
      append_json_string(interface_column_, interface_);  // with its quotes
    } else if (format_ == DecodeFormat::csv) {
      interface_column_ = csv_quote(interface_);  // a ',' or '"' in a name
    } else {
      interface_column_ = candump_interface(interface_);  // spaces and controls as '_', as candump's column
    }
  }
  // One line in one go: room for all of it, then written in place (no append per column).
  const std::size_t at = out.size();
  out.resize(at + 2 * kTimeColumnMax + interface_column_.size() + e.text.size() + 64);
  char* w = out.data() + at;
  auto copy = [&w](std::string_view s) {
    std::memcpy(w, s.data(), s.size());
    w += s.size();
  };
  if (format_ == DecodeFormat::jsonl) {
    const std::string_view line = e.text;  // ...,"remote":b  \0  [,"message":{...}]
    copy(line.substr(0, e.split));
    if (f.timestamp_ns) {
      copy(",\"timestamp_ns\":");
      w = stamp_chars(*f.timestamp_ns, w);
    }
    copy("},\"interface\":");
    copy(interface_column_);
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
