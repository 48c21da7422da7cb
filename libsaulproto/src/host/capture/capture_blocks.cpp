#include "saulproto/host/capture/capture_blocks.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <cerrno>
#include <span>
#include <system_error>

#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/compressed.hpp"
#include "saulproto/host/capture/pcap.hpp"
#include "saulproto/host/capture/pcapng.hpp"
#include "capture_io.hpp"

namespace saul::host {
namespace {

/// Reads [at, at + n) of fd into `out` from out[used] on (growing out when needed); returns the new `used`.
std::size_t append_range(int fd, std::uint64_t at, std::uint64_t n, std::vector<std::uint8_t>& out, std::size_t used) {
  if (out.size() < used + n) out.resize(used + static_cast<std::size_t>(n));
  int error = 0;
  const std::size_t done = detail::pread_full(fd, out.data() + used, static_cast<std::size_t>(n), at, &error);
  if (error != 0) throw std::system_error(error, std::generic_category(), "reading the capture");
  return used + done;  // fewer than n when the file shrank: what there is
}

}  // namespace

std::unique_ptr<CaptureBlocks> CaptureBlocks::of(int fd, std::uint64_t size, CaptureFormat format,
                                                 std::uint64_t block_bytes) {
  std::unique_ptr<CaptureBlocks> blocks(new CaptureBlocks(fd, size, format));
  switch (format) {
    case CaptureFormat::candump:
      blocks->starts_ = split_candump_blocks(fd, size, block_bytes);
      break;
    case CaptureFormat::pcap:
      try {
        const PcapReader header(fd, size, 0, 0);  // reads the file header alone
        blocks->cutter_ = detail::pcap_block_cutter(fd, size, header.big_endian(), block_bytes);
      } catch (const CaptureOpenError&) {
        return nullptr;  // not a pcap header after all
      }
      break;
    case CaptureFormat::pcapng:
      blocks->cutter_ = detail::pcapng_block_cutter(fd, size, block_bytes);
      break;
    default:
      return nullptr;
  }
  return blocks;
}

CaptureBlocks::CaptureBlocks(int fd, std::uint64_t size, CaptureFormat format)
    : fd_(fd), size_(size), format_(format) {}

void CaptureBlocks::cut(std::size_t starts, std::vector<std::uint8_t>* lend, Range& r) const {
  while (cutter_ && !cut_all_ && starts_.size() < starts) {
    std::uint64_t start = 0;
    if (!cutter_->next(start)) {
      cut_all_ = true;
      break;
    }
    starts_.push_back(start);
    prefix_end_ = cutter_->prefix_end();
    // the walk that found block k's end read its bytes: its reader takes them instead of reading them again
    if (lend != nullptr && starts_.size() == starts)
      r.lent = cutter_->lend(starts_[starts - 2], start, *lend, r.offset);
    // The size comes last. The cutter stays: the last block's bytes may still be in its window for range().
    if (start >= size_) cut_all_ = true;
  }
}

std::optional<CaptureBlocks::Range> CaptureBlocks::range(std::size_t k, std::vector<std::uint8_t>* lend) const {
  std::lock_guard lock(mutex_);
  Range r;
  cut(k + 2, lend, r);
  if (starts_.size() < k + 2) return std::nullopt;
  r.begin = starts_[k];
  r.end = starts_[k + 1];
  r.prefix_end = prefix_end_;
  // Block k's end was found by a walk that had no reader to lend to (has(k + 1) on another thread got there first):
  // the window may hold its bytes still.
  if (lend != nullptr && !r.lent && cutter_) r.lent = cutter_->lend(r.begin, r.end, *lend, r.offset);
  if (format_ == CaptureFormat::pcapng && k > 0 && prefix_.size() != prefix_end_)  // read once, copied per block
    prefix_.resize(append_range(fd_, 0, prefix_end_, prefix_, 0));
  return r;
}

bool CaptureBlocks::has(std::size_t k) const {
  {
    // A block that starts before the end is there: its end is cut when it is read, so that the bytes the cut reads
    // go to its reader (range(k, lend)).
    std::lock_guard lock(mutex_);
    Range unused;
    cut(k + 1, nullptr, unused);
    if (starts_.size() > k && starts_[k] < size_) return true;
  }
  return range(k).has_value();
}

std::size_t CaptureBlocks::count() const {
  std::size_t k = 0;
  while (has(k)) ++k;
  return k;
}

std::unique_ptr<CaptureBlocks> CaptureBlocks::open(const std::string& path, std::uint64_t block_bytes) {
  struct Closer {  // closes the file on every way out but the blocks' own
    int fd;
    ~Closer() {
      if (fd >= 0) ::close(fd);
    }
  } file{::open(capture_open_name(path), O_RDONLY | O_CLOEXEC)};
  struct stat st {};
  std::uint8_t head[4096];
  ssize_t got = 0;
  if (file.fd < 0 || ::fstat(file.fd, &st) != 0 || !S_ISREG(st.st_mode) ||
      (got = ::pread(file.fd, head, sizeof head, 0)) <= 0)
    return nullptr;
  const std::span<const std::uint8_t> first(head, static_cast<std::size_t>(got));
  const auto format = detect_capture_format(first);
  if (detect_compression(first) != Compression::none || !format) return nullptr;
  auto blocks = of(file.fd, static_cast<std::uint64_t>(st.st_size), *format, block_bytes);
  if (!blocks) return nullptr;
  blocks->owned_ = true;
  file.fd = -1;
  return blocks;
}

CaptureBlocks::~CaptureBlocks() {
  if (owned_) ::close(fd_);
}

CaptureBlocks::Read CaptureBlocks::read(std::size_t k, Scratch& scratch,
                                        const std::function<bool(const FrameBatch&)>& each,
                                        CandumpLineTaker* taker) const {
  const auto r = range(k, format_ == CaptureFormat::candump ? nullptr : &scratch.bytes);
  Read read;
  if (!r) return read;
  const std::uint64_t begin = r->begin, end = r->end, prefix_end = r->prefix_end;
  FrameBatch& batch = scratch.batch;
  const std::uint8_t* const lent = r->lent ? scratch.bytes.data() + r->offset : nullptr;
  switch (format_) {
    case CaptureFormat::candump: {
      CandumpReader scanner(fd_, begin, end, std::size_t{256} << 10);
      while (scanner.next_batch(batch, taker) && each(batch)) {
      }
      read.lines = scanner.lines();
      read.bytes = end - begin;
      break;
    }
    case CaptureFormat::pcap: {
      PcapReader scanner(fd_, size_, begin, end, std::span<const std::uint8_t>(lent, lent ? end - begin : 0),
                         std::size_t{256} << 10);
      while (scanner.next_batch(batch) && each(batch)) {
      }
      read.bytes = end - (k == 0 ? 0 : begin);  // block 0 counts the file header too
      break;
    }
    case CaptureFormat::pcapng: {
      // Block k > 0 is read after the header blocks; what its reader says of them is block 0's to say. The block's
      // bytes lent by the cutter have room for them in front.
      std::span<const std::uint8_t> bytes;
      std::size_t prefix = 0;
      std::size_t from = r->offset;
      if (lent != nullptr && k > 0 && prefix_end <= from && prefix_.size() == prefix_end) {
        from -= static_cast<std::size_t>(prefix_end);
        std::memcpy(scratch.bytes.data() + from, prefix_.data(), prefix_.size());  // prefix_ is set before range() returns
        prefix = prefix_.size();
      }
      if (lent != nullptr && prefix == (k > 0 ? prefix_end : 0)) {
        bytes = std::span<const std::uint8_t>(scratch.bytes.data() + from, prefix + (end - begin));
      } else {
        prefix = k > 0 ? append_range(fd_, 0, prefix_end, scratch.bytes, 0) : 0;
        const std::size_t used = append_range(fd_, begin, end - begin, scratch.bytes, prefix);
        bytes = std::span<const std::uint8_t>(scratch.bytes.data(), used);
      }
      PcapngReader reader(bytes);
      while (reader.next_batch(batch, FrameBatch::kMax)) {
        for (auto& c : batch.corrupt) c.error.position += begin - prefix;
        if (k > 0) {
          const auto in_prefix = std::remove_if(batch.corrupt.begin(), batch.corrupt.end(),
                                                [&](const auto& c) { return c.error.position < begin; });
          batch.corrupt.erase(in_prefix, batch.corrupt.end());
        }
        if (!each(batch)) break;
      }
      read.bytes = end - begin;
      break;
    }
    default:
      break;
  }
  return read;
}

std::optional<std::uint64_t> CaptureBlocks::first_time(const std::function<bool(const CanFrame&)>& keep) const {
  Scratch scratch;
  std::optional<std::uint64_t> first;
  for (std::size_t k = 0; !first && has(k); ++k)
    read(k, scratch, [&](const FrameBatch& batch) {
      for (const auto& f : batch.frames)
        if (!keep || keep(f)) {
          first = f.timestamp_ns.value_or(0);
          return false;
        }
      return true;
    });
  return first;
}

// ---- compressed candump text in blocks ----------------------------------------------------------------------------

bool CaptureTextBlocks::take(std::size_t k, std::string& out, std::uint64_t& bytes_read) {
  std::unique_lock lock(mutex_);
  turn_.wait(lock, [&] { return next_ == k; });
  struct Next {  // the next block's turn, whatever happens here
    CaptureTextBlocks& t;
    ~Next() {
      ++t.next_;
      t.turn_.notify_all();
    }
  } next{*this};
  out.clear();
  out.swap(carry_);
  for (;;) {
    const std::size_t nl = out.rfind('\n');
    if (nl != std::string::npos && (out.size() >= block_ || end_)) {  // whole lines, the rest for the next block
      carry_.assign(out, nl + 1);
      out.resize(nl + 1);
      break;
    }
    if (end_) break;  // what is left: the last line, without its newline
    const std::size_t line = nl == std::string::npos ? 0 : nl + 1;
    if (out.size() - line > kMaxCandumpLine + 1) {
      out.resize(line + kMaxCandumpLine + 1);
      drop_rest_of_line(out);
      continue;
    }
    read_more(out);
  }
  bytes_read = text_.bytes_read() - counted_;
  counted_ += bytes_read;
  return !out.empty();
}

void CaptureTextBlocks::read_more(std::string& out) {
  const std::size_t at = out.size();
  out.resize(at + block_);
  const std::size_t got = text_.read(out.data() + at, block_);
  out.resize(at + got);
  if (got == 0) end_ = true;
}

/// Reads past the current line's newline, which ends `out`'s line; what follows it goes on `out`.
void CaptureTextBlocks::drop_rest_of_line(std::string& out) {
  std::string rest;
  for (;;) {
    read_more(rest);
    const std::size_t nl = rest.find('\n');
    if (nl != std::string::npos) {
      out.append(rest, nl, std::string::npos);
      return;
    }
    rest.clear();
    if (end_) return;
  }
}

}  // namespace saul::host
