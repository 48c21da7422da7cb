// What a logic analyser's UART decoder writes, read back as bytes: sigrok's "uart" protocol decoder, run by
// sigrok-cli or by PulseView. Checked against sigrok-cli 0.7.2 / libsigrokdecode 0.5.3 (Debian 12) on VCDs made by
// captures/make_uart_vcd.py; PulseView's formats follow its source (decodetrace.cpp export_annotations,
// tabular_decoder/view.cpp save_data_as_csv).
//
//  sigrok (CaptureFormat::sigrok), one annotation per line:
//      sigrok-cli -i cap.vcd -P uart:rx=rx:baudrate=460800 -A uart=rx-data          ->  uart-1: AA
//      ... --protocol-decoder-samplenum                                             ->  1023-1195 uart-1: AA
//      PulseView "Export all annotations" (its default "%s %d: %r: %1")             ->  1023-1195 UART: RX: AA
//  sigrok_json: sigrok-cli ... --protocol-decoder-jsontrace, one event per line:
//      {"ph": "B", "ts": 226.000000, "pid": "uart-1", "tid": "RX", "name": "FE"},   (ts in microseconds)
//  pulseview_csv: PulseView's decoder table, "Save" (both of its CSV styles):
//      "Sample","Time","Decoder","Ann Row","Ann Class","Value"
//      "1023","102.300 µs","UART","RX","RX data","AA"
//
// A byte is an annotation whose text is exactly two hex digits (the decoder's default format=hex, 8 data bits),
// or, when the file names annotation classes (PulseView CSV), one of class "RX data"/"TX data". "Parity error",
// "Frame error" and "Break condition" annotations set uart_error bits: on the byte just before them when they
// fall within 2.5 bit times of its end (or when there are no sample numbers to tell), else on a chunk of their
// own with no bytes. Everything else (start, stop and parity bits, single data bits, warnings we do not know) is
// ignored. Each byte is one SerialChunk; its link is the decoder instance plus the row when known ("uart-1:RX",
// "UART:TX", spaces turned into '_'); its time is the annotation's start (the start of the first data bit).
#pragma once

#include <cstdint>
#include <istream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/host/capture/serial_capture.hpp"

namespace saul::host {

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

/// Parses a PulseView time ("102.300 µs", "1.023 ms", "0.000 s", "-5 ns", "1:02.345", "1:00:02.345") into ns.
std::optional<std::int64_t> parse_pulseview_time(std::string_view text) noexcept;

/// Splits one CSV line of PulseView's table into fields: "quoted" fields with "" escapes, or unquoted fields
/// with "\," escapes (its two save styles). Returns false on an unterminated quote.
bool split_pulseview_csv(std::string_view line, std::vector<std::string>& fields);

/// Turns annotations into chunks (shared by the three readers; exposed for tests). Each link holds back its
/// last byte until its next byte (or the end), so that error annotations after it can still be added to it.
class UartAnnotationFolder {
 public:
  explicit UartAnnotationFolder(const SerialReadOptions& options) : options_(options) {}
  /// Takes one annotation; returns true when a chunk is ready in ready().
  bool add(const UartAnnotation& annotation);
  /// At the end of the file: true while held chunks come out (call until false).
  bool finish();
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

/// Base of the three line-based readers.
class UartExportReader : public SerialCaptureReader {
 public:
  UartExportReader(std::istream& in, const SerialReadOptions& options, CaptureFormat format)
      : in_(in), folder_(options), format_(format) {}
  Status next() final;
  [[nodiscard]] const SerialChunk& chunk() const final { return folder_.ready(); }
  [[nodiscard]] const CaptureError& error() const final { return error_; }
  [[nodiscard]] CaptureFormat format() const final { return format_; }

 protected:
  enum class Line { annotation, skip, corrupt };
  /// Parses one line into annotation (or says to skip it, or fills error_'s column and message).
  virtual Line parse(std::string_view line, UartAnnotation& annotation) = 0;
  /// The line is corrupt at `column` (reading goes on at the next line).
  Line corrupt(std::size_t column, std::string message);

 private:
  std::istream& in_;
  std::string line_;
  std::uint64_t line_number_ = 0;
  CaptureError error_;
  UartAnnotationFolder folder_;
  CaptureFormat format_;
  bool done_ = false;
};

class SigrokAnnotationReader final : public UartExportReader {
 public:
  SigrokAnnotationReader(std::istream& in, const SerialReadOptions& options)
      : UartExportReader(in, options, CaptureFormat::sigrok) {}

 private:
  Line parse(std::string_view line, UartAnnotation& annotation) override;
};

class SigrokJsonTraceReader final : public UartExportReader {
 public:
  SigrokJsonTraceReader(std::istream& in, const SerialReadOptions& options)
      : UartExportReader(in, options, CaptureFormat::sigrok_json) {}

 private:
  Line parse(std::string_view line, UartAnnotation& annotation) override;
};

class PulseViewCsvReader final : public UartExportReader {
 public:
  PulseViewCsvReader(std::istream& in, const SerialReadOptions& options)
      : UartExportReader(in, options, CaptureFormat::pulseview_csv) {}

 private:
  Line parse(std::string_view line, UartAnnotation& annotation) override;
  bool have_header_ = false;
  int sample_ = -1, time_ = -1, decoder_ = -1, row_ = -1, class_ = -1, value_ = -1;
  std::vector<std::string> fields_;
};

}  // namespace saul::host
