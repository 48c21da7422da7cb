// Capture files of CAN traffic, whatever their format (one header per format; docs/captures.md says what each keeps
// and loses), maybe gzip or zstd compressed (compressed.hpp): one reader and one writer interface, format detection
// by content, and factories that open files. The serial links' byte captures share the format enum and detection
// (serial_capture.hpp). Readers stream in constant memory; a corrupt record is reported with its position (line for
// text formats, byte offset for binary ones) and, where the format allows, the reader carries on after it.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <istream>
#include <memory>
#include <optional>
#include <ostream>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "saulproto/core/can_frame.hpp"

namespace saul::host {

class McapCaptureWriter;

enum class CaptureFormat : std::uint8_t {
  candump,  ///< can-utils log lines, "(1700000000.000000) can0 123#1122"
  pcap,     ///< libpcap file, LINKTYPE_CAN_SOCKETCAN (227)
  pcapng,   ///< pcapng, interfaces with LINKTYPE_CAN_SOCKETCAN
  asc,      ///< Vector ASC text, as log2asc and python-can write it
  blf,        ///< Vector BLF (binary logging format), zlib-compressed log containers
  trc,        ///< PEAK PCAN-View/PCAN-Explorer trace, versions 1.0 to 2.1
  csv,        ///< python-can's CSV log: timestamp,arbitration_id,extended,remote,error,dlc,data (base64)
  gvret_csv,  ///< SavvyCAN's native CSV ("GVRET"): Time Stamp,ID,Extended,Dir,Bus,LEN,D1..D8
  mcap,       ///< MCAP (Foxglove, Lichtblick, PlotJuggler, ROS 2): frames on "/can/frames" (mcap.hpp)
  // Byte captures of the UART links (serial_capture.hpp, uart_export.hpp): not CAN, read as SerialChunks.
  serial,         ///< saulctl's serial log, "(1700000000.000000) serial:/dev/ttyUSB0@460800:8N1 interboard AA05..."
  sigrok,         ///< sigrok-cli UART annotation text ("uart-1: AA", "1023-1195 uart-1: AA"), PulseView's export
  sigrok_json,    ///< sigrok-cli --protocol-decoder-jsontrace (Google Trace Event JSON)
  pulseview_csv,  ///< PulseView's decoder table saved as CSV ("Sample","Time","Decoder","Ann Row",...)
};

/// True for the formats that hold serial bytes rather than CAN frames.
constexpr bool holds_serial_bytes(CaptureFormat format) noexcept { return format >= CaptureFormat::serial; }

/// "candump", "pcap", ..., "gvret-csv", "mcap", "serial", "sigrok", "sigrok-json", "pulseview-csv".
std::string_view to_string(CaptureFormat format) noexcept;
/// The inverse of to_string; also accepts "log" for candump. Case-sensitive.
std::optional<CaptureFormat> capture_format_from_name(std::string_view name) noexcept;
/// By file name: .log/.candump, .pcap/.cap, .pcapng/.ntar, .asc, .blf, .trc, .csv (python-can's), .serial
/// (case-insensitive); nullopt otherwise, also for a compressed name (strip_compression_extension first).
std::optional<CaptureFormat> capture_format_from_extension(std::string_view path) noexcept;
/// Every format's to_string() name, in the order help lists them: --input-format's choices.
std::vector<std::string> capture_format_names();
/// For help text: the labels of the CAN formats, then (with_serial) the serial ones: "candump, pcap, ..., GVRET CSV;
/// .gz/.zst too". Every verb's help takes its list from here, so a format added is named wherever files are read.
std::string capture_format_list(bool with_serial);
/// By the first bytes of a file (give at least 512 when the file has them): binary magics (pcap, pcapng, BLF,
/// MCAP), else the first line that tells a text format (candump or serial log, ASC, TRC, the CSVs, sigrok).
/// nullopt when none matches (compressed data included: see detect_compression).
std::optional<CaptureFormat> detect_capture_format(std::span<const std::uint8_t> head) noexcept;

/// What a format can carry, so callers (and tests) know what a round trip keeps.
struct CaptureTraits {
  std::uint64_t resolution_ns;  ///< timestamps are truncated to a multiple of this
  bool interface_names;         ///< names survive (candump, pcapng); otherwise see channel_order
  bool channel_order;           ///< only the order of first appearance survives (ASC channel N reads as can<N-1>)
  bool error_details;           ///< an error frame keeps its class bits and data bytes (not in ASC)
  bool remote_frames;           ///< remote frames can be written (not in SavvyCAN's CSV)
  bool error_frames;            ///< error frames can be written (not in SavvyCAN's CSV)
};
CaptureTraits capture_traits(CaptureFormat format) noexcept;

/// Where a record is: text formats count lines, binary formats count bytes.
enum class PositionKind : std::uint8_t { line, byte_offset };
/// What the reader does after a corrupt record.
enum class Recovery : std::uint8_t { next_line, next_record, next_block, stop };

/// A corrupt record.
struct CaptureError {
  std::size_t column = 0;  ///< text formats: 0-based column where the problem starts; 0 for binary formats
  std::string message;     ///< what is wrong, e.g. "id is not hexadecimal"
  PositionKind kind = PositionKind::line;
  std::uint64_t position = 0;  ///< 1-based line number, or byte offset of the record or block from the file start
  Recovery recovery = Recovery::next_line;
};

/// "FILE:LINE:COLUMN: message (line skipped)" for text, "FILE: byte OFFSET: message (record skipped)" for binary
/// formats ("(block skipped)", "(reading stopped)").
std::string format_capture_error(std::string_view path, const CaptureError& error);

/// A file that cannot be opened or is not the format it claims (bad magic, unsupported link type).
class CaptureOpenError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A batch of frames as every reader hands them out (CaptureReader::next_batch): frames in file order, their
/// interfaces (views valid until the reader's next call) and the corrupt records among them.
struct FrameBatch {
  static constexpr std::size_t kMax = 4096;  ///< the most frames one batch holds
  struct Corrupt {
    std::size_t before = 0;  ///< the corrupt record came before frames[before] (== frames.size(): after the last)
    CaptureError error;      ///< candump read in blocks: the line number counts from the block's first line
  };
  std::vector<CanFrame> frames;
  std::vector<std::string_view> interfaces;
  std::vector<Corrupt> corrupt;
  /// The interface names' text when no reader's buffer holds it (own(), RecordCaptureReader::next_batch).
  std::string names;
  void clear() noexcept {
    frames.clear();
    interfaces.clear();
    corrupt.clear();
  }
  [[nodiscard]] bool empty() const noexcept { return frames.empty() && corrupt.empty(); }
  /// Calls on_frame(i) for frames[i] and on_corrupt(error) for each corrupt record, in file order.
  template <class OnFrame, class OnCorrupt>
  void walk(OnFrame&& on_frame, OnCorrupt&& on_corrupt) const {
    std::size_t c = 0;
    for (std::size_t i = 0; i <= frames.size(); ++i) {
      for (; c < corrupt.size() && corrupt[c].before <= i; ++c) on_corrupt(corrupt[c].error);
      if (i < frames.size()) on_frame(i);
    }
  }
  /// Copies the interface names into `names` and points the views there: the batch then outlives its reader's
  /// next call (a batch read while another thread hands on the one before).
  void own();
};

/// Reads frames in batches: the one reading interface of every format.
class CaptureReader {
 public:
  CaptureReader() = default;
  CaptureReader(const CaptureReader&) = delete;
  CaptureReader& operator=(const CaptureReader&) = delete;
  virtual ~CaptureReader() = default;

  /// Fills `batch` (cleared first) with the next records in file order, up to FrameBatch::kMax frames; false (batch
  /// empty) at the end. A frame's timestamp_ns is set whenever the format has one; formats without interface names
  /// report "can0" (pcap), "can<N-1>" for ASC channel N, "can<i>" for a pcapng interface with no if_name. A
  /// Recovery::stop error is the last record. Never throws for bad content.
  virtual bool next_batch(FrameBatch& batch) = 0;
  [[nodiscard]] virtual CaptureFormat format() const = 0;
  /// For progress: bytes of the file read so far (up to 64 KiB ahead of the record last returned) and its size.
  /// Readers of files opened by path know both (a pipe has no size); readers on a caller's stream say 0 / nullopt.
  [[nodiscard]] virtual std::uint64_t bytes_read() const { return 0; }
  [[nodiscard]] virtual std::optional<std::uint64_t> bytes_total() const { return std::nullopt; }
};

/// How the one read path (read_capture) reads a capture: on one thread, with a second thread reading ahead, or cut
/// into blocks that `threads` threads work on, handed back in file order (the same results).
struct ReadOptions {
  unsigned threads = 2;
  std::uint64_t parallel_from = std::uint64_t{4} << 20;  ///< files this big use `threads` (~20 ms of work on one core)
  std::uint64_t block = std::uint64_t{256} << 10;  ///< bytes per block
  bool live = false;  ///< one thread, each batch handed on as soon as it is read (a pipe from candump -L)
};

/// What the read path read: frames, and corrupt records skipped.
struct ReadCounts {
  std::uint64_t frames = 0;
  std::uint64_t corrupt = 0;
};

/// The one read path for work that takes every frame in file order (convert, plot, replay): `each` gets the batches
/// as next_batch() gives them and returns false to stop reading (from options.parallel_from bytes on, a second
/// thread reads ahead). `progress` (may be empty) gets the records and file bytes read so far after each batch.
/// Throws what reading or `each` throws.
ReadCounts read_in_order(std::unique_ptr<CaptureReader>& reader, const ReadOptions& options,
                         const std::function<bool(const FrameBatch&)>& each,
                         const std::function<void(std::uint64_t records, std::uint64_t bytes)>& progress = {});

/// A reader of one record at a time (ASC, BLF, TRC, the CSV logs, pcapng, MCAP): next_batch() hands out what next()
/// gives.
class RecordCaptureReader : public CaptureReader {
 public:
  bool next_batch(FrameBatch& batch) override;

 protected:
  enum class Status { frame, corrupt, end };
  /// Advances to the next record: on Status::frame, frame_ and name_ describe it; on Status::corrupt, error_ does
  /// (a Recovery::stop error is followed by Status::end).
  virtual Status next() = 0;
  /// What reading one record gave: a frame, a corrupt record, or nothing to hand out (reading goes on).
  enum class Step { frame, corrupt, skipped };
  static Status status(Step step) { return step == Step::frame ? Status::frame : Status::corrupt; }
  CanFrame frame_;
  std::string name_ = "can0";
  CaptureError error_;
};

/// A reader of a text format (ASC, TRC, the CSV logs): next() hands each line, without its CR and (line 1) a UTF-8
/// byte-order mark, to parse_line() until one gives a frame or a corrupt record.
class LineCaptureReader : public RecordCaptureReader {
 protected:
  explicit LineCaptureReader(std::istream& in) : in_(in) {}
  Status next() override;
  virtual Step parse_line(std::string_view line) = 0;
  /// The line is corrupt from `column` on; reading goes on at the next line.
  Step corrupt(std::size_t column, std::string message);

 private:
  std::istream& in_;
  std::string line_;
  std::uint64_t line_number_ = 0;
};

/// Appends frames. Writers that wrap a caller's std::ostream leave it open; writers from open_capture_writer own
/// their file and close it (without throwing) when destroyed if close() was not called.
class CaptureWriter {
 public:
  CaptureWriter() = default;
  CaptureWriter(const CaptureWriter&) = delete;
  CaptureWriter& operator=(const CaptureWriter&) = delete;
  virtual ~CaptureWriter() = default;

  /// Appends one frame seen on `interface` ("" means "can0"). A frame without a timestamp is written at time 0.
  /// Throws std::invalid_argument for a frame that is not valid() (or both remote and error) and
  /// std::runtime_error when the output fails or the writer is closed.
  virtual void write(const CanFrame& frame, std::string_view interface) = 0;
  /// Pushes what is buffered to the file; throws std::runtime_error when that fails.
  virtual void flush() = 0;
  /// Writes what the format needs at its end and flushes: the file is complete and readable. Idempotent.
  virtual void close() = 0;
  [[nodiscard]] virtual CaptureFormat format() const = 0;
  /// The MCAP writer underneath (copy_frames converts into it in blocks), or nullptr.
  virtual McapCaptureWriter* mcap() noexcept { return nullptr; }
};

/// Throws std::invalid_argument when `frame` cannot be written to any capture format.
void check_writable(const CanFrame& frame);

/// What every writer onto a caller's std::ostream shares, so each format says only how it writes a frame (put())
/// and how it ends (finish(), run once by close()). Errors name the format ("ASC: write failed").
class StreamCaptureWriter : public CaptureWriter {
 public:
  void write(const CanFrame& frame, std::string_view interface) final {
    if (closed_) throw std::runtime_error(std::string(name_) + " writer: write after close");
    check_writable(frame);
    if (!std::exchange(started_, true)) begin(frame.timestamp_ns.value_or(0));
    put(frame, interface);
    check_written();
  }
  void flush() override {
    out_.flush();
    check_written();
  }
  void close() final {
    if (closed_) return;
    closed_ = true;
    if (!std::exchange(started_, true)) begin(0);
    finish();
    flush();
  }

 protected:
  /// `header`: the line a text format starts with, written at once.
  StreamCaptureWriter(std::ostream& out, const char* name, std::string_view header = {}) : out_(out), name_(name) {
    if (header.empty()) return;
    out_ << header;
    check_written();
  }
  /// Writes one frame that write() checked.
  virtual void put(const CanFrame& frame, std::string_view interface) = 0;
  /// What the format writes before its first frame, whose time is `first_ns` (0 when close() comes first): a
  /// header that carries the first frame's date (ASC, TRC). Runs once.
  virtual void begin(std::uint64_t /*first_ns*/) {}
  /// What the format writes at its end (a trailer, a header put right), before close()'s flush. Runs once.
  virtual void finish() {}
  /// After writing to out_: a failed stream throws.
  void check_written() const {
    if (!out_) throw std::runtime_error(std::string(name_) + ": write failed");
  }
  [[nodiscard]] bool closed() const { return closed_; }

  std::ostream& out_;

 private:
  const char* name_;
  bool started_ = false;
  bool closed_ = false;
};

/// The name a capture path is opened by: "-" is standard input ("/dev/stdin"; a file called "-" is "./-"), any
/// other path itself: every verb reads `-` as decode does.
inline const char* capture_open_name(const std::string& path) noexcept {
  return path == "-" ? "/dev/stdin" : path.c_str();
}

/// Opens a capture file for reading ("-": standard input; pipes work, nothing is seeked), gzip or zstd told by
/// content. The format is `format`, else detected from the content, else from the extension (without .gz/.zst).
/// Throws CaptureOpenError when the file cannot be opened, its format cannot be told, its header is not usable, it
/// holds serial bytes, or the extension says candump but no line of its first 4 KiB is one. A decompression error
/// ends the reading with one corrupt record (Recovery::stop).
std::unique_ptr<CaptureReader> open_capture_reader(const std::string& path,
                                                   std::optional<CaptureFormat> format = std::nullopt);
/// A capture file's content as bytes in order, decompressed: candump text that the read path cuts into blocks.
class CaptureText {
 public:
  virtual ~CaptureText() = default;
  /// Up to n bytes of the content (fewer only at its end); 0 at the end.
  virtual std::size_t read(char* dst, std::size_t n) = 0;
  /// Bytes of the file read so far (compressed bytes for a compressed file).
  [[nodiscard]] virtual std::uint64_t bytes_read() const = 0;
  /// After the end: a decompression error as one corrupt record (Recovery::stop); nullopt at a clean end.
  [[nodiscard]] virtual std::optional<CaptureError> end_error() const = 0;
  /// Whether the file is gzip or zstd.
  [[nodiscard]] virtual bool compressed() const = 0;
};
/// The content of a candump capture that open_capture() or open_capture_reader() opened, as text from that same
/// open file (a pipe can be read only once). `reader` is given up for the text; nullptr (and `reader` kept) when it
/// is not such a reader, not candump, or something has read from it already.
std::unique_ptr<CaptureText> take_capture_text(std::unique_ptr<CaptureReader>& reader);
/// What the first bytes of a file that is no capture look like, for the message that refuses it: "binary data of
/// no format saulctl knows, starting 28 B1 ...", "a BusMaster log", "a text file whose first line is '...'", ...
std::string describe_non_capture(std::string_view head);
/// A reader of `format` over a stream the caller keeps alive. Throws CaptureOpenError for a bad binary header.
std::unique_ptr<CaptureReader> make_capture_reader(std::istream& in, CaptureFormat format);

/// Creates (truncates) a capture file ("-": standard output). The format is `format`, else from the extension; a
/// name ending in .gz or .zst is compressed (run.log.gz: a gzipped candump log). Throws CaptureOpenError when neither
/// says, for a serial format, or when the file cannot be created. `make` (may be empty) builds the format writer on
/// the opened (maybe compressing) stream, for writers with options of their own (open_mcap_writer).
std::unique_ptr<CaptureWriter> open_capture_writer(
    const std::string& path, std::optional<CaptureFormat> format = std::nullopt,
    const std::function<std::unique_ptr<CaptureWriter>(std::ostream&)>& make = {});
/// A writer of `format` onto a stream the caller keeps alive (and closes).
std::unique_ptr<CaptureWriter> make_capture_writer(std::ostream& out, CaptureFormat format);

/// What copy_frames saw.
struct CopyStats {
  std::uint64_t frames = 0;
  std::uint64_t corrupt = 0;
  std::uint64_t error_frames = 0;
  std::uint64_t remote_frames = 0;
  std::uint64_t left_out = 0;  ///< frames the output format cannot hold (CaptureTraits), not written
  std::vector<std::string> interfaces;  ///< distinct names, in order of first appearance (the first kListed)
  bool more_interfaces = false;          ///< there were more than kListed
  static constexpr std::size_t kListed = 1024;
};

/// Copies every frame of `in` (opened from `path`, `compressed` when gzip or zstd; path may be empty) to `out`
/// (not closed) through read_in_order (into MCAP: McapCaptureWriter::copy). Corrupt records go to on_corrupt (may
/// be empty); remote and error frames that out's format cannot hold are left out and counted. Memory
/// O(CopyStats::kListed) of its own.
CopyStats copy_frames(std::unique_ptr<CaptureReader>& in, CaptureWriter& out,
                      const std::function<void(const CaptureError&)>& on_corrupt,
                      const std::function<void(std::uint64_t records, std::uint64_t bytes)>& progress = {},
                      const std::string& path = {}, bool compressed = false, const ReadOptions& read = {});

/// Sentences saying what a copy into `format` lost (interface names, error-frame details, frames it cannot hold);
/// empty when nothing.
std::vector<std::string> conversion_losses(const CopyStats& stats, CaptureFormat format);

}  // namespace saul::host
