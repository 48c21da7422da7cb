// Private helpers of the capture formats: byte-order loads and stores, reading that counts the offset and skips
// without seeking (so pipes work), a window for walking headers, closing a writer with its file.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <istream>
#include <limits>
#include <ostream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/bytes.hpp"  // our writers store little-endian with bytes::put_u16le / put_u32le
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/interface_index.hpp"

namespace saul::host::detail {

/// What a format's error record without SocketCAN details reads as: CAN_ERR_BUSERROR (0x080) with 8 zero bytes,
/// as asc2log converts an ASC ErrorFrame (ASC, BLF and TRC error records). No timestamp.
inline CanFrame bus_error_frame() {
  CanFrame f;
  f.error = true;
  f.id = 0x080;
  f.dlc = 8;
  return f;
}
/// "can<N-1>" for a format's channel N (1-based).
inline std::string channel_name(std::uint64_t channel) { return "can" + std::to_string(channel - 1); }
/// The message for a CAN FD record, in every reader.
inline constexpr std::string_view kFdUnsupported = "CAN FD frame: the robot's bus is classic CAN, FD is not supported";

/// A binary format's corrupt record at byte `position` of the file.
inline CaptureError byte_error(std::uint64_t position, Recovery recovery, std::string message) {
  return {0, std::move(message), PositionKind::byte_offset, position, recovery};
}

/// The number of `interface` among the interfaces a writer has seen, in order of first appearance (0-based);
/// a new one is added. Throws std::invalid_argument when there would be more than `max` (the format's limit).
inline std::size_t channel_index(InterfaceIndex& seen, std::string_view interface, std::size_t max,
                                 std::string_view format) {
  if (interface.empty()) interface = "can0";
  const auto index = seen.find_or_add(interface, max);
  if (!index)
    throw std::invalid_argument(std::string(format) + ": more than " + std::to_string(max) +
                                " interfaces, the channels the format numbers");
  return *index;
}

/// Flushes a writer's stream; throws std::runtime_error("<format>: write failed") when the stream has failed.
inline void flush_checked(std::ostream& out, std::string_view format) {
  out.flush();
  if (!out) throw std::runtime_error(std::string(format) + ": write failed");
}

/// Runs write(); a std::runtime_error it throws comes out naming the file: "cannot write 'PATH': ...".
template <class Write>
void naming_file(const std::string& path, const Write& write) {
  try {
    write();
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("cannot write '" + path + "': " + e.what());
  }
}

/// Closes a format writer (close_writer()) and then its file, and reports the first failure of either with the
/// file's name: std::runtime_error("cannot write 'PATH': ...").
template <class CloseWriter>
void close_with_file(const CloseWriter& close_writer, std::ofstream& file, const std::string& path) {
  std::string failure;
  try {
    close_writer();
  } catch (const std::runtime_error& e) {
    failure = e.what();
  }
  file.close();
  if (failure.empty() && file.fail()) failure = std::strerror(errno);
  if (!failure.empty()) throw std::runtime_error("cannot write '" + path + "': " + failure);
}

/// The snapshot length our pcap and pcapng writers declare: more than any CAN frame record.
inline constexpr std::uint32_t kSnaplen = 0xFFFF;

// One load and at most one byte swap: they run per field of every packet.
inline std::uint16_t load_u16(const std::uint8_t* p, bool big) noexcept {
  std::uint16_t v;
  std::memcpy(&v, p, sizeof v);
  return big == (std::endian::native == std::endian::big) ? v : __builtin_bswap16(v);
}

inline std::uint32_t load_u32(const std::uint8_t* p, bool big) noexcept {
  std::uint32_t v;
  std::memcpy(&v, p, sizeof v);
  return big == (std::endian::native == std::endian::big) ? v : __builtin_bswap32(v);
}

inline std::uint64_t load_u64(const std::uint8_t* p, bool big) noexcept {
  const std::uint64_t a = load_u32(p, big);
  const std::uint64_t b = load_u32(p + 4, big);
  return big ? (a << 32 | b) : (b << 32 | a);
}

inline void write_bytes(std::ostream& out, const std::uint8_t* p, std::size_t n) {
  out.write(reinterpret_cast<const char*>(p), static_cast<std::streamsize>(n));
}

/// Reads up to n bytes at file offset `at` into dst, retrying after short reads and EINTR; returns the count read,
/// fewer than n at the end of the file or on a read error (its errno in *error when given, else 0 there).
inline std::size_t pread_full(int fd, void* dst, std::size_t n, std::uint64_t at, int* error = nullptr) noexcept {
  if (error != nullptr) *error = 0;
  std::size_t done = 0;
  while (done < n) {
    const ssize_t got = ::pread(fd, static_cast<char*>(dst) + done, n - done, static_cast<off_t>(at + done));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0 && error != nullptr) *error = errno;
    if (got <= 0) break;
    done += static_cast<std::size_t>(got);
  }
  return done;
}

/// A window of a regular file for walking record or block headers forward with large reads, each byte read once:
/// at(pos, n) gives the n bytes at file offset pos (nullptr past the end or on a read error), good until the next
/// at() or lend(). The block just walked can be lent whole to the thread that is to read it (lend()); without lend()
/// the window keeps at most about two windows' bytes.
class HeaderWindow {
 public:
  /// Room kept in front of the bytes read, for a caller of lend() to put bytes before them (pcapng's header blocks).
  static constexpr std::size_t kFront = 4096;
  HeaderWindow(int fd, std::uint64_t size, std::size_t window)
      : fd_(fd), size_(size), window_(window), buf_(kFront + window) {}
  const std::uint8_t* at(std::uint64_t pos, std::size_t n) {
    if (pos + n > size_) return nullptr;
    if (pos < from_ || pos + n > to_) {
      if (pos < from_ || pos > to_) {
        from_ = to_ = pos;  // elsewhere: start afresh
      } else if (to_ - from_ > 2 * std::uint64_t{window_}) {
        // walked long without a lend: keep from pos on only
        std::memmove(buf_.data() + kFront, buf_.data() + kFront + (pos - from_), static_cast<std::size_t>(to_ - pos));
        from_ = pos;
      }
      // read on from to_: up to a window from from_ (a block's walk: one read), at least to pos + n, and at least
      // half a window (a walk past a window without a lend)
      std::uint64_t want = std::max({from_ + window_, pos + n, to_ + window_ / 2}) - to_;
      if (want > size_ - to_) want = size_ - to_;
      const auto kept = static_cast<std::size_t>(to_ - from_);
      if (buf_.size() < kFront + kept + want) buf_.resize(kFront + kept + static_cast<std::size_t>(want));
      to_ += pread_full(fd_, buf_.data() + kFront + kept, static_cast<std::size_t>(want), to_);
      if (pos + n > to_) return nullptr;  // a read error, or the file shrank
    }
    return buf_.data() + kFront + (pos - from_);
  }
  /// When the window holds the file's bytes [from, to): swaps its buffer with `into`, which then holds them from
  /// into[offset] on (offset >= kFront), keeping what it read after `to`. False otherwise.
  bool lend(std::uint64_t from, std::uint64_t to, std::vector<std::uint8_t>& into, std::size_t& offset) {
    if (from < from_ || to > to_ || from > to || from_ == to_) return false;
    offset = kFront + static_cast<std::size_t>(from - from_);
    into.swap(buf_);
    const auto tail = static_cast<std::size_t>(to_ - to);
    if (buf_.size() < kFront + std::max<std::size_t>(tail, window_)) buf_.resize(kFront + std::max<std::size_t>(tail, window_));
    std::memcpy(buf_.data() + kFront, into.data() + kFront + (to - from_), tail);
    from_ = to;
    return true;
  }

 private:
  int fd_;
  std::uint64_t size_;
  std::size_t window_;
  std::vector<std::uint8_t> buf_;
  std::uint64_t from_ = 0, to_ = 0;  // the file bytes in buf_ from buf_[kFront] on
};

/// Reads up to n bytes of a stream buffer, fewer only at its end (sgetn reads on through short reads of a pipe and
/// a decompressor's pieces until then); 0 at the end.
inline std::size_t read_some(std::streambuf& source, char* dst, std::size_t n) {
  const std::streamsize got = source.sgetn(dst, static_cast<std::streamsize>(n));
  return got > 0 ? static_cast<std::size_t>(got) : 0;
}

/// Reads up to n bytes, adding what arrived to `offset`; returns that count (fewer than n only at the end). Straight
/// from the stream's buffer: istream::read()'s sentry per call cost a fifth of reading a pcapng packet.
inline std::size_t read_counted(std::istream& in, std::uint8_t* dst, std::size_t n, std::uint64_t& offset) {
  std::streambuf* buf = in.rdbuf();
  const std::size_t got = buf == nullptr ? 0 : read_some(*buf, reinterpret_cast<char*>(dst), n);
  offset += got;
  return got;
}

/// Skips up to n bytes without seeking (pipes work), adding what was skipped to `offset`; returns that count.
inline std::uint64_t skip_counted(std::istream& in, std::uint64_t n, std::uint64_t& offset) {
  std::uint64_t done = 0;
  constexpr std::uint64_t kChunk = std::numeric_limits<std::int32_t>::max();
  while (done < n && in) {
    const std::uint64_t want = n - done < kChunk ? n - done : kChunk;
    in.ignore(static_cast<std::streamsize>(want));
    const auto got = static_cast<std::uint64_t>(in.gcount());
    done += got;
    if (got < want) break;
  }
  offset += done;
  return done;
}

/// A file's block starts found one at a time by walking its record headers (pcap, pcapng) in a HeaderWindow, so that
/// the walk overlaps the decoding of the first blocks instead of coming before it.
class BlockCutter {
 public:
  virtual ~BlockCutter() = default;
  /// The next start (the first record's first, the file's size last); false once the size was given.
  bool next(std::uint64_t& start) {
    switch (state_) {
      case State::first:
        state_ = State::walking;
        start = last_;
        return true;
      case State::walking:
        if (walk(start)) return true;
        state_ = State::over;  // the rest is one block
        start = size_;
        return true;
      case State::over:
        break;
    }
    return false;
  }
  /// pcapng: where the header blocks end (the first packet block), known once a start after the first was given.
  [[nodiscard]] virtual std::uint64_t prefix_end() const { return 0; }
  /// The bytes [from, to) just walked, when the window still holds them all: HeaderWindow::lend().
  bool lend(std::uint64_t from, std::uint64_t to, std::vector<std::uint8_t>& into, std::size_t& offset) {
    return window_.lend(from, to, into, offset);
  }

 protected:
  /// Blocks of about `block` bytes from `first` on; the window is a block and some, so that a block's walk usually
  /// takes one read.
  BlockCutter(int fd, std::uint64_t first, std::uint64_t size, std::uint64_t block)
      : window_(fd, size, static_cast<std::size_t>(std::min<std::uint64_t>(block, std::uint64_t{64} << 20)) +
                              (std::size_t{16} << 10)),
        size_(size), block_(block == 0 ? 1 : block), pos_(first), last_(first) {}
  /// The next start before the end; false where the walk stops (the end, or a record it cannot cut after).
  virtual bool walk(std::uint64_t& start) = 0;

  HeaderWindow window_;
  const std::uint64_t size_;
  const std::uint64_t block_;
  std::uint64_t pos_;   // the next record the walk reads
  std::uint64_t last_;  // the last start given

 private:
  enum class State { first, walking, over };
  State state_ = State::first;
};
/// Record starts that cut a pcap file (`big`: its byte order) into blocks of about `block` bytes: 24, s1, ..., its
/// size. From the first implausible or cut record on, the rest is one block (a corrupt file reads as in one piece).
std::unique_ptr<BlockCutter> pcap_block_cutter(int fd, std::uint64_t size, bool big, std::uint64_t block);
/// Packet block starts that cut a pcapng file: 0, s1, ..., its size; block k > 0 reads as the header blocks
/// [0, prefix_end()) followed by its own. From the first block after the first packet that is not a packet block,
/// or whose length is not plausible, the rest is one block; a prefix over 1 MiB is not cut at all.
std::unique_ptr<BlockCutter> pcapng_block_cutter(int fd, std::uint64_t size, std::uint64_t block);

}  // namespace saul::host::detail
