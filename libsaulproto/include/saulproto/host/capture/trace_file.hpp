// Loop trace files (docs/captures.md, "Loop traces"): what `saulctl tune record` writes. A 12-byte header
//   "SAULTRACE 1\n"
// and then the BALANCE console's bytes exactly as they came: 39-byte LOOP_TRACE records (docs/protocol.md section 10)
// and any console text between them. Reading goes through the core's trace::ConsoleDecoder, so a cut or corrupt
// record is reported with its byte offset in the file and the rest is read; memory is constant whatever the file.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <span>
#include <string>
#include <string_view>

#include "saulproto/core/trace.hpp"

namespace saul::host {

inline constexpr std::string_view kTraceMagic = "SAULTRACE 1\n";

/// True when the file starts with kTraceMagic (false when it cannot be read).
bool is_trace_file(const std::string& path);

/// Writes a trace file: the header at open, then bytes as they come. Throws std::runtime_error naming the file.
class TraceFileWriter {
 public:
  explicit TraceFileWriter(const std::string& path);
  ~TraceFileWriter();
  TraceFileWriter(const TraceFileWriter&) = delete;
  TraceFileWriter& operator=(const TraceFileWriter&) = delete;
  void write(std::span<const std::uint8_t> bytes);
  /// Flushes and closes; throws on a write error (a full disk).
  void close();

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
};

/// What a reader is told, in file order. Offsets are bytes from the start of the file (the header included).
struct TraceSink {
  std::function<void(const trace::LoopTrace&, std::uint64_t offset)> record;
  std::function<void(std::string_view line)> line;                      ///< console text (may be empty)
  std::function<void(Reason reason, std::uint64_t offset)> corrupt;     ///< a rejected or cut record
};

/// Reads a whole trace file (path "-": standard input). Throws std::runtime_error when it cannot be opened or is not
/// a trace file (the message names the file and says what it is instead). Returns the decoder's counters.
trace::Counters read_trace_file(const std::string& path, const TraceSink& sink);

/// The same for console bytes in memory without the header (what a bench suite's `trace` step captured from
/// BALANCE's console); offsets are bytes into `bytes`.
trace::Counters read_trace_bytes(std::span<const std::uint8_t> bytes, const TraceSink& sink);

}  // namespace saul::host
