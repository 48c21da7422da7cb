#include "saulproto/core/hex.hpp"
#include "saulproto/host/capture/serial_capture.hpp"

#include <fmt/format.h>

#include <span>
#include <stdexcept>

#include "saulproto/host/capture/uart_export.hpp"
#include "capture_io.hpp"
#include "text_fields.hpp"

namespace saul::host {
namespace {

using detail::column_error;

}  // namespace

constexpr std::string_view kProtocolNames[] = {"raw", "interboard", "crsf", "pride"};  // by SerialProtocol

std::string_view to_string(SerialProtocol protocol) noexcept {
  return kProtocolNames[static_cast<std::size_t>(protocol)];
}

std::optional<SerialProtocol> serial_protocol_from_name(std::string_view name) noexcept {
  for (std::size_t i = 0; i < std::size(kProtocolNames); ++i)
    if (name == kProtocolNames[i]) return static_cast<SerialProtocol>(i);
  return std::nullopt;
}

SerialProtocol protocol_for_baud(std::uint32_t baud) noexcept {
  switch (baud) {
    case 460800: return SerialProtocol::interboard;
    case 420000:
    case 416666: return SerialProtocol::crsf;
    case 38400: return SerialProtocol::pride;
    default: return SerialProtocol::raw;
  }
}

namespace {

/// Parses one serial-log line (no newline). False with error's column and message when it is not one.
bool parse_serial_line(std::string_view line, SerialChunk& out, CaptureError& error) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  std::uint64_t ns = 0;
  std::size_t close = 0;
  if (!detail::parse_paren_time(line, 18'000'000'000ULL, ns, close, error)) return false;

  std::size_t pos = close + 1;
  std::size_t start = 0;
  const std::string_view link = detail::word(line, pos, start);
  if (link.empty()) return column_error(error, start, "missing link name");
  const std::string_view protocol_text = detail::word(line, pos, start);
  if (protocol_text.empty()) return column_error(error, start, "missing protocol (interboard, crsf, pride or raw)");
  const auto protocol = serial_protocol_from_name(protocol_text);
  if (!protocol) return column_error(error, start, "unknown protocol: use interboard, crsf, pride or raw");
  const std::string_view data = detail::word(line, pos, start);
  if (data.empty()) return column_error(error, start, "missing bytes (hex, or '-' for none)");
  out.bytes.clear();
  if (data != "-") {
    if (data.size() % 2 != 0) return column_error(error, start, "bytes have an odd number of hex digits");
    for (std::size_t i = 0; i < data.size(); i += 2) {
      const int hi = hex::value(data[i]);
      const int lo = hex::value(data[i + 1]);
      if (hi < 0 || lo < 0) return column_error(error, start + i, "bytes are not hexadecimal");
      out.bytes.push_back(static_cast<std::uint8_t>(hi << 4 | lo));
    }
  }
  std::uint8_t errors = 0;
  for (;;) {
    const std::string_view mark = detail::word(line, pos, start);
    if (mark.empty()) break;
    if (mark == "!parity") {
      errors |= uart_error::kParity;
    } else if (mark == "!framing") {
      errors |= uart_error::kFraming;
    } else if (mark == "!break") {
      errors |= uart_error::kBreak;
    } else {
      return column_error(error, start, "unexpected text after the bytes (only !parity, !framing, !break)");
    }
  }
  if (out.bytes.empty() && errors == 0)
    return column_error(error, start, "a line with no bytes must carry an error mark");
  out.timestamp_ns = ns;
  out.link.assign(link);
  out.protocol = *protocol;
  out.errors = errors;
  return true;
}

/// One serial-log line, without newline: at most 64 `bytes` of a chunk (the writer splits longer ones), with the
/// uart_error marks `errors`.
std::string format_serial_line(const SerialChunk& chunk, std::span<const std::uint8_t> bytes, std::uint8_t errors) {
  const std::uint64_t ns = chunk.timestamp_ns.value_or(0);
  std::string s = fmt::format("({:010}.{:06}) {} {} ", ns / 1'000'000'000ULL, (ns % 1'000'000'000ULL) / 1000,
                              chunk.link, to_string(chunk.protocol));
  for (std::uint8_t b : bytes) {
    s += hex::kUpperDigits[b >> 4];
    s += hex::kUpperDigits[b & 0xF];
  }
  if (bytes.empty()) s += '-';
  if (errors & uart_error::kParity) s += " !parity";
  if (errors & uart_error::kFraming) s += " !framing";
  if (errors & uart_error::kBreak) s += " !break";
  return s;
}

}  // namespace

SerialLogReader::Status SerialLogReader::next() {
  while (std::getline(in_, line_)) {
    ++line_number_;
    if (line_.empty() || line_[0] != '(') continue;  // comment or blank
    if (parse_serial_line(line_, chunk_, error_)) return Status::chunk;
    detail::line_error(error_, line_number_, error_.column, std::move(error_.message));
    return Status::corrupt;
  }
  return Status::end;
}

void SerialLogWriter::write(const SerialChunk& chunk) {
  if (closed_) throw std::runtime_error("serial log writer: write after close");
  if (chunk.link.empty() || chunk.link.find_first_of(" \t\r\n") != std::string::npos)
    throw std::invalid_argument(fmt::format("serial log: link name '{}' is empty or has white space", chunk.link));
  if (chunk.bytes.empty() && chunk.errors == 0) return;  // nothing to say
  const std::span<const std::uint8_t> bytes(chunk.bytes);
  std::size_t at = 0;
  do {  // lines of at most kMaxBytesPerLine bytes with the same time; the marks go with the last
    const std::size_t n = std::min(kMaxBytesPerLine, bytes.size() - at);
    const std::uint8_t errors = at + n == bytes.size() ? chunk.errors : 0;
    out_ << format_serial_line(chunk, bytes.subspan(at, n), errors) << '\n';
    at += n;
  } while (at < bytes.size());
  if (!out_) throw std::runtime_error("serial log: write failed");
}

void SerialLogWriter::flush() { detail::flush_checked(out_, "serial log"); }

void SerialLogWriter::close() {
  if (closed_) return;
  closed_ = true;
  flush();
}

std::unique_ptr<SerialCaptureReader> make_serial_capture_reader(std::istream& in, CaptureFormat format,
                                                                const SerialReadOptions& options) {
  if (!holds_serial_bytes(format))
    throw std::invalid_argument(fmt::format("{} holds CAN frames, not serial bytes", to_string(format)));
  if (format == CaptureFormat::serial) return std::make_unique<SerialLogReader>(in);
  return make_uart_export_reader(in, format, options);
}

std::unique_ptr<SerialCaptureWriter> make_serial_capture_writer(std::ostream& out) {
  return std::make_unique<SerialLogWriter>(out);
}

}  // namespace saul::host
