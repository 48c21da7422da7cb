#include "saulproto/host/capture/pcap.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <bit>
#include <cerrno>
#include <cstring>
#include <limits>
#include <span>
#include <stdexcept>
#include <system_error>

#include "capture_io.hpp"

namespace saul::host {
namespace {

using detail::load_u32;

constexpr std::uint32_t kEffFlag = 0x8000'0000;
constexpr std::uint32_t kRtrFlag = 0x4000'0000;
constexpr std::uint32_t kErrFlag = 0x2000'0000;
constexpr std::uint8_t kCanFdFdf = 0x04;
constexpr std::size_t kCanFdMtu = 72;

constexpr std::uint32_t kMagicMicro = 0xA1B2'C3D4;
constexpr std::uint32_t kMagicNano = 0xA1B2'3C4D;
/// A record longer than this cannot be a CAN packet nor anything sane; its length field is taken as garbage.
constexpr std::uint32_t kMaxRecord = 256 * 1024;

}  // namespace

std::string_view decode_socketcan_packet(std::span<const std::uint8_t> packet, CanFrame& out) noexcept {
  if (packet.size() < 8) return "packet shorter than the 8-byte SocketCAN header";
  const std::uint32_t id_flags = load_u32(packet.data(), true);
  const std::uint8_t length = packet[4];
  if ((packet[5] & kCanFdFdf) != 0 || packet.size() == kCanFdMtu)
    return detail::kFdUnsupported;
  if (length > CanFrame::kMaxDlc) return "payload_length above 8";
  const std::uint32_t id = id_flags & CanFrame::kMaxExtendedId;
  const bool error = (id_flags & kErrFlag) != 0;
  const bool extended = !error && (id_flags & kEffFlag) != 0;
  if (!error && !extended && id > CanFrame::kMaxStandardId) return "11-bit id above 7FF (EFF flag not set)";
  const bool remote = (id_flags & kRtrFlag) != 0;
  std::uint64_t data = 0;  // the payload's bytes, the first the lowest (as in memory), zeros after them
  if (remote) {
    if (error) return "an error frame cannot be a remote frame";
  } else {
    if (packet.size() - 8 < length) return "packet holds fewer data bytes than its payload_length";
    if (packet.size() >= 16 && std::endian::native == std::endian::little) {  // the usual 16-byte packet: one load
      std::memcpy(&data, packet.data() + 8, sizeof data);
      if (length < 8) data &= (std::uint64_t{1} << (8 * length)) - 1;
    } else {
      std::uint8_t bytes[8] = {};
      for (std::size_t i = 0; i < length; ++i) bytes[i] = packet[8 + i];
      std::memcpy(&data, bytes, sizeof data);
    }
  }
  // Every field but the time, which the caller set (nothing changes when the packet is refused above).
  out.id = id;
  out.extended = extended;
  out.remote = remote;
  out.error = error;
  out.dlc = length;
  std::memcpy(out.data.data(), &data, sizeof data);
  return {};
}

std::array<std::uint8_t, 16> encode_socketcan_packet(const CanFrame& frame) noexcept {
  std::array<std::uint8_t, 16> p{};
  std::uint32_t id_flags = frame.id;
  if (frame.error) {
    id_flags |= kErrFlag;
  } else {
    if (frame.extended) id_flags |= kEffFlag;
    if (frame.remote) id_flags |= kRtrFlag;
  }
  for (int i = 0; i < 4; ++i) p[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(id_flags >> (24 - 8 * i));
  p[4] = frame.error ? 8 : frame.dlc;  // an error frame always carries 8 bytes (CAN_ERR_DLC), as the kernel sends it
  const auto payload = frame.payload();
  for (std::size_t i = 0; i < payload.size(); ++i) p[8 + i] = payload[i];
  return p;
}

// ---- reader ----

PcapReader::PcapReader(int fd, std::uint64_t size, std::uint64_t begin, std::uint64_t end,
                       std::span<const std::uint8_t> bytes, std::size_t block_bytes)
    : fd_(fd), size_(size), cap_(bytes.data() ? 0 : block_bytes + kMaxRecord + 16),
      block_(bytes.data() ? 0 : block_bytes) {
  if (bytes.data() == nullptr) buf_.reset(new std::uint8_t[cap_]);
  data_ = bytes.data() ? bytes.data() : buf_.get();
  read_header();
  tail_ = bytes.size();
  offset_ = begin < 24 ? 24 : begin;
  read_to_ = offset_ + bytes.size();
  size_ = end < size ? end : size;
}

void PcapReader::read_header() {
  std::array<std::uint8_t, 24> h{};
  std::uint64_t counted = 0;
  const std::size_t got = in_ != nullptr ? detail::read_counted(*in_, h.data(), h.size(), counted)
                                         : detail::pread_full(fd_, h.data(), std::min<std::uint64_t>(size_, 24), 0);
  if (got < h.size())
    throw CaptureOpenError(fmt::format("not a pcap file: {} bytes, a pcap header needs 24", got));
  const std::uint32_t magic = load_u32(h.data(), false);
  if (magic == kMagicMicro || magic == kMagicNano) {
    big_ = false;
  } else if (load_u32(h.data(), true) == kMagicMicro || load_u32(h.data(), true) == kMagicNano) {
    big_ = true;
  } else {
    throw CaptureOpenError(fmt::format("not a pcap file: magic {:02X} {:02X} {:02X} {:02X}", h[0], h[1], h[2], h[3]));
  }
  nano_ = load_u32(h.data(), big_) == kMagicNano;
  const std::uint16_t major = detail::load_u16(h.data() + 4, big_);
  if (major != 2) throw CaptureOpenError(fmt::format("pcap version {} is not supported (only 2.x)", major));
  const std::uint32_t linktype = load_u32(h.data() + 20, big_) & 0xFFFF;
  if (linktype != kLinktypeCanSocketcan)
    throw CaptureOpenError(fmt::format(
        "pcap link type {} is not CAN: only LINKTYPE_CAN_SOCKETCAN (227) is read{}", linktype,
        linktype == 113 ? " (113 is Linux cooked capture: capture on the CAN interface itself, e.g. tcpdump -i can0)"
                        : ""));
}

PcapReader::PcapReader(std::istream& in, std::size_t block_bytes)
    : in_(&in), size_(std::numeric_limits<std::uint64_t>::max()), cap_(block_bytes + kMaxRecord + 16),
      block_(block_bytes) {
  buf_.reset(new std::uint8_t[cap_]);
  data_ = buf_.get();
  read_header();
}

namespace {

class PcapCutter final : public detail::BlockCutter {
 public:
  PcapCutter(int fd, std::uint64_t size, bool big, std::uint64_t block) : BlockCutter(fd, 24, size, block), big_(big) {}

 private:
  bool walk(std::uint64_t& start) override {
    while (const std::uint8_t* h = window_.at(pos_, 16)) {
      const std::uint32_t incl = detail::load_u32(h + 8, big_);
      if (incl > kMaxRecord) break;
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

  bool big_;
};

}  // namespace

std::unique_ptr<detail::BlockCutter> detail::pcap_block_cutter(int fd, std::uint64_t size, bool big,
                                                               std::uint64_t block) {
  return std::make_unique<PcapCutter>(fd, size, big, block);
}

// At least n bytes from head_ in the buffer, or all that is left of the file; returns how many there are.
std::size_t PcapReader::ensure(std::size_t n) {
  if (tail_ - head_ >= n || read_to_ >= size_) return tail_ - head_;
  if (head_ > 0) {
    std::memmove(buf_.get(), buf_.get() + head_, tail_ - head_);  // (bytes in memory: all there, never here)
    tail_ -= head_;
    head_ = 0;
  }
  while (tail_ < n && read_to_ < size_) {
    std::size_t want = cap_ - tail_ < block_ ? cap_ - tail_ : block_;
    if (want > size_ - read_to_) want = static_cast<std::size_t>(size_ - read_to_);
    const ssize_t got = in_ != nullptr ? static_cast<ssize_t>(in_->rdbuf()->sgetn(reinterpret_cast<char*>(buf_.get() + tail_),
                                                                                  static_cast<std::streamsize>(want)))
                                       : ::pread(fd_, buf_.get() + tail_, want, static_cast<off_t>(read_to_));
    if (got < 0) {
      if (errno == EINTR) continue;
      throw std::system_error(errno, std::generic_category(), "reading the capture");
    }
    if (got == 0) {
      size_ = read_to_;  // the end of the stream, or the file shrank
      break;
    }
    tail_ += static_cast<std::size_t>(got);
    read_to_ += static_cast<std::uint64_t>(got);
  }
  return tail_ - head_;
}

void PcapReader::corrupt(FrameBatch& batch, std::uint64_t at, Recovery recovery, std::string message) {
  if (recovery == Recovery::stop) stopped_ = true;
  batch.corrupt.push_back({batch.frames.size(), detail::byte_error(at, recovery, std::move(message))});
}

bool PcapReader::next_batch(FrameBatch& batch) {
  batch.clear();
  while (!stopped_ && batch.frames.size() < FrameBatch::kMax) {
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
    if (incl > kMaxRecord) {
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
    if (incl > kCanFdMtu) {
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


// ---- writer ----

PcapWriter::PcapWriter(std::ostream& out, PcapWriterOptions options) : StreamCaptureWriter(out, "pcap"), options_(options) {
  std::array<std::uint8_t, 24> h{};
  bytes::put_u32le(h.data(), options_.nanosecond ? kMagicNano : kMagicMicro);
  bytes::put_u16le(h.data() + 4, 2);
  bytes::put_u16le(h.data() + 6, 4);
  // thiszone and sigfigs stay 0
  bytes::put_u32le(h.data() + 16, detail::kSnaplen);
  bytes::put_u32le(h.data() + 20, kLinktypeCanSocketcan);
  detail::write_bytes(out_, h.data(), h.size());
  check_written();
}

void PcapWriter::put(const CanFrame& frame, std::string_view /*interface*/) {
  const std::uint64_t ns = frame.timestamp_ns.value_or(0);
  const std::uint64_t sec = ns / 1'000'000'000ULL;
  if (sec > 0xFFFF'FFFFULL) throw std::invalid_argument("pcap: timestamp after the year 2106 does not fit");
  const std::uint64_t frac = options_.nanosecond ? ns % 1'000'000'000ULL : ns % 1'000'000'000ULL / 1000U;
  std::array<std::uint8_t, 32> r{};
  bytes::put_u32le(r.data(), static_cast<std::uint32_t>(sec));
  bytes::put_u32le(r.data() + 4, static_cast<std::uint32_t>(frac));
  bytes::put_u32le(r.data() + 8, 16);
  bytes::put_u32le(r.data() + 12, 16);
  const auto packet = encode_socketcan_packet(frame);
  for (std::size_t i = 0; i < packet.size(); ++i) r[16 + i] = packet[i];
  detail::write_bytes(out_, r.data(), r.size());
}

}  // namespace saul::host
