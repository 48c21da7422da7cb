#include "saulproto/core/hex.hpp"
#include "saulproto/host/capture/uart_export.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>

#include "../util.hpp"
#include "text_fields.hpp"

namespace saul::host {
namespace {

/// One annotation, whatever file it came from.
struct UartAnnotation {
  std::optional<std::uint64_t> start_sample;
  std::optional<std::uint64_t> end_sample;
  std::optional<std::uint64_t> time_ns;  ///< when the file gives a time (JSON trace, PulseView's Time column)
  std::string source;                    ///< decoder instance ("uart-1", "UART")
  std::string row;                       ///< "RX", "TX", or "" when the file does not say
  std::string ann_class;                 ///< "RX data", ... when the file says (PulseView CSV), else ""
  std::string text;                      ///< "AA", "Parity error", "Start bit", ...
};

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r' || s.back() == '\n')) s.remove_suffix(1);
  return s;
}

std::string_view unquote(std::string_view s) {
  s = trim(s);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
  return s;
}

/// "RX" or "TX" when the row or class says so, else "".
std::string_view direction(const UartAnnotation& a) {
  for (std::string_view s : {std::string_view(a.row), std::string_view(a.ann_class)}) {
    if (detail::starts_with_nocase(s, "tx")) return "TX";
    if (detail::starts_with_nocase(s, "rx")) return "RX";
  }
  return "";
}

std::string link_of(const UartAnnotation& a) {
  std::string link = a.source.empty() ? std::string("uart") : a.source;
  const std::string_view dir = direction(a);
  if (!dir.empty()) {
    link += ':';
    link += dir;
  }
  for (char& c : link)
    if (c == ' ' || c == '\t') c = '_';
  return link;
}

std::uint8_t error_of(std::string_view text) {
  if (text == "Parity error" || text == "Parity err") return uart_error::kParity;
  if (text == "Frame error" || text == "Frame err") return uart_error::kFraming;
  if (text == "Break condition" || text == "Break" || text == "Brk") return uart_error::kBreak;
  return 0;
}

std::optional<std::uint8_t> byte_of(const UartAnnotation& a) {
  if (!a.ann_class.empty()) {
    const std::string_view c = a.ann_class;
    if (!(c.size() >= 4 && c.substr(c.size() - 4) == "data")) return std::nullopt;  // "RX data", "TX data"
  }
  const std::string_view t = a.text;
  if (t.size() != 2) return std::nullopt;
  const int hi = hex::value(t[0]);
  const int lo = hex::value(t[1]);
  if (hi < 0 || lo < 0) return std::nullopt;
  return static_cast<std::uint8_t>(hi << 4 | lo);
}

/// Turns annotations into chunks. Each link holds back its last byte until its next byte (or the end), so that
/// error annotations after it can still be added to it.
class UartAnnotationFolder {
 public:
  explicit UartAnnotationFolder(const SerialReadOptions& options) : options_(options) {}
  /// Takes one annotation; returns true when a chunk is ready in ready().
  bool add(const UartAnnotation& a) {
    const auto byte = byte_of(a);
    const std::uint8_t error = byte ? 0 : error_of(a.text);
    if (!byte && error == 0) return false;

    std::optional<std::uint64_t> time;
    if (a.start_sample && options_.samplerate_hz > 0) {
      const std::uint64_t s = *a.start_sample;
      const std::uint64_t rate = options_.samplerate_hz;
      time = s / rate * 1'000'000'000ULL + (s % rate) * 1'000'000'000ULL / rate;
    } else if (a.time_ns) {
      time = a.time_ns;
    }
    std::string link = link_of(a);
    Held* held = nullptr;
    for (auto& h : held_)
      if (h.chunk.link == link) held = &h;

    if (error != 0 && held && !held->chunk.bytes.empty()) {
      bool near = true;
      if (a.start_sample && held->end_sample && held->bit)
        near = *a.start_sample <= *held->end_sample + (*held->bit * 5) / 2 + 1;
      if (near) {
        held->chunk.errors |= error;
        return false;
      }
    }
    Held next;
    next.chunk.timestamp_ns = time;
    next.chunk.link = std::move(link);
    next.chunk.protocol = options_.protocol.value_or(SerialProtocol::raw);
    if (byte) next.chunk.bytes.push_back(*byte);
    next.chunk.errors = error;
    next.end_sample = a.end_sample;
    if (byte && a.start_sample && a.end_sample && *a.end_sample > *a.start_sample)
      next.bit = (*a.end_sample - *a.start_sample) / 8;
    if (held) {
      ready_ = std::move(held->chunk);
      *held = std::move(next);
      return true;
    }
    held_.push_back(std::move(next));
    return false;
  }
  /// At the end of the file: true while held chunks come out (call until false).
  bool finish() {
    if (held_.empty()) return false;
    ready_ = std::move(held_.front().chunk);
    held_.erase(held_.begin());
    return true;
  }
  [[nodiscard]] const SerialChunk& ready() const { return ready_; }

 private:
  struct Held {
    SerialChunk chunk;
    std::optional<std::uint64_t> end_sample;
    std::optional<std::uint64_t> bit;  // samples per bit, estimated from the byte annotation
  };
  SerialReadOptions options_;
  std::vector<Held> held_;  // one per link holding a chunk; links are few
  SerialChunk ready_;
};

/// The reader of the three line-based formats.
class UartExportReader final : public SerialCaptureReader {
 public:
  UartExportReader(std::istream& in, const SerialReadOptions& options, CaptureFormat format)
      : in_(in), folder_(options), format_(format) {}
  Status next() override {
    if (done_) return folder_.finish() ? Status::chunk : Status::end;
    UartAnnotation annotation;
    while (const auto text = detail::next_line(in_, line_, line_number_)) {
      const std::string_view line = *text;
      annotation = UartAnnotation{};
      switch (parse(line, annotation)) {
        case Line::skip: continue;
        case Line::corrupt: return Status::corrupt;
        case Line::annotation:
          if (folder_.add(annotation)) return Status::chunk;
          continue;
      }
    }
    done_ = true;
    return folder_.finish() ? Status::chunk : Status::end;
  }
  [[nodiscard]] const SerialChunk& chunk() const override { return folder_.ready(); }
  [[nodiscard]] const CaptureError& error() const override { return error_; }
  [[nodiscard]] CaptureFormat format() const override { return format_; }

 private:
  enum class Line { annotation, skip, corrupt };
  /// Parses one line into annotation (or says to skip it, or fills error_'s column and message).
  Line parse(std::string_view line, UartAnnotation& annotation) {
    if (format_ == CaptureFormat::sigrok) return sigrok_line(line, annotation);
    if (format_ == CaptureFormat::sigrok_json) return json_line(line, annotation);
    return pulseview_line(line, annotation);
  }
  /// The line is corrupt at `column` (reading goes on at the next line).
  Line corrupt(std::size_t column, std::string message) {
    detail::line_error(error_, line_number_, column, std::move(message));
    return Line::corrupt;
  }
  Line sigrok_line(std::string_view line, UartAnnotation& a) {
    if (trim(line).empty() || line.front() == '#') return Line::skip;
    std::size_t pos = 0;
    if (line.front() >= '0' && line.front() <= '9') {
      const std::size_t dash = line.find('-');
      const std::size_t space = line.find(' ');
      if (dash != std::string_view::npos && space != std::string_view::npos && dash < space) {
        a.start_sample = detail::parse_decimal(trim(line.substr(0, dash)));
        a.end_sample = detail::parse_decimal(trim(line.substr(dash + 1, space - dash - 1)));
      }
      // "uart-1: ..." also starts with a letter, so a leading digit means sample numbers
      if (!a.start_sample || !a.end_sample)
        return corrupt(0, "expected START-END sample numbers before the decoder name");
      pos = space + 1;
    }
    const std::string_view rest = line.substr(pos);
    const std::size_t colon = rest.find(": ");
    if (colon == std::string_view::npos || colon == 0)
      return corrupt(pos, "expected 'NAME: TEXT' (a sigrok-cli or PulseView annotation)");
    a.source = unquote(rest.substr(0, colon));
    std::string_view text = rest.substr(colon + 2);
    const std::size_t second = text.find(": ");
    if (second != std::string_view::npos) {
      a.row = unquote(text.substr(0, second));
      text = text.substr(second + 2);
    }
    a.text = unquote(text);
    return Line::annotation;
  }
  Line json_line(std::string_view line, UartAnnotation& a) {
    std::string_view t = trim(line);
    if (t.empty() || t == "{\"traceEvents\": [" || t == "{\"traceEvents\":[" || t == "]}" || t == "]" || t == "}")
      return Line::skip;
    if (t.back() == ',') t.remove_suffix(1);
    const auto j = nlohmann::json::parse(t.begin(), t.end(), nullptr, false);
    if (j.is_discarded() || !j.is_object()) return corrupt(0, "not a JSON trace event");
    const auto ph = j.find("ph");
    if (ph == j.end() || !ph->is_string()) return corrupt(0, "trace event without \"ph\"");
    if (*ph != "B") return Line::skip;  // "E" closes the annotation "B" opened
    const auto ts = j.find("ts");
    const auto name = j.find("name");
    if (ts == j.end() || !ts->is_number() || name == j.end() || !name->is_string())
      return corrupt(0, "trace event without a numeric \"ts\" and a \"name\"");
    const double us = ts->get<double>();
    if (us >= 0) a.time_ns = static_cast<std::uint64_t>(std::llround(us * 1000.0));
    if (const auto pid = j.find("pid"); pid != j.end() && pid->is_string()) a.source = pid->get<std::string>();
    if (const auto tid = j.find("tid"); tid != j.end() && tid->is_string()) a.row = tid->get<std::string>();
    a.text = name->get<std::string>();
    return Line::annotation;
  }
  Line pulseview_line(std::string_view line, UartAnnotation& a) {
    if (trim(line).empty()) return Line::skip;
    if (!split_pulseview_csv(line, fields_)) return corrupt(0, "a quoted field has no closing quote");
    if (!have_header_) {
      for (std::size_t i = 0; i < fields_.size(); ++i) {
        const std::string_view f = trim(fields_[i]);
        const int index = static_cast<int>(i);
        if (f == "Sample") sample_ = index;
        if (f == "Time") time_ = index;
        if (f == "Decoder") decoder_ = index;
        if (f == "Ann Row") row_ = index;
        if (f == "Ann Class") class_ = index;
        if (f == "Value") value_ = index;
      }
      if (value_ < 0) return corrupt(0, "not a PulseView table header (no \"Value\" column)");
      have_header_ = true;
      return Line::skip;
    }
    auto field = [this](int index) -> std::string_view {
      const auto i = static_cast<std::size_t>(index);
      return index >= 0 && i < fields_.size() ? trim(fields_[i]) : std::string_view();
    };
    if (static_cast<std::size_t>(value_) >= fields_.size()) return corrupt(0, "fewer fields than the header has");
    if (sample_ >= 0) a.start_sample = detail::parse_decimal(field(sample_));
    if (time_ >= 0) {
      const auto ns = parse_pulseview_time(field(time_));
      if (ns && *ns >= 0) a.time_ns = static_cast<std::uint64_t>(*ns);
    }
    a.source = field(decoder_);
    a.row = field(row_);
    a.ann_class = field(class_);
    a.text = field(value_);
    return Line::annotation;
  }
  std::istream& in_;
  std::string line_;
  std::uint64_t line_number_ = 0;
  CaptureError error_;
  UartAnnotationFolder folder_;
  CaptureFormat format_;
  bool done_ = false;
  bool have_header_ = false;  // PulseView CSV: the columns below are known
  int sample_ = -1, time_ = -1, decoder_ = -1, row_ = -1, class_ = -1, value_ = -1;
  std::vector<std::string> fields_;
};

}  // namespace

std::optional<std::int64_t> parse_pulseview_time(std::string_view text) noexcept {
  std::string_view s = trim(text);
  bool negative = false;
  if (!s.empty() && (s.front() == '+' || s.front() == '-')) {
    negative = s.front() == '-';
    s.remove_prefix(1);
  }
  // a decimal number (digits, '.', digits) at the front
  auto number = [](std::string_view& t, long double& v) {
    const std::size_t n = std::min(t.find_first_not_of("0123456789."), t.size());
    const auto [end, ec] = std::from_chars(t.data(), t.data() + n, v, std::chars_format::fixed);
    if (n == 0 || ec != std::errc() || end != t.data() + n) return false;
    t.remove_prefix(n);
    return true;
  };
  long double ns = 0;
  if (s.find(':') != std::string_view::npos) {
    // [[D:]H:]M:S.fff
    long double parts[4] = {0, 0, 0, 0};
    int n = 0;
    for (;;) {
      long double v = 0;
      if (n == 4 || !number(s, v)) return std::nullopt;
      parts[n++] = v;
      if (s.empty()) break;
      if (s.front() != ':') return std::nullopt;
      s.remove_prefix(1);
    }
    static constexpr long double kUnit[4] = {86400, 3600, 60, 1};
    for (int i = 0; i < n; ++i) ns += parts[i] * kUnit[4 - n + i];
    ns *= 1e9L;
  } else {
    long double v = 0;
    if (!number(s, v)) return std::nullopt;
    s = trim(s);
    long double unit = 1e9L;
    if (s.starts_with("\xCE\xBC") || s.starts_with("\xC2\xB5")) {  // Greek mu (PulseView) or micro sign
      unit = 1e3L;
      s.remove_prefix(2);
    } else if (s.size() == 2 && s[1] == 's') {
      switch (s[0]) {
        case 'p': unit = 1e-3L; break;
        case 'n': unit = 1; break;
        case 'u': unit = 1e3L; break;
        case 'm': unit = 1e6L; break;
        case 'k': unit = 1e12L; break;
        default: return std::nullopt;
      }
      s.remove_prefix(1);
    }
    if (s != "s") return std::nullopt;
    ns = v * unit;
  }
  // A time beyond +-292 years in ns does not fit: a bad field, not a time (llround of it is unspecified, and
  // negating INT64_MIN is undefined; found by fuzz_serial_pulseview_csv, kept in tests/fuzz/regression).
  if (!(ns >= 0 && ns < 9.2e18L)) return std::nullopt;
  const auto rounded = static_cast<std::int64_t>(std::llround(ns));
  return negative ? -rounded : rounded;
}

bool split_pulseview_csv(std::string_view line, std::vector<std::string>& fields) {
  fields.clear();
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  std::size_t i = 0;
  for (;;) {
    std::string field;
    if (i < line.size() && line[i] == '"') {
      ++i;
      for (;;) {
        if (i >= line.size()) return false;
        if (line[i] == '"') {
          if (i + 1 < line.size() && line[i + 1] == '"') {
            field += '"';
            i += 2;
            continue;
          }
          ++i;
          break;
        }
        field += line[i++];
      }
      while (i < line.size() && line[i] != ',') ++i;  // tolerate spaces after the closing quote
    } else {
      while (i < line.size() && line[i] != ',') {
        if (line[i] == '\\' && i + 1 < line.size() && line[i + 1] == ',') {
          field += ',';
          i += 2;
          continue;
        }
        field += line[i++];
      }
    }
    fields.push_back(std::move(field));
    if (i >= line.size()) return true;
    ++i;  // the comma
  }
}

std::unique_ptr<SerialCaptureReader> make_uart_export_reader(std::istream& in, CaptureFormat format,
                                                             const SerialReadOptions& options) {
  return std::make_unique<UartExportReader>(in, options, format);
}

}  // namespace saul::host
