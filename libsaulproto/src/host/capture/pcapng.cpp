#include "saulproto/host/capture/pcapng.hpp"

#include <fmt/format.h>

#include <array>
#include <cstring>
#include <optional>
#include <span>
#include <stdexcept>

#include "capture_io.hpp"
#include "saulproto/host/capture/pcap.hpp"

namespace saul::host {
namespace {

using detail::load_u16;
using detail::load_u32;

constexpr std::uint32_t kShb = 0x0A0D'0D0A;  // the same in both byte orders
constexpr std::uint32_t kIdb = 0x0000'0001;
constexpr std::uint32_t kEpb = 0x0000'0006;
constexpr std::uint32_t kSpb = 0x0000'0003;
constexpr std::uint32_t kByteOrderMagic = 0x1A2B'3C4D;
/// Largest SHB/IDB/EPB body parsed; larger blocks of those types are reported and skipped. Bounds memory.
constexpr std::uint32_t kMaxBody = 1024 * 1024;

constexpr std::uint16_t kOptEnd = 0;
constexpr std::uint16_t kShbUserAppl = 4;
constexpr std::uint16_t kIfName = 2;
constexpr std::uint16_t kIfTsresol = 9;
constexpr std::uint16_t kIfTsoffset = 14;

constexpr std::uint64_t kNsPerSec = 1'000'000'000ULL;

/// Timestamp units (as if_tsresol stores them) to nanoseconds. Cost O(1) (O(n) for 10^-n).
std::uint64_t ticks_to_ns(std::uint64_t ticks, std::uint8_t tsresol) {
  const unsigned n = tsresol & 0x7FU;
  if (tsresol & 0x80U) {  // 2^-n seconds
    if (n == 0) return ticks * kNsPerSec;
    if (n >= 64) return 0;
    const std::uint64_t sec = ticks >> n;
    std::uint64_t frac = ticks & ((std::uint64_t{1} << n) - 1);
    unsigned shift = n;
    if (shift > 34) {  // keep frac * 1e9 below 2^64
      frac >>= shift - 34;
      shift = 34;
    }
    return sec * kNsPerSec + ((frac * kNsPerSec) >> shift);
  }
  if (n <= 9) {
    std::uint64_t scale = 1;
    for (unsigned i = n; i < 9; ++i) scale *= 10;
    return ticks * scale;
  }
  if (n > 28) return 0;
  std::uint64_t divisor = 1;
  for (unsigned i = 9; i < n && divisor <= UINT64_MAX / 10; ++i) divisor *= 10;
  return ticks / divisor;
}

/// What a Section Header Block's byte-order magic says: true for big-endian; nullopt when it is no such magic.
std::optional<bool> section_big_endian(const std::uint8_t* magic) {
  if (load_u32(magic, false) == kByteOrderMagic) return false;
  if (load_u32(magic, true) == kByteOrderMagic) return true;
  return std::nullopt;
}

/// Builds a block in a byte buffer, little-endian.
class BlockBuilder {
 public:
  explicit BlockBuilder(std::uint32_t type) {
    u32(type);
    u32(0);  // total length, patched in finish()
  }
  void u16(std::uint16_t v) { little_endian(v, 2); }
  void u32(std::uint32_t v) { little_endian(v, 4); }
  void raw(std::span<const std::uint8_t> v) { bytes_.insert(bytes_.end(), v.begin(), v.end()); }
  void pad() {
    while (bytes_.size() % 4) bytes_.push_back(0);
  }
  void option(std::uint16_t code, std::span<const std::uint8_t> value) {
    u16(code);
    u16(static_cast<std::uint16_t>(value.size()));
    raw(value);
    pad();
  }
  void finish_and_write(std::ostream& out) {
    const auto total = static_cast<std::uint32_t>(bytes_.size() + 4);
    u32(total);
    bytes::put_u32le(bytes_.data() + 4, total);
    detail::write_bytes(out, bytes_.data(), bytes_.size());
  }

 private:
  void little_endian(std::uint32_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) bytes_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  std::vector<std::uint8_t> bytes_;
};

std::span<const std::uint8_t> as_bytes(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

}  // namespace

// ---- blocks for several threads ----

namespace {

class PcapngCutter final : public detail::BlockCutter {
 public:
  PcapngCutter(int fd, std::uint64_t size, std::uint64_t block) : BlockCutter(fd, 0, size, block) {}
  [[nodiscard]] std::uint64_t prefix_end() const override { return prefix_end_; }

 private:
  bool walk(std::uint64_t& start) override {
    while (const std::uint8_t* at = window_.at(pos_, 12)) {
      // a copy: the run below may move the window's bytes (it reads on, and may grow its buffer)
      std::uint8_t h[12];
      std::memcpy(h, at, sizeof h);
      const std::uint32_t type = load_u32(h, big_);
      // Among the packets, eight blocks of this one's type and length in a row are stepped over at once, their
      // headers loaded side by side (one at a time, each length waits for the one before): only where the
      // walk would not stop or start a block among them.
      if (packets_ && (type == kEpb || type == kSpb)) {
        const std::uint64_t length = load_u32(h + 4, big_);
        if (length >= 12 && length % 4 == 0 && length <= kRunBlock && pos_ + 8 * length <= size_ &&
            pos_ + 7 * length - last_ < block_) {
          if (const std::uint8_t* run = window_.at(pos_, 7 * length + 8)) {
            bool same = true;
            for (std::uint64_t k = 1; k < 8; ++k)
              same &= load_u32(run + k * length, big_) == type && load_u32(run + k * length + 4, big_) == length;
            if (same) {
              pos_ += 8 * length;
              continue;
            }
          }
        }
      }
      if (type == kShb) {
        const auto big = section_big_endian(h + 8);
        if (pos_ != 0 || !big) break;  // a second section: not cut from here on
        big_ = *big;
      }
      const std::uint32_t length = load_u32(h + 4, big_);
      if (length < 12 || length % 4 != 0 || pos_ + length > size_) break;
      const bool packet = type == kEpb || type == kSpb;
      if (!packets_ && packet) {
        if (pos_ > (std::uint64_t{1} << 20)) break;  // a prefix too large to read again per block
        packets_ = true;
        prefix_end_ = pos_;
      } else if (packets_ && !packet) {
        break;
      }
      if (packet && pos_ - last_ >= block_ && pos_ > prefix_end_) {
        start = last_ = pos_;  // a block starts here; the next walk goes on over this packet
        return true;
      }
      pos_ += length;
    }
    return false;
  }

  static constexpr std::uint64_t kRunBlock = 4096;  // longer blocks are stepped one at a time
  bool big_ = false;
  bool packets_ = false;  // a packet block was seen
  std::uint64_t prefix_end_ = 0;
};

}  // namespace

std::unique_ptr<detail::BlockCutter> detail::pcapng_block_cutter(int fd, std::uint64_t size, std::uint64_t block) {
  return std::make_unique<PcapngCutter>(fd, size, block);
}

// ---- reader ----

PcapngReader::PcapngReader(std::istream& in) : in_(&in) { open(); }

PcapngReader::PcapngReader(std::span<const std::uint8_t> bytes) : mem_(bytes) { open(); }

std::size_t PcapngReader::take(std::uint8_t* dst, std::size_t n) {
  if (in_ != nullptr) return detail::read_counted(*in_, dst, n, offset_);
  const std::size_t left = mem_.size() - static_cast<std::size_t>(offset_);
  if (n > left) n = left;
  std::memcpy(dst, mem_.data() + offset_, n);
  offset_ += n;
  return n;
}

std::size_t PcapngReader::take_body(std::size_t n) {
  if (in_ != nullptr) {
    body_.resize(n);
    const std::size_t got = detail::read_counted(*in_, body_.data(), n, offset_);
    body_view_ = std::span<const std::uint8_t>(body_.data(), got);
    return got;
  }
  const std::size_t left = mem_.size() - static_cast<std::size_t>(offset_);
  if (n > left) n = left;
  body_view_ = mem_.subspan(static_cast<std::size_t>(offset_), n);
  offset_ += n;
  return n;
}

std::uint64_t PcapngReader::skip(std::uint64_t n) {
  if (in_ != nullptr) return detail::skip_counted(*in_, n, offset_);
  const std::uint64_t left = mem_.size() - offset_;
  if (n > left) n = left;
  offset_ += n;
  return n;
}

void PcapngReader::open() {
  std::array<std::uint8_t, 12> h{};
  const std::size_t got = take(h.data(), h.size());
  if (got < h.size() || load_u32(h.data(), false) != kShb)
    throw CaptureOpenError("not a pcapng file: it does not start with a Section Header Block");
  const auto big = section_big_endian(h.data() + 8);
  if (!big) throw CaptureOpenError("not a pcapng file: bad byte-order magic in the Section Header Block");
  big_ = *big;
  if (block(0, kShb, load_u32(h.data() + 4, big_), 12) == Step::corrupt)
    throw CaptureOpenError("pcapng section header: " + error_.message);
}

PcapngReader::Step PcapngReader::corrupt(std::uint64_t offset, Recovery recovery, std::string message) {
  error_ = detail::byte_error(offset, recovery, std::move(message));
  if (recovery == Recovery::stop) stopped_ = true;
  return Step::corrupt;
}

PcapngReader::Status PcapngReader::next() {
  for (;;) {
    if (stopped_) return Status::end;
    const std::uint64_t start = offset_;
    std::array<std::uint8_t, 12> h{};
    std::size_t got = take(h.data(), 8);
    if (got == 0) return Status::end;
    if (got < 8) {
      corrupt(start, Recovery::stop, fmt::format("file ends inside a block header ({} of 8 bytes)", got));
      return Status::corrupt;
    }
    const std::uint32_t type = load_u32(h.data(), big_);
    std::uint32_t header_bytes = 8;
    if (type == kShb) {  // a new section, maybe in the other byte order
      header_bytes = 12;
      got = take(h.data() + 8, 4);
      if (got < 4) {
        corrupt(start, Recovery::stop, "file ends inside a section header");
        return Status::corrupt;
      }
      const auto big = section_big_endian(h.data() + 8);
      if (!big) {
        corrupt(start, Recovery::stop, "section header has a bad byte-order magic");
        return Status::corrupt;
      }
      big_ = *big;
    }
    if (const Step step = block(start, type, load_u32(h.data() + 4, big_), header_bytes); step != Step::skipped)
      return status(step);
  }
}

PcapngReader::Step PcapngReader::block(std::uint64_t start, std::uint32_t type, std::uint32_t length,
                                       std::uint32_t header_bytes) {
  if (length < header_bytes + 4 || length % 4 != 0 || (type == kShb && length < 28))
    return corrupt(start, Recovery::stop, fmt::format("block length {} is not valid", length));
  const std::uint32_t body_length = length - header_bytes - 4;
  const bool wanted = type == kShb || type == kIdb || type == kEpb || type == kSpb;
  const bool parse = wanted && body_length <= kMaxBody;
  std::uint64_t got = parse ? take_body(body_length) : skip(body_length);
  std::array<std::uint8_t, 4> trailer{};
  if (got == body_length) got += take(trailer.data(), 4);
  if (got < std::uint64_t{body_length} + 4)
    return corrupt(start, Recovery::stop,
                   fmt::format("file ends inside a block ({} of {} bytes)", got + header_bytes, length));
  const std::uint32_t trailing = load_u32(trailer.data(), big_);
  if (trailing != length)
    return corrupt(start, Recovery::next_block,
                   fmt::format("block length {} at the end differs from {} at the start", trailing, length));

  if (type == kIdb) {
    if (interfaces_.size() >= kPcapngMaxInterfaces)
      return corrupt(start, Recovery::next_block,
                     fmt::format("more than {} interfaces in one section: this one is not read (its packets are "
                                 "reported as of an undeclared interface)",
                                 kPcapngMaxInterfaces));
    if (!parse) {
      interfaces_.push_back({});  // keep the numbering of the interfaces that follow
      return corrupt(start, Recovery::next_block,
                     fmt::format("interface description block of {} bytes is too long", length));
    }
    return interface_block(start);
  }
  if (type == kEpb || type == kSpb) {
    if (!parse)
      return corrupt(start, Recovery::next_block, fmt::format("{}packet block of {} bytes is too long for a CAN packet",
                                                              type == kSpb ? "simple " : "", length));
    return type == kEpb ? packet_block(start) : simple_packet_block(start);
  }
  if (type == kShb) {
    if (!parse) return corrupt(start, Recovery::stop, "section header block is too long");
    const std::uint16_t major = load_u16(body_view_.data(), big_);
    if (major != 1) return corrupt(start, Recovery::stop, fmt::format("pcapng version {} is not supported", major));
    interfaces_.clear();  // interface ids count from 0 in every section
    return Step::skipped;
  }
  return Step::skipped;  // a block type we do not need (statistics, name resolution, custom, ...)
}

PcapngReader::Step PcapngReader::interface_block(std::uint64_t start) {
  Interface iface;
  const std::size_t n = body_view_.size();
  if (n < 8) {
    interfaces_.push_back(iface);
    return corrupt(start, Recovery::next_block, "interface description block is too short");
  }
  iface.linktype = load_u16(body_view_.data(), big_);
  iface.snaplen = load_u32(body_view_.data() + 4, big_);
  std::size_t pos = 8;
  while (pos + 4 <= n) {
    const std::uint16_t code = load_u16(body_view_.data() + pos, big_);
    const std::uint16_t len = load_u16(body_view_.data() + pos + 2, big_);
    if (code == kOptEnd) break;
    if (pos + 4 + len > n) {
      interfaces_.push_back(iface);
      return corrupt(start, Recovery::next_block,
                     fmt::format("interface option {} runs past the end of its block", code));
    }
    const std::uint8_t* value = body_view_.data() + pos + 4;
    if (code == kIfName) {
      std::size_t used = len;
      while (used > 0 && value[used - 1] == 0) --used;  // some writers add a terminating NUL
      iface.name.assign(reinterpret_cast<const char*>(value), used);
    } else if (code == kIfTsresol && len >= 1) {
      iface.tsresol = value[0];
    } else if (code == kIfTsoffset && len == 8) {
      iface.tsoffset = static_cast<std::int64_t>(detail::load_u64(value, big_));
    }
    pos += 4 + ((len + 3U) & ~3U);
  }
  if (iface.name.empty()) iface.name = fmt::format("can{}", interfaces_.size());
  interfaces_.push_back(std::move(iface));
  return Step::skipped;
}

PcapngReader::Step PcapngReader::packet_block(std::uint64_t start) {
  const std::size_t n = body_view_.size();
  if (n < 20) return corrupt(start, Recovery::next_block, "enhanced packet block is too short");
  const std::uint32_t id = load_u32(body_view_.data(), big_);
  const std::uint64_t ticks = std::uint64_t{load_u32(body_view_.data() + 4, big_)} << 32 | load_u32(body_view_.data() + 8, big_);
  const std::uint32_t captured = load_u32(body_view_.data() + 12, big_);
  if (captured > n - 20)
    return corrupt(start, Recovery::next_block,
                   fmt::format("captured length {} runs past the end of its block", captured));
  if (id >= interfaces_.size())
    return corrupt(start, Recovery::next_block,
                   fmt::format("packet of interface {}, which no interface description block declared", id));
  const Interface& iface = interfaces_[id];
  if (iface.linktype != kLinktypeCanSocketcan) return Step::skipped;  // another kind of interface in the file
  frame_.timestamp_ns = packet_time(iface, ticks);
  return socketcan_packet(start, iface, std::span<const std::uint8_t>(body_view_.data() + 20, captured));
}

std::uint64_t PcapngReader::packet_time(const Interface& iface, std::uint64_t ticks) {
  std::uint64_t ns = ticks_to_ns(ticks, iface.tsresol);
  if (iface.tsoffset >= 0) {
    ns += static_cast<std::uint64_t>(iface.tsoffset) * kNsPerSec;
  } else {
    const std::uint64_t back = static_cast<std::uint64_t>(-iface.tsoffset) * kNsPerSec;
    ns = ns > back ? ns - back : 0;
  }
  return ns;
}

bool PcapngReader::usual_packet(FrameBatch& batch) {
  // Exactly the checks block() and packet_block() make on the way to a frame; the first that does not pass hands
  // the block to next(), which reports it as those do.
  const std::size_t left = mem_.size() - static_cast<std::size_t>(offset_);
  if (left < 32) return false;  // header 8 + packet fields 20 + trailer 4
  const std::uint8_t* const p = mem_.data() + offset_;
  if (load_u32(p, big_) != kEpb) return false;
  const std::uint32_t length = load_u32(p + 4, big_);
  if (length < 32 || length % 4 != 0 || length > left || length - 12 > kMaxBody) return false;
  if (load_u32(p + length - 4, big_) != length) return false;
  const std::uint8_t* const body = p + 8;
  const std::uint32_t id = load_u32(body, big_);
  const std::uint32_t captured = load_u32(body + 12, big_);
  if (id >= interfaces_.size() || captured > length - 32) return false;
  const Interface& iface = interfaces_[id];
  if (iface.linktype != kLinktypeCanSocketcan) return false;
  CanFrame& f = batch.frames.emplace_back();
  f.timestamp_ns = packet_time(iface, std::uint64_t{load_u32(body + 4, big_)} << 32 | load_u32(body + 8, big_));
  if (!decode_socketcan_packet(std::span<const std::uint8_t>(body + 20, captured), f).empty()) {
    batch.frames.pop_back();
    return false;
  }
  batch.interfaces.push_back(iface.name);
  offset_ += length;
  return true;
}

bool PcapngReader::next_batch(FrameBatch& batch, std::size_t max) {
  batch.clear();
  while (batch.frames.size() + batch.corrupt.size() < max) {
    if (in_ == nullptr && !stopped_ && usual_packet(batch)) continue;
    // next() may add or clear interfaces, whose names the batch's views point into: only first in a batch
    if (!batch.frames.empty() || !batch.corrupt.empty()) break;
    const Status st = next();
    if (st == Status::end) break;
    if (st == Status::corrupt) {
      batch.corrupt.push_back({batch.frames.size(), error_});
    } else {
      batch.frames.push_back(frame_);
      batch.interfaces.push_back(name_);
    }
  }
  return !batch.frames.empty() || !batch.corrupt.empty();
}

PcapngReader::Step PcapngReader::socketcan_packet(std::uint64_t start, const Interface& iface,
                                                  std::span<const std::uint8_t> packet) {
  const std::string_view why = decode_socketcan_packet(packet, frame_);
  if (!why.empty()) return corrupt(start, Recovery::next_block, std::string(why));
  if (name_ != iface.name) name_ = iface.name;  // nearly always the same interface as the packet before
  return Step::frame;
}

PcapngReader::Step PcapngReader::simple_packet_block(std::uint64_t start) {
  // Original length, then the packet cut to interface 0's snap length (and padded): no interface id, no time.
  const std::size_t n = body_view_.size();
  if (n < 4) return corrupt(start, Recovery::next_block, "simple packet block is too short");
  if (interfaces_.empty())
    return corrupt(start, Recovery::next_block, "simple packet block before any interface description block");
  const Interface& iface = interfaces_[0];
  if (iface.linktype != kLinktypeCanSocketcan) return Step::skipped;
  std::size_t captured = load_u32(body_view_.data(), big_);
  if (iface.snaplen != 0 && captured > iface.snaplen) captured = iface.snaplen;
  if (captured > n - 4)
    return corrupt(start, Recovery::next_block,
                   fmt::format("packet length {} runs past the end of its simple packet block", captured));
  frame_.timestamp_ns.reset();
  return socketcan_packet(start, iface, std::span<const std::uint8_t>(body_view_.data() + 4, captured));
}

// ---- writer ----

PcapngWriter::PcapngWriter(std::ostream& out) : StreamCaptureWriter(out, "pcapng") {
  BlockBuilder b(kShb);
  b.u32(kByteOrderMagic);
  b.u16(1);  // version 1.0
  b.u16(0);
  b.u32(0xFFFF'FFFF);  // section length: not given
  b.u32(0xFFFF'FFFF);
  b.option(kShbUserAppl, as_bytes("libsaulproto"));
  b.option(kOptEnd, {});
  b.finish_and_write(out_);
  check_written();
}

void PcapngWriter::put(const CanFrame& frame, std::string_view interface) {
  if (interface.empty()) interface = "can0";
  if (interface.size() > 1024) throw std::invalid_argument("pcapng: interface name longer than 1024 bytes");
  const std::size_t known = interfaces_.size();
  const auto found = interfaces_.find_or_add(interface, kPcapngMaxInterfaces);
  if (!found)
    throw std::invalid_argument(fmt::format("pcapng: more than {} interfaces (is the log's interface column noise?)",
                                            kPcapngMaxInterfaces));
  const std::size_t id = *found;
  if (interfaces_.size() > known) {  // first frame of this interface: describe it
    BlockBuilder b(kIdb);
    b.u16(static_cast<std::uint16_t>(kLinktypeCanSocketcan));
    b.u16(0);
    b.u32(detail::kSnaplen);
    b.option(kIfName, as_bytes(interface));
    const std::array<std::uint8_t, 1> nanoseconds{9};
    b.option(kIfTsresol, nanoseconds);
    b.option(kOptEnd, {});
    b.finish_and_write(out_);
  }
  const std::uint64_t ns = frame.timestamp_ns.value_or(0);
  const auto packet = encode_socketcan_packet(frame);
  BlockBuilder b(kEpb);
  b.u32(static_cast<std::uint32_t>(id));
  b.u32(static_cast<std::uint32_t>(ns >> 32));
  b.u32(static_cast<std::uint32_t>(ns));
  b.u32(static_cast<std::uint32_t>(packet.size()));
  b.u32(static_cast<std::uint32_t>(packet.size()));
  b.raw(packet);
  b.finish_and_write(out_);
}

}  // namespace saul::host
