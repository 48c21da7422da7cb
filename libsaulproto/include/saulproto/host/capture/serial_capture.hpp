// Byte captures of the robot's UART links (inter-board 460800 8N1, CRSF 420000 8N1, Pride 38400 8E1), read through
// one interface (SerialCaptureReader) that hands out timestamped chunks of bytes (docs/captures.md):
//  - our own serial log (CaptureFormat::serial), one line per chunk as it came off the port, candump-like:
//        (1763800000.000100) serial:/dev/ttyUSB0@460800:8N1 interboard AA0501F40106FF010F
//    time, link, protocol (interboard, crsf, pride, raw), the bytes in hex, then " !parity", " !framing" or " !break"
//    marks of a logic analyser ("-" for no bytes);
//  - logic-analyser exports of sigrok's UART decoder (uart_export.hpp), which name no protocol: give one in
//    SerialReadOptions, or let the caller guess it (guess_serial_protocol in serial_decode.hpp).
// Format detection and open_capture() are shared with the CAN formats (capture.hpp).
#pragma once

#include <cstdint>
#include <istream>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/host/capture/capture.hpp"

namespace saul::host {

enum class SerialProtocol : std::uint8_t {
  raw,         ///< not known (or not one of ours): bytes are kept, nothing is decoded
  interboard,  ///< the IO <-> BALANCE UART (core/interboard.hpp)
  crsf,        ///< a CRSF/ELRS receiver (core/crsf.hpp)
  pride,       ///< the Pride ES motor controller's one-wire link (core/pride.hpp)
};

/// "raw", "interboard", "crsf", "pride".
std::string_view to_string(SerialProtocol protocol) noexcept;
std::optional<SerialProtocol> serial_protocol_from_name(std::string_view name) noexcept;
/// What the robot runs at a baud rate: 460800 inter-board, 420000 and 416666 CRSF, 38400 Pride; raw otherwise.
SerialProtocol protocol_for_baud(std::uint32_t baud) noexcept;

/// UART errors a logic analyser reports with a byte (SerialChunk::errors).
namespace uart_error {
inline constexpr std::uint8_t kParity = 0x01;
inline constexpr std::uint8_t kFraming = 0x02;
inline constexpr std::uint8_t kBreak = 0x04;
}  // namespace uart_error

/// A run of bytes seen on one link at one time: what one read() of the port returned, or one byte of a logic
/// analyser export.
struct SerialChunk {
  std::optional<std::uint64_t> timestamp_ns;  ///< Unix time for recordings; from the capture start for imports
  std::string link;                           ///< "serial:/dev/ttyUSB0@460800:8N1", "uart-1:RX", ... (no spaces)
  SerialProtocol protocol = SerialProtocol::raw;
  std::vector<std::uint8_t> bytes;
  std::uint8_t errors = 0;  ///< uart_error bits
  bool operator==(const SerialChunk&) const = default;
};

/// How to read files that do not say everything themselves (logic-analyser exports).
struct SerialReadOptions {
  /// The protocol of every chunk of a file that names none (sigrok, PulseView); raw when absent.
  std::optional<SerialProtocol> protocol;
  /// Of the logic capture, to turn sample numbers into time; 0 = unknown: such chunks carry no timestamp, except
  /// where the file has times of its own (the JSON trace, PulseView's Time column).
  std::uint64_t samplerate_hz = 0;
  /// The file's format instead of the one its content says (`--input-format`), when no format is given otherwise.
  std::optional<CaptureFormat> format;
};

/// Reads chunks one at a time, in constant memory.
class SerialCaptureReader {
 public:
  enum class Status { chunk, corrupt, end };
  SerialCaptureReader() = default;
  SerialCaptureReader(const SerialCaptureReader&) = delete;
  SerialCaptureReader& operator=(const SerialCaptureReader&) = delete;
  virtual ~SerialCaptureReader() = default;

  /// Advances. On Status::chunk, chunk() holds it (valid until the next call); on Status::corrupt, error() says
  /// what and where (the reader goes on with the next line). Never throws for bad content.
  virtual Status next() = 0;
  [[nodiscard]] virtual const SerialChunk& chunk() const = 0;
  [[nodiscard]] virtual const CaptureError& error() const = 0;
  [[nodiscard]] virtual CaptureFormat format() const = 0;
  /// For progress, as CaptureReader::bytes_read() and bytes_total().
  [[nodiscard]] virtual std::uint64_t bytes_read() const { return 0; }
  [[nodiscard]] virtual std::optional<std::uint64_t> bytes_total() const { return std::nullopt; }
};

/// Appends chunks. Only our serial log is writable.
class SerialCaptureWriter {
 public:
  SerialCaptureWriter() = default;
  SerialCaptureWriter(const SerialCaptureWriter&) = delete;
  SerialCaptureWriter& operator=(const SerialCaptureWriter&) = delete;
  virtual ~SerialCaptureWriter() = default;
  /// Throws std::invalid_argument for a link name with white space (or empty), std::runtime_error when the
  /// output fails or the writer is closed. A chunk of more than 64 bytes is written as several lines with the
  /// same time. A chunk without a timestamp is written at time 0.
  virtual void write(const SerialChunk& chunk) = 0;
  virtual void flush() = 0;
  /// Flushes; the file is complete after every line, so this only makes later writes fail. Idempotent.
  virtual void close() = 0;
  [[nodiscard]] virtual CaptureFormat format() const = 0;
};

/// Reads our serial log. Lines not starting with '(' are comments.
class SerialLogReader final : public SerialCaptureReader {
 public:
  explicit SerialLogReader(std::istream& in) : in_(in) {}
  Status next() override;
  [[nodiscard]] const SerialChunk& chunk() const override { return chunk_; }
  [[nodiscard]] const CaptureError& error() const override { return error_; }
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::serial; }

 private:
  std::istream& in_;
  std::string line_;
  SerialChunk chunk_;
  CaptureError error_;
  std::uint64_t line_number_ = 0;
};

class SerialLogWriter final : public SerialCaptureWriter {
 public:
  explicit SerialLogWriter(std::ostream& out) : out_(out) {}
  void write(const SerialChunk& chunk) override;
  void flush() override;
  void close() override;
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::serial; }
  static constexpr std::size_t kMaxBytesPerLine = 64;

 private:
  std::ostream& out_;
  bool closed_ = false;
};

/// A reader of a serial `format` over a stream the caller keeps alive. Throws std::invalid_argument for a CAN format.
std::unique_ptr<SerialCaptureReader> make_serial_capture_reader(std::istream& in, CaptureFormat format,
                                                                const SerialReadOptions& options = {});
/// Opens a serial capture file for reading, as open_capture_reader() opens CAN captures.
std::unique_ptr<SerialCaptureReader> open_serial_capture_reader(const std::string& path,
                                                                const SerialReadOptions& options = {},
                                                                std::optional<CaptureFormat> format = std::nullopt);

/// A capture file of either kind, told by its content: exactly one of the two readers is set.
struct OpenedCapture {
  CaptureFormat format = CaptureFormat::candump;
  std::unique_ptr<CaptureReader> frames;        ///< CAN formats
  std::unique_ptr<SerialCaptureReader> chunks;  ///< serial formats
  bool compressed = false;                      ///< gzip or zstd (`format` is what it holds)
};
/// Opens any capture file (CAN or serial) with one look at its first bytes, so pipes work. Throws
/// CaptureOpenError as open_capture_reader does.
OpenedCapture open_capture(const std::string& path, const SerialReadOptions& options = {},
                           std::optional<CaptureFormat> format = std::nullopt);

/// A serial-log writer onto a caller's stream (a file: RotatingSerialWriter, recorder.hpp).
std::unique_ptr<SerialCaptureWriter> make_serial_capture_writer(std::ostream& out);

}  // namespace saul::host
