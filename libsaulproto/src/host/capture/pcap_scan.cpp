#include "saulproto/host/capture/pcap_scan.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <span>
#include <system_error>

#include "capture_io.hpp"
#include "saulproto/host/capture/pcap.hpp"

namespace saul::host {
namespace pcap_scan {  // named: pcap.cpp has the same constants in its anonymous namespace (unity builds)

constexpr std::uint32_t kMagicMicro = 0xA1B2'C3D4;
constexpr std::uint32_t kMagicNano = 0xA1B2'3C4D;
constexpr std::size_t kCanFdMtu = 72;
constexpr std::uint32_t kMaxRecord = 256 * 1024;  // as PcapReader: a longer length field is garbage

}  // namespace pcap_scan

PcapScanner::PcapScanner(int fd, std::uint64_t size, std::size_t block_bytes)
    : fd_(fd), size_(size), cap_(block_bytes + pcap_scan::kMaxRecord + 16), block_(block_bytes) {
  buf_.reset(new std::uint8_t[cap_]);
  data_ = buf_.get();
  read_header();
}

PcapScanner::PcapScanner(int fd, std::uint64_t size, std::uint64_t begin, std::uint64_t end,
                         std::span<const std::uint8_t> bytes)
    : fd_(fd), size_(size), cap_(0), block_(0) {
  read_header();
  data_ = bytes.data();
  tail_ = bytes.size();
  offset_ = begin < 24 ? 24 : begin;
  read_to_ = offset_ + bytes.size();
  size_ = end < size ? end : size;
}

void PcapScanner::read_header() {
  std::uint8_t h[4];
  if (size_ < 24 || ::pread(fd_, h, 4, 0) != 4) throw CaptureOpenError("not a pcap file");
  const std::uint32_t magic = detail::load_u32(h, false);
  if (magic == pcap_scan::kMagicMicro || magic == pcap_scan::kMagicNano) {
    big_ = false;
  } else if (detail::load_u32(h, true) == pcap_scan::kMagicMicro || detail::load_u32(h, true) == pcap_scan::kMagicNano) {
    big_ = true;
  } else {
    throw CaptureOpenError("not a pcap file");
  }
  nano_ = detail::load_u32(h, big_) == pcap_scan::kMagicNano;
}

PcapScanner::PcapScanner(int fd, std::uint64_t size, std::uint64_t begin, std::uint64_t end, std::size_t block_bytes)
    : PcapScanner(fd, size, block_bytes) {
  offset_ = read_to_ = begin < 24 ? 24 : begin;
  size_ = end < size ? end : size;
}

PcapScanner::~PcapScanner() = default;

namespace {

class PcapCutter final : public detail::BlockCutter {
 public:
  PcapCutter(int fd, std::uint64_t size, bool big, std::uint64_t block)
      : BlockCutter(24, size), window_(fd, size, detail::window_bytes(block)), size_(size), block_(block == 0 ? 1 : block),
        big_(big) {}
  bool lend(std::uint64_t from, std::uint64_t to, std::vector<std::uint8_t>& into, std::size_t& offset) override {
    return window_.lend(from, to, into, offset);
  }

 private:
  bool walk(std::uint64_t& start) override {
    while (const std::uint8_t* h = window_.at(pos_, 16)) {
      const std::uint32_t incl = detail::load_u32(h + 8, big_);
      if (incl > pcap_scan::kMaxRecord) break;
      // Eight records of this one's length in a row (a SocketCAN capture is all 16-byte packets) are stepped over
      // at once, their lengths loaded side by side: one record at a time, each length waits for the one before.
      // Only where no record among them would end the walk or start a block.
      const std::uint64_t stride = 16 + std::uint64_t{incl};
      if (incl <= kRunRecord && pos_ + 8 * stride < size_ && pos_ + 8 * stride - last_ < block_) {
        if (const std::uint8_t* run = window_.at(pos_, 7 * stride + 16)) {
          bool same = true;
          for (std::uint64_t k = 1; k < 8; ++k) same &= detail::load_u32(run + k * stride + 8, big_) == incl;
          if (same) {
            pos_ += 8 * stride;
            continue;
          }
        }
      }
      const std::uint64_t next = pos_ + 16 + incl;
      if (next >= size_) break;
      pos_ = next;
      if (next - last_ >= block_) {
        start = last_ = next;
        return true;
      }
    }
    return false;  // from the first implausible or cut record on, the rest is one block
  }

  static constexpr std::uint32_t kRunRecord = 4096;  // longer records are stepped one at a time
  detail::HeaderWindow window_;
  std::uint64_t size_;
  std::uint64_t block_;
  bool big_;
  std::uint64_t pos_ = 24;
  std::uint64_t last_ = 24;  // the last start given
};

}  // namespace

std::unique_ptr<detail::BlockCutter> detail::pcap_block_cutter(int fd, std::uint64_t size, bool big,
                                                               std::uint64_t block) {
  return std::make_unique<PcapCutter>(fd, size, big, block);
}

std::vector<std::uint64_t> PcapScanner::block_starts(std::uint64_t block) const {
  std::vector<std::uint64_t> starts;
  const auto cut = detail::pcap_block_cutter(fd_, size_, big_, block);
  std::uint64_t start = 0;
  while (cut->next(start)) starts.push_back(start);
  return starts;
}

// At least n bytes from head_ in the buffer, or all that is left of the file; returns how many there are.
std::size_t PcapScanner::ensure(std::size_t n) {
  if (tail_ - head_ >= n || read_to_ >= size_) return tail_ - head_;
  if (head_ > 0) {
    std::memmove(buf_.get(), buf_.get() + head_, tail_ - head_);  // (bytes in memory: all there, never here)
    tail_ -= head_;
    head_ = 0;
  }
  while (tail_ < n && read_to_ < size_) {
    std::size_t want = cap_ - tail_ < block_ ? cap_ - tail_ : block_;
    if (want > size_ - read_to_) want = static_cast<std::size_t>(size_ - read_to_);
    const ssize_t got = ::pread(fd_, buf_.get() + tail_, want, static_cast<off_t>(read_to_));
    if (got < 0) {
      if (errno == EINTR) continue;
      throw std::system_error(errno, std::generic_category(), "reading the capture");
    }
    if (got == 0) {
      size_ = read_to_;  // the file shrank
      break;
    }
    tail_ += static_cast<std::size_t>(got);
    read_to_ += static_cast<std::uint64_t>(got);
  }
  return tail_ - head_;
}

void PcapScanner::corrupt(FrameBatch& batch, std::uint64_t at, Recovery recovery, std::string message) {
  FrameBatch::Corrupt bad;
  bad.before = batch.frames.size();
  bad.error.column = 0;
  bad.error.kind = PositionKind::byte_offset;
  bad.error.position = at;
  bad.error.recovery = recovery;
  bad.error.message = std::move(message);
  if (recovery == Recovery::stop) stopped_ = true;
  batch.corrupt.push_back(std::move(bad));
}

// Record by record exactly as PcapReader::next() reads them.
bool PcapScanner::next_batch(FrameBatch& batch) {
  batch.clear();
  while (!stopped_ && batch.frames.size() < CandumpScanner::kMaxBatch) {
    const std::uint64_t start = offset_;
    const std::size_t have_header = ensure(16);
    if (have_header == 0) break;
    if (have_header < 16) {
      corrupt(batch, start, Recovery::stop,
              fmt::format("file ends inside a record header ({} of 16 bytes)", have_header));
      break;
    }
    const std::uint8_t* h = data_ + head_;
    const std::uint32_t sec = detail::load_u32(h, big_);
    const std::uint32_t frac = detail::load_u32(h + 4, big_);
    const std::uint32_t incl = detail::load_u32(h + 8, big_);
    if (incl > pcap_scan::kMaxRecord) {
      corrupt(batch, start, Recovery::stop, fmt::format("record length {} is not plausible", incl));
      break;
    }
    const std::size_t have = ensure(16 + std::size_t{incl}) - 16;
    if (have < incl) {
      corrupt(batch, start, Recovery::stop, fmt::format("file ends inside a record ({} of {} bytes)", have, incl));
      break;
    }
    const std::uint8_t* packet = data_ + head_ + 16;
    head_ += 16 + std::size_t{incl};
    offset_ += 16 + std::uint64_t{incl};
    if (frac >= (nano_ ? 1'000'000'000U : 1'000'000U)) {
      corrupt(batch, start, Recovery::next_record, fmt::format("timestamp fraction {} is not below one second", frac));
      continue;
    }
    if (incl > pcap_scan::kCanFdMtu) {
      corrupt(batch, start, Recovery::next_record,
              fmt::format("record of {} bytes is longer than any SocketCAN packet", incl));
      continue;
    }
    CanFrame& f = batch.frames.emplace_back();
    f.timestamp_ns = std::uint64_t{sec} * 1'000'000'000ULL + (nano_ ? frac : std::uint64_t{frac} * 1000U);
    const std::string_view why = decode_socketcan_packet(std::span<const std::uint8_t>(packet, incl), f);
    if (!why.empty()) {
      batch.frames.pop_back();
      corrupt(batch, start, Recovery::next_record, std::string(why));
      continue;
    }
    batch.interfaces.push_back("can0");
  }
  return !batch.frames.empty() || !batch.corrupt.empty();
}

}  // namespace saul::host
