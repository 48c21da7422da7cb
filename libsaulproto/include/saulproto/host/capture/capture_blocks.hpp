// A capture file read in blocks on several threads, for the one read path (src/host/capture/read_path.hpp). Each
// block starts at a record's start (a candump line, a pcap record, a pcapng packet block), so every thread reads its
// own blocks and the caller puts the results back in file order. Uncompressed regular candump, pcap and pcapng files
// only; CaptureTextBlocks cuts a candump log's text as it is read (compressed, a pipe). A corrupt file reads as it
// does in one piece: where no cut can be made safely, the rest of the file is one block.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"

namespace saul::host {
namespace detail {
class BlockCutter;
}

class CaptureBlocks {
 public:
  /// `path` cut into blocks of about `block_bytes`; nullptr when it is not an uncompressed candump, pcap or pcapng
  /// regular file. Throws std::system_error when reading fails.
  static std::unique_ptr<CaptureBlocks> open(const std::string& path, std::uint64_t block_bytes);
  /// The same over an open file (`fd` not owned) of a known format (nullptr when its header says otherwise).
  static std::unique_ptr<CaptureBlocks> of(int fd, std::uint64_t size, CaptureFormat format, std::uint64_t block_bytes);
  CaptureBlocks(const CaptureBlocks&) = delete;
  CaptureBlocks& operator=(const CaptureBlocks&) = delete;
  ~CaptureBlocks();

  [[nodiscard]] CaptureFormat format() const noexcept { return format_; }
  /// Whether there is a block k. Thread-safe. A pcap or pcapng file is cut as it is read: this walks its record
  /// headers up to block k's start (serially, behind a lock), and read(k) walks on to its end.
  [[nodiscard]] bool has(std::size_t k) const;
  /// The number of blocks (cuts the whole file first).
  [[nodiscard]] std::size_t count() const;

  /// What a reading thread keeps from block to block (no allocation per block).
  struct Scratch {
    FrameBatch batch;
    std::vector<std::uint8_t> bytes;  // pcapng: the header blocks and the block, read in place
  };
  /// What reading a block found besides its frames.
  struct Read {
    /// candump: the block's lines (its corrupt records' lines count from the block's first line); else 0.
    std::uint64_t lines = 0;
    std::uint64_t bytes = 0;  ///< the block's share of the file (the blocks' shares add up to its size)
  };
  /// Block k's (has(k)) frames and corrupt records, batch by batch in file order, to each(batch) until it returns
  /// false; blocks can be read at once on several threads, each with its own Scratch. A candump block's lines go to
  /// `taker` first (CandumpReader::next_batch). Throws std::system_error when reading fails.
  Read read(std::size_t k, Scratch& scratch, const std::function<bool(const FrameBatch&)>& each,
            CandumpLineTaker* taker = nullptr) const;
  /// The time of the first frame that `keep` accepts (every frame when empty), 0 for a frame without one; nullopt
  /// when none does. Reads the blocks in order up to that frame.
  [[nodiscard]] std::optional<std::uint64_t> first_time(const std::function<bool(const CanFrame&)>& keep) const;

 private:
  CaptureBlocks(int fd, std::uint64_t size, CaptureFormat format);
  struct Range {
    std::uint64_t begin = 0, end = 0;
    std::uint64_t prefix_end = 0;  // pcapng: the header blocks that every block is read after
    bool lent = false;             // the bytes [begin, end) are in `lend` from lend[offset] on (range())
    std::size_t offset = 0;
  };
  /// Block k's bytes, cutting the file that far when needed; nullopt when there is no block k. When it is this call
  /// that cuts block k's end and the cutter still holds the block's bytes, they are swapped into `lend`.
  [[nodiscard]] std::optional<Range> range(std::size_t k, std::vector<std::uint8_t>* lend = nullptr) const;
  /// Cuts until `starts` starts are known (or the cut ends), lending the bytes of the block whose end is found last to
  /// `lend` (r.lent, r.offset). mutex_ held.
  void cut(std::size_t starts, std::vector<std::uint8_t>* lend, Range& r) const;
  int fd_;
  bool owned_ = false;  // open() opened fd_: closed with this
  std::uint64_t size_;
  CaptureFormat format_;
  mutable std::mutex mutex_;  // guards what follows: the cut goes on as blocks are read
  mutable std::vector<std::uint64_t> starts_;  // block k is [starts_[k], starts_[k + 1])
  mutable std::unique_ptr<detail::BlockCutter> cutter_;  // finds the starts (null: all known up front, candump)
  mutable bool cut_all_ = false;                         // the cutter found the last start
  mutable std::uint64_t prefix_end_ = 0;
  mutable std::vector<std::uint8_t> prefix_;  // pcapng: the file's bytes [0, prefix_end_), once a block k > 0 asked
};

/// A candump log read from a stream (CaptureText: compressed, or a pipe) and cut into blocks of whole lines, taken
/// by the threads in turn. A line longer than kMaxCandumpLine keeps its first kMaxCandumpLine + 1 bytes (reported as
/// too long by the scanner), the rest of it is dropped: a block holds at most about twice the block size.
class CaptureTextBlocks {
 public:
  CaptureTextBlocks(CaptureText& text, std::size_t block_bytes)
      : text_(text), block_(block_bytes == 0 ? 1 : block_bytes) {}
  /// Block k's lines into `out` once blocks 0 .. k - 1 were taken (waits for that), and the file bytes read for
  /// them; false when the text ended before it.
  bool take(std::size_t k, std::string& out, std::uint64_t& bytes_read);

 private:
  void read_more(std::string& out);
  void drop_rest_of_line(std::string& out);

  CaptureText& text_;
  std::size_t block_;
  std::mutex mutex_;
  std::condition_variable turn_;
  std::size_t next_ = 0;  // the block whose turn it is
  std::string carry_;     // text read after the last block's last newline
  bool end_ = false;
  std::uint64_t counted_ = 0;  // file bytes given to blocks so far
};

}  // namespace saul::host
