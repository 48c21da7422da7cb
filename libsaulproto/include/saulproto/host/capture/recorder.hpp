// Writing a recording into a series of files: `saulctl record --rotate-size 100M --rotate-time 10m`. With rotation
// the files are NAME-000.EXT, NAME-001.EXT, ...; a new file starts before the frame that would go into a file that
// holds max_bytes already, or whose first frame is max_duration older (by the frames' timestamps). Each file is
// complete and readable on its own. With RotationOptions::compress each finished file is compressed on another
// thread (NAME-000.EXT.gz or .zst, the plain file removed); close() waits for the last. open_capture_writer()'s
// file is such a writer without rotation.
#pragma once

#include <cstdint>
#include <fstream>
#include <functional>
#include <future>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/compressed.hpp"
#include "saulproto/host/capture/serial_capture.hpp"

namespace saul::host {

struct RotationOptions {
  std::uint64_t max_bytes = 0;        ///< 0: no rotation by size
  std::uint64_t max_duration_ns = 0;  ///< 0: no rotation by time
  Compression compress = Compression::none;  ///< compress every file once it is finished (the last one at close())
  [[nodiscard]] bool enabled() const { return max_bytes > 0 || max_duration_ns > 0; }
};

/// "run.log", 3 -> "run-003.log"; "dir/run" (no extension), 3 -> "dir/run-003".
std::string numbered_path(const std::string& path, unsigned index);

/// Parses "100M", "1.5G", "64k", "4096" (bytes; k/M/G are powers of 1024, an optional "B" or "iB" after them).
/// Throws std::invalid_argument.
std::uint64_t parse_size(const std::string& text);

/// What the rotating writers of CAN frames and of serial chunks share (Writer: CaptureWriter or
/// SerialCaptureWriter). `on_new_file(path)` is told of every file opened; `make` builds each file's format writer.
/// The path "-" is standard output, appended to when `append`; `packing` compresses as it writes (run.log.gz).
template <class Writer>
class RotatingFiles : public Writer {
 public:
  using MakeWriter = std::function<std::unique_ptr<Writer>(std::ostream&)>;
  RotatingFiles(const std::string& path, RotationOptions rotation, std::function<void(const std::string&)> on_new_file,
                MakeWriter make, Compression packing = Compression::none, bool append = false);
  ~RotatingFiles() override;
  void flush() override;
  void close() override;
  [[nodiscard]] CaptureFormat format() const override { return inner_->format(); }
  /// The file being written; after close() the last file's final name (with .gz/.zst when compressed).
  [[nodiscard]] const std::string& current_path() const { return current_path_; }
  [[nodiscard]] unsigned files() const { return index_ + 1; }
  [[nodiscard]] std::uint64_t bytes_in_file();  ///< of the current file, as written so far

 protected:
  /// Writes one item at `timestamp_ns` with write(format writer), into a new file first when the plan says so.
  void write_item(std::optional<std::uint64_t> timestamp_ns, const std::function<void(Writer&)>& write);
  [[nodiscard]] Writer& writer() const { return *inner_; }
  RotationOptions rotation_;

 private:
  /// Whether an item at timestamp_ns must go into a new file, given what the current file holds.
  [[nodiscard]] bool due(std::optional<std::uint64_t> timestamp_ns);
  /// Opens file `index` (a new, empty one): NAME-<index>.EXT, or the path itself when rotation is off.
  void open(unsigned index);
  /// Closes the current file and hands it to the compressor; after the last (closed_), waits for the compressor.
  void close_current();
  std::string path_;
  /// With RotationOptions::compress: the compression (compress_file) of the files closed so far, each on a thread of
  /// its own that first waits for the file before; the first failure up to the last ("": none).
  std::future<std::string> compressed_;
  std::function<void(const std::string&)> on_new_file_;
  MakeWriter make_;
  Compression packing_;
  bool append_;
  std::unique_ptr<char[]> buffer_;  // file_'s buffer: outlives it
  std::unique_ptr<std::ofstream> file_;
  std::unique_ptr<CompressingBuf> packer_;  // with packing_: between the format writer and the file
  std::unique_ptr<std::ostream> packed_;
  std::unique_ptr<Writer> inner_;           // declared last: destroyed first
  std::string current_path_;
  unsigned index_ = 0;
  std::uint64_t items_in_file_ = 0;
  std::optional<std::uint64_t> file_start_ns_;
  bool closed_ = false;
};

/// CAN frames into one file or a rotating series.
class RotatingCaptureWriter final : public RotatingFiles<CaptureWriter> {
 public:
  /// `make`, when given, builds each file's format writer on its stream (an MCAP writer with options and decoded
  /// channels, report/mcap_signals.hpp); otherwise make_capture_writer(stream, format).
  RotatingCaptureWriter(const std::string& path, CaptureFormat format, RotationOptions rotation = {},
                        std::function<void(const std::string&)> on_new_file = {}, MakeWriter make = {},
                        Compression packing = Compression::none, bool append = false);
  void write(const CanFrame& frame, std::string_view interface) override {
    write_item(frame.timestamp_ns, [&](CaptureWriter& w) { w.write(frame, interface); });
  }
  /// Without rotation only: copy_frames writes into it past write().
  McapCaptureWriter* mcap() noexcept override { return rotation_.enabled() ? nullptr : writer().mcap(); }
};

/// Serial chunks into one serial log or a rotating series.
class RotatingSerialWriter final : public RotatingFiles<SerialCaptureWriter> {
 public:
  /// `make`, when given, builds each file's writer on its stream (an MCAP writer of the decoded messages,
  /// report/mcap_serial.hpp); otherwise make_serial_capture_writer(stream), a serial log.
  RotatingSerialWriter(const std::string& path, RotationOptions rotation = {},
                       std::function<void(const std::string&)> on_new_file = {}, MakeWriter make = {})
      : RotatingFiles(path, rotation, std::move(on_new_file),
                      make ? std::move(make) : MakeWriter(make_serial_capture_writer)) {}
  void write(const SerialChunk& chunk) override {
    write_item(chunk.timestamp_ns, [&](SerialCaptureWriter& w) { w.write(chunk); });
  }
};

}  // namespace saul::host
