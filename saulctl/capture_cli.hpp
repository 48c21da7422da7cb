// Options shared by the verbs that read capture files (decode, stats, plot, replay): how to read logic-analyser
// exports that do not say everything (--protocol, --samplerate), and --input-format for a file whose content
// should not decide.
#pragma once

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "saulproto/host/capture/serial_capture.hpp"

namespace saulctl {

struct SerialCliOptions {
  std::string protocol;    ///< "", interboard, crsf, pride, raw
  std::string samplerate;  ///< "", "10M", "10MHz", "1000000"
  std::string input_format;  ///< "", or a capture format name (--input-format)
};

/// Adds --protocol, --samplerate and --input-format to a verb.
void add_serial_read_options(CLI::App* cmd, SerialCliOptions& options);
/// The reader options they give (the forced format, and .protocol for links whose capture names none); throws
/// CLI::ValidationError for a bad sample rate.
saul::host::SerialReadOptions serial_read_options(const SerialCliOptions& options);
/// For a verb that reads its capture more than once (replay, plot): throws CLI::ValidationError saying why a file that
/// can be read only once (a pipe, "-" on a pipe) will not do. A missing file or a directory is left to open_capture().
void refuse_read_once(std::string_view verb, const std::string& file, std::string_view reads);
/// "10M", "10MHz", "200k", "1000000", "1e6" -> Hz. Throws CLI::ValidationError.
std::uint64_t parse_rate_hz(const std::string& text);

/// From what size decode and stats put the second core to work on a file (blocks on both cores, or a reading
/// thread): below 4 MiB (~20 ms of work) a thread costs more than it saves; tests give 1.
inline constexpr const char* kParallelFrom = "4MiB";
/// Adds --parallel-from SIZE (default kParallelFrom) to a verb.
void add_parallel_from_option(CLI::App* cmd, std::string& size);
/// Bytes of a size option ("4MiB", "64k", "1"); throws CLI::ValidationError naming `option`.
std::uint64_t parse_size_option(const std::string& option, const std::string& text);

/// A progress line on stderr ("decode: 42% of 2.8 GB, 12 345 678 records, 3.1 s"), redrawn at most 4 times a
/// second after the first half second; only when stderr is a terminal and, for a verb that prints records to
/// stdout, stdout is not. $SAUL_PROGRESS=0 turns it off, =1 forces it on (redrawn at every check: for tests).
class Progress {
 public:
  Progress(std::string verb, bool stdout_carries_records);
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  ~Progress() { finish(); }
  /// `records` more read. Cheap: looks at the clock once every 4096 records.
  void update_many(std::uint64_t records, std::uint64_t bytes_read, std::optional<std::uint64_t> bytes_total) {
    const std::uint64_t before = records_;
    records_ += records;
    if (enabled_ && (before >> 12) != (records_ >> 12)) draw(bytes_read, bytes_total);
  }
  /// `records` read so far in all (the read path's progress sink).
  void read_so_far(std::uint64_t records, std::uint64_t bytes_read, std::optional<std::uint64_t> bytes_total) {
    update_many(records - records_, bytes_read, bytes_total);
  }
  /// Clears the line (also done by the destructor).
  void finish();

 private:
  void draw(std::uint64_t bytes_read, std::optional<std::uint64_t> bytes_total);
  std::string verb_;
  bool enabled_ = false;
  bool forced_ = false;
  bool drawn_ = false;
  std::uint64_t records_ = 0;
  std::chrono::steady_clock::time_point start_, last_;
};

/// Reports a corrupt record of `path` on stderr ("saulctl VERB: FILE:LINE:COL: what"), clearing `progress`'s line
/// first so that the message gets a line of its own (the progress line comes back at its next draw).
std::function<void(const saul::host::CaptureError&)> corrupt_reporter(const std::string& path, Progress* progress);

/// Reads every chunk of a serial capture, drawing `progress`: a corrupt line is reported (corrupt_reporter) and
/// counted in `corrupt`, every other chunk handed to `on_chunk`.
void read_serial_chunks(const std::string& path, saul::host::SerialCaptureReader& reader,
                        ::saulctl::Progress& progress, std::uint64_t& corrupt,
                        const std::function<void(const saul::host::SerialChunk&)>& on_chunk);

}  // namespace saulctl
