#include "saulproto/host/report/fast_emit.hpp"

#include <algorithm>
#include <charconv>
#include <cstring>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/hex.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/report/format.hpp"

namespace saul::host {
namespace {

/// v's last `digits` hex digits, upper case.
char* put_hex(char* w, std::uint32_t v, int digits) {
  for (int i = digits - 1; i >= 0; --i, v >>= 4) w[i] = hex::kUpperDigits[v & 0xF];
  return w + digits;
}

std::string_view bool_text(bool b) { return b ? "true" : "false"; }

// What the line says of the frame's content before the per-frame columns' place (the split of a cached line):
// text "300#E8030CFE{pad} [!reason [detail]]", CSV "300,0,0,4,E8030CFE,[!reason,]", JSON
// {["error":"reason",["error_detail":"...",]]"frame":{"data":..,"remote":b
// (room for 2 * TimeColumn::kMaxChars + 6 * detail + 256).
char* head_chars(char* w, DecodeFormat format, const CanFrame& f, Reason reason, const std::string& detail) {
  const bool ok = reason == Reason::ok;
  if (format == DecodeFormat::text) {
    char* const at = w;
    w = write_candump_frame(w, f);
    while (w < at + 24) *w++ = ' ';
    *w++ = ' ';
    if (ok) return w;
    *w++ = '!';
    w = put_chars(w, to_string(reason));
    if (!detail.empty()) *w++ = ' ';
    return put_chars(w, detail);
  }
  if (format == DecodeFormat::csv) {
    int digits = 1;
    while (digits < 8 && (f.id >> (4 * digits)) != 0) ++digits;
    w = put_hex(w, f.id, digits);
    w = put_chars(w, f.extended ? ",1," : ",0,");
    w = put_chars(w, f.remote ? "1," : "0,");
    w = std::to_chars(w, w + 4, unsigned{f.dlc}).ptr;
    *w++ = ',';
    w = write_candump_frame(w, f, true);
    *w++ = ',';
    if (ok) return w;
    *w++ = '!';
    w = put_chars(w, to_string(reason));
    *w++ = ',';
    return w;
  }
  *w++ = '{';
  if (!ok) {
    w = put_chars(w, "\"error\":\"");
    w = put_chars(w, to_string(reason));
    w = put_chars(w, "\",");
    if (!detail.empty()) {
      std::string quoted;
      append_json_string(quoted, detail);
      w = put_chars(w, "\"error_detail\":");
      w = put_chars(w, quoted);
      *w++ = ',';
    }
  }
  w = put_chars(w, "\"frame\":{\"data\":\"");
  if (!f.remote) w = write_candump_frame(w, f, true);  // the data's digits
  w = put_chars(w, "\",\"dlc\":");
  w = std::to_chars(w, w + 4, unsigned{f.dlc}).ptr;
  w = put_chars(w, ",\"error\":");
  w = put_chars(w, bool_text(f.error));
  w = put_chars(w, ",\"extended\":");
  w = put_chars(w, bool_text(f.extended));
  w = put_chars(w, ",\"id\":");
  w = std::to_chars(w, w + 12, f.id).ptr;
  w = put_chars(w, ",\"remote\":");
  return put_chars(w, bool_text(f.remote));
}

// The message part of the line: text "name k=v ...", CSV "name,fields", JSON ,"message":{"k":v,...,"type":"name"},
// from the frame's bytes (a frame that decodes carries exactly the values its message holds). Room for
// 2 * message_chars_max(d) + 16.
char* message_chars(char* w, DecodeFormat format, const signals::MessageDesc& d, const CanFrame& f) {
  if (format == DecodeFormat::jsonl) w = put_chars(w, ",\"message\":");
  char* const at = w;
  w = write_message(w, format == DecodeFormat::jsonl ? MessageFormat::json : MessageFormat::text, d,
                    signals::Wire{f.id, f.payload()});
  if (format != DecodeFormat::csv) return w;
  // "name,fields": the space after the name becomes the comma when the fields need no quotes (nearly always)
  char* const space = std::find(at, w, ' ');
  if (space == w) {
    *w++ = ',';
    return w;
  }
  bool plain = true;  // (find_first_of would call memchr once per character)
  for (const char* c = space; c < w; ++c) plain = plain && *c != ',' && *c != '"';
  *space = ',';
  return plain ? w : put_chars(space + 1, csv_quote(std::string(space + 1, w)));
}

}  // namespace

FrameEmitter::FrameEmitter(DecodeFormat format, TimeMode time, std::optional<std::uint64_t> first)
    : format_(format), time_(time), cache_(1024) {
  if (first) time_.note(*first);
}
FrameEmitter::~FrameEmitter() = default;

std::string frame_text(const CanFrame& f) {
  const Result<DecodedName> result = decode_bus_name(f);
  const std::string detail = f.error ? describe_error_frame(f) : std::string();
  const signals::MessageDesc* d = result ? signals::find_can(f.id, f.extended) : nullptr;
  std::string text(6 * detail.size() + (d ? 2 * message_chars_max(*d) : 0) + 320, '\0');
  char* w = head_chars(text.data(), DecodeFormat::text, f, result.reason(), detail);
  if (d) w = message_chars(w, DecodeFormat::text, *d, f);
  text.resize(static_cast<std::size_t>(w - text.data()));
  return text;
}

void FrameEmitter::add(const CanFrame& f, std::string_view interface, fmt::memory_buffer& out, DecodeCounts& counts) {
  // robot buses repeat payloads: the content's text from before, in its slot of the cache (none while the judge
  // finds that the frames do not repeat)
  Entry* e = nullptr;
  FrameKey key;
  if (judge_.use()) {
    key = frame_key(f);
    e = &cache_[key.slot(cache_.size())];
  }
  const bool hit = e && e->used && e->key == key;
  if (e) judge_.looked(hit);
  Result<DecodedName> result = Reason::ok;
  if (!hit) result = decode_bus_name(f);
  counts.count(hit ? e->reason : result.reason());
  const bool text = format_ == DecodeFormat::text;
  const bool json = format_ == DecodeFormat::jsonl;
  if (text && interface.empty()) interface = "can0";
  if (interface != interface_) {
    interface_.assign(interface);
    interface_column_.clear();
    if (json) {
      append_json_string(interface_column_, interface_);  // with its quotes
    } else if (format_ == DecodeFormat::csv) {
      interface_column_ = csv_quote(interface_);  // a ',' or '"' in a name
    } else {
      interface_column_ = candump_interface(interface_);  // spaces and controls as '_', as candump's column
    }
  }
  // What an error frame reports, when asked (sniff): "!error_frame bus-off", or an "error_detail" member.
  const std::string detail = !hit && f.error && error_detail_ ? describe_error_frame(f) : std::string();
  const signals::MessageDesc* d = !hit && result ? signals::find_can(f.id, f.extended) : nullptr;
  // One line in one go: room for all of it, then written in place.
  const std::size_t room = hit ? e->text.size() : 6 * detail.size() + (d ? 2 * message_chars_max(*d) : 0);
  const std::size_t at = out.size();
  out.resize(at + 2 * TimeColumn::kMaxChars + interface_column_.size() + room + 320);
  char* w = out.data() + at;
  const std::uint64_t ns = f.timestamp_ns.value_or(0);
  if (!json) {
    w = time_.write(w, ns, text);
    *w++ = text ? ' ' : ',';
    w = put_chars(w, interface_column_);
    *w++ = text ? ' ' : ',';
  }
  const std::string_view line = hit ? std::string_view(e->text) : std::string_view();
  char* const head = w;
  w = hit ? put_chars(w, line.substr(0, e->split)) : head_chars(w, format_, f, result.reason(), detail);
  const auto head_size = static_cast<std::size_t>(w - head);
  if (json) {
    if (f.timestamp_ns) {
      w = put_chars(w, ",\"timestamp_ns\":");
      w = std::to_chars(w, w + TimeColumn::kMaxChars, *f.timestamp_ns).ptr;
    }
    w = put_chars(w, "},\"interface\":");
    w = put_chars(w, interface_column_);
  }
  char* const tail = w;
  if (hit) {
    w = put_chars(w, line.substr(e->split));
  } else {
    if (d) w = message_chars(w, format_, *d, f);
    if (e) {
      e->used = true;
      e->key = key;
      e->reason = result.reason();
      e->split = head_size;
      e->text.assign(head, head_size);
      e->text.append(tail, static_cast<std::size_t>(w - tail));
    }
  }
  if (json) {
    w = put_chars(w, ",\"time\":\"");
    w = time_.write(w, ns, false);
    w = put_chars(w, "\"}");
  }
  *w++ = '\n';
  out.resize(static_cast<std::size_t>(w - out.data()));
}

}  // namespace saul::host
