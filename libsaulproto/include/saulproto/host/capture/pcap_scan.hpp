// Fast reading of pcap files (LINKTYPE_CAN_SOCKETCAN): large reads into one buffer, records decoded in place,
// frames handed out in batches (CandumpBatch, interfaces all "can0"). The same frames and the same corrupt-record
// reports (byte offsets, messages, recovery) as PcapReader (pcap.hpp), which stays the reader of streams.
// Memory is one buffer (block size + the longest record accepted), whatever the file size.
#pragma once

#include <cstdint>
#include <memory>

#include "saulproto/host/capture/candump_scan.hpp"

namespace saul::host {

class PcapScanner {
 public:
  /// Reads the regular file `fd` (not owned) of `size` bytes with pread(2). Throws CaptureOpenError when its
  /// first bytes are not a pcap header (open it with open_capture_reader first for the full checks and messages).
  PcapScanner(int fd, std::uint64_t size, std::size_t block_bytes = std::size_t{1} << 20);
  PcapScanner(const PcapScanner&) = delete;
  PcapScanner& operator=(const PcapScanner&) = delete;
  ~PcapScanner();

  /// Fills `batch` (cleared first) with up to CandumpScanner::kMaxBatch records; false (batch empty) at the end.
  bool next_batch(CandumpBatch& batch);
  [[nodiscard]] std::uint64_t bytes_read() const noexcept { return offset_; }

 private:
  std::size_t ensure(std::size_t n);
  void corrupt(CandumpBatch& batch, std::uint64_t at, Recovery recovery, std::string message);

  int fd_;
  std::uint64_t size_;
  std::unique_ptr<std::uint8_t[]> buf_;
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
