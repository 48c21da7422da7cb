// Fast reading of pcap files (LINKTYPE_CAN_SOCKETCAN): large reads into one buffer, records decoded in place,
// frames handed out in batches (FrameBatch, interfaces all "can0"). The same frames and the same corrupt-record
// reports (byte offsets, messages, recovery) as PcapReader (pcap.hpp), which stays the reader of streams.
// Memory is one buffer (block size + the longest record accepted), whatever the file size.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "saulproto/host/capture/candump_scan.hpp"

namespace saul::host {

class PcapScanner {
 public:
  /// Reads the regular file `fd` (not owned) of `size` bytes with pread(2). Throws CaptureOpenError when its
  /// first bytes are not a pcap header (open it with open_capture_reader first for the full checks and messages).
  PcapScanner(int fd, std::uint64_t size, std::size_t block_bytes = std::size_t{1} << 20);
  /// Reads only the records from byte `begin` (a record's start, e.g. from block_starts()) to `end`.
  PcapScanner(int fd, std::uint64_t size, std::uint64_t begin, std::uint64_t end,
              std::size_t block_bytes = std::size_t{1} << 20);
  /// The same with the file's bytes [begin, end) already in memory (`bytes`, kept alive by the caller): nothing is
  /// read but the header's magic.
  PcapScanner(int fd, std::uint64_t size, std::uint64_t begin, std::uint64_t end, std::span<const std::uint8_t> bytes);
  PcapScanner(const PcapScanner&) = delete;
  PcapScanner& operator=(const PcapScanner&) = delete;
  ~PcapScanner();

  /// Fills `batch` (cleared first) with up to CandumpScanner::kMaxBatch records; false (batch empty) at the end.
  bool next_batch(FrameBatch& batch);
  [[nodiscard]] std::uint64_t bytes_read() const noexcept { return offset_; }

  /// Record starts that cut the file into blocks of about `block` bytes, for decoding blocks on several threads:
  /// {24, s1, s2, ..., size}. Walks the record headers (one read of the file in large pieces); from the first
  /// implausible or cut record on, the rest is one block, so a corrupt file reads as it does in one piece.
  [[nodiscard]] std::vector<std::uint64_t> block_starts(std::uint64_t block) const;
  /// The file's byte order (for cutting it one block at a time: CaptureBlocks).
  [[nodiscard]] bool big_endian() const noexcept { return big_; }

 private:
  void read_header();
  std::size_t ensure(std::size_t n);
  void corrupt(FrameBatch& batch, std::uint64_t at, Recovery recovery, std::string message);

  int fd_;
  std::uint64_t size_;
  std::unique_ptr<std::uint8_t[]> buf_;
  const std::uint8_t* data_ = nullptr;  // buf_, or the bytes given
  std::size_t cap_;
  std::size_t block_;
  std::size_t head_ = 0, tail_ = 0;
  std::uint64_t offset_ = 24;   // file offset of buf_[head_]
  std::uint64_t read_to_ = 24;  // file offset of buf_[tail_]
  bool big_ = false;
  bool nano_ = false;
  bool stopped_ = false;
};

}  // namespace saul::host
