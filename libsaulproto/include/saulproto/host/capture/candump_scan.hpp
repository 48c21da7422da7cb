// Fast reading of candump logs: large reads into one buffer, lines scanned in place (no std::string per line),
// frames handed out in batches. The same lines, frames and errors as CandumpReader (candump.hpp), which stays the
// reader of streams (compressed files, std::istream); this one reads a file descriptor.
//
// Memory is one buffer (block size + the longest line accepted), whatever the file size. A line longer than
// kMaxCandumpLine bytes is never held: it is reported as corrupt ("line longer than ...") at its line number and
// skipped, and reading carries on with the next line. (A long line that does not start with '(' is a comment to
// canplayer, skipped like any other comment.)
//
// A file can be read in ranges (split_candump_blocks): each range starts at a line start, so several threads can
// read one file, each with its own scanner, and the caller puts the results back in file order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/capture.hpp"

namespace saul::host {

/// The longest candump line the scanner accepts (a real one is under 100 bytes).
inline constexpr std::size_t kMaxCandumpLine = 64 * 1024;

/// What one call of CandumpScanner::next_batch found: frames in file order, their interfaces (views into the
/// scanner's buffer, valid until the next call) and the corrupt lines among them.
struct CandumpBatch {
  struct Corrupt {
    std::size_t before = 0;  ///< the corrupt line came before frames[before] (== frames.size(): after the last)
    CaptureError error;      ///< position: line number counted from the scanner's first line (1-based)
  };
  std::vector<CanFrame> frames;
  std::vector<std::string_view> interfaces;
  std::vector<Corrupt> corrupt;
  void clear() noexcept {
    frames.clear();
    interfaces.clear();
    corrupt.clear();
  }
};

class CandumpScanner {
 public:
  /// Reads `fd` (not owned, not closed) from its current position to its end with read(2): files and pipes.
  explicit CandumpScanner(int fd, std::size_t block_bytes = kDefaultBlock);
  /// Reads the byte range [begin, end) of a regular file with pread(2) (begin a line start, e.g. from
  /// split_candump_blocks). Line numbers count from the range's first line.
  CandumpScanner(int fd, std::uint64_t begin, std::uint64_t end, std::size_t block_bytes = kDefaultBlock);
  CandumpScanner(const CandumpScanner&) = delete;
  CandumpScanner& operator=(const CandumpScanner&) = delete;
  ~CandumpScanner();

  /// Fills `batch` (cleared first) with the lines of up to one block (at most kMaxBatch frames); false (batch empty) at the end. Throws
  /// std::runtime_error when reading fails.
  bool next_batch(CandumpBatch& batch);
  /// Lines seen so far (comments and corrupt lines included).
  [[nodiscard]] std::uint64_t lines() const noexcept { return line_; }
  /// Bytes read so far (from the range's start).
  [[nodiscard]] std::uint64_t bytes_read() const noexcept { return consumed_; }
  /// The first line that was neither blank nor a candump line (skipped as a comment), its first 256 bytes: what
  /// a file that yields no frame looks like (describe_non_capture). Empty when there was none.
  [[nodiscard]] const std::string& first_other() const noexcept { return first_other_; }

  static constexpr std::size_t kDefaultBlock = std::size_t{1} << 20;
  /// The most frames one batch holds.
  static constexpr std::size_t kMaxBatch = 4096;

 private:
  void line(std::string_view text, CandumpBatch& batch);
  void too_long(CandumpBatch& batch);
  std::size_t fill(char* dst, std::size_t n);

  int fd_;
  bool positional_;
  std::uint64_t offset_ = 0;  // next pread position
  std::uint64_t end_ = 0;
  std::unique_ptr<char[]> buf_;
  std::size_t cap_;
  std::size_t block_;
  std::size_t head_ = 0, tail_ = 0;
  bool eof_ = false;
  bool skipping_ = false;  // inside an over-long line: drop bytes up to its newline
  std::uint64_t line_ = 0;
  std::uint64_t consumed_ = 0;
  std::string first_other_;
};

/// Calls on_frame(frame, interface) and on_corrupt(error) for everything in `batch`, in file order.
template <class OnFrame, class OnCorrupt>
void for_each_in_order(const CandumpBatch& batch, OnFrame&& on_frame, OnCorrupt&& on_corrupt) {
  std::size_t c = 0;
  const std::size_t n = batch.frames.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (; c < batch.corrupt.size() && batch.corrupt[c].before == i; ++c) on_corrupt(batch.corrupt[c].error);
    on_frame(batch.frames[i], batch.interfaces[i]);
  }
  for (; c < batch.corrupt.size(); ++c) on_corrupt(batch.corrupt[c].error);
}

/// A regular file of uncompressed candump text (told by its first bytes, as detect_capture_format does), open
/// for CandumpScanner; closed when destroyed.
class CandumpFile {
 public:
  /// nullptr when `path` is not such a file or cannot be opened (then read it with open_capture_reader).
  static std::unique_ptr<CandumpFile> open(const std::string& path);
  CandumpFile(const CandumpFile&) = delete;
  CandumpFile& operator=(const CandumpFile&) = delete;
  ~CandumpFile();
  [[nodiscard]] int fd() const noexcept { return fd_; }
  [[nodiscard]] std::uint64_t size() const noexcept { return size_; }

 private:
  CandumpFile(int fd, std::uint64_t size) : fd_(fd), size_(size) {}
  int fd_;
  std::uint64_t size_;
};

/// Reads the byte range [begin, end) of a regular file (begin a line start) with a CandumpScanner and calls
/// prepare(batch, slot) then on_batch(batch, bytes_read, slot) for every batch, in file order, on_batch on the
/// caller's thread. With `ahead` the scanning and `prepare` run on a second thread, up to kAheadBatches batches
/// ahead of on_batch, so reading and parsing take one core and the caller's work the other; the batch's interfaces
/// then point into storage of the batch's own (valid during the call, as without `ahead`). `slot` (below
/// kAheadBatches) names where prepare may leave its results for on_batch: slots are reused once on_batch returned.
/// Rethrows what the scanner, prepare or on_batch threw (the reading thread is stopped first).
inline constexpr std::size_t kAheadBatches = 4;
using CandumpBatchSink = std::function<void(const CandumpBatch& batch, std::uint64_t bytes_read, std::size_t slot)>;
using CandumpBatchPrepare = std::function<void(const CandumpBatch& batch, std::size_t slot)>;
void scan_candump(int fd, std::uint64_t begin, std::uint64_t end, bool ahead, const CandumpBatchSink& on_batch,
                  const CandumpBatchPrepare& prepare = {});

/// Splits [0, size) of a regular file into ranges of about `block` bytes that start at line starts (a range may
/// be longer, never empty): returns the range starts, first 0, plus `size` as the last element. Reads only near
/// the nominal boundaries (and through any line that crosses one). Throws std::runtime_error when reading fails.
std::vector<std::uint64_t> split_candump_blocks(int fd, std::uint64_t size, std::uint64_t block);

}  // namespace saul::host
