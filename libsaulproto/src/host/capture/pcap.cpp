#include "saulproto/host/capture/pcap.hpp"

#include <fmt/format.h>

#include <bit>
#include <cstring>
#include <stdexcept>

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
    return "CAN FD frame: the robot's bus is classic CAN, FD is not supported";
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

PcapReader::PcapReader(std::istream& in) : in_(in) {
  std::array<std::uint8_t, 24> h{};
  const std::size_t got = detail::read_counted(in_, h.data(), h.size(), offset_);
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

PcapReader::Status PcapReader::corrupt(std::uint64_t offset, Recovery recovery, std::string message) {
  error_.column = 0;
  error_.kind = PositionKind::byte_offset;
  error_.position = offset;
  error_.recovery = recovery;
  error_.message = std::move(message);
  if (recovery == Recovery::stop) stopped_ = true;
  return Status::corrupt;
}

PcapReader::Status PcapReader::next() {
  if (stopped_) return Status::end;
  const std::uint64_t start = offset_;
  std::array<std::uint8_t, 16> h{};
  const std::size_t got = detail::read_counted(in_, h.data(), h.size(), offset_);
  if (got == 0) return Status::end;
  if (got < h.size())
    return corrupt(start, Recovery::stop, fmt::format("file ends inside a record header ({} of 16 bytes)", got));
  const std::uint32_t sec = load_u32(h.data(), big_);
  const std::uint32_t frac = load_u32(h.data() + 4, big_);
  const std::uint32_t incl = load_u32(h.data() + 8, big_);
  if (incl > kMaxRecord)
    return corrupt(start, Recovery::stop, fmt::format("record length {} is not plausible", incl));

  std::array<std::uint8_t, kCanFdMtu> packet{};
  const std::size_t want = incl < packet.size() ? incl : packet.size();
  const std::size_t have = detail::read_counted(in_, packet.data(), want, offset_);
  const std::uint64_t rest = incl - want;
  const std::uint64_t skipped = have == want ? detail::skip_counted(in_, rest, offset_) : 0;
  if (have < want || skipped < rest)
    return corrupt(start, Recovery::stop,
                   fmt::format("file ends inside a record ({} of {} bytes)", have + skipped, incl));

  if (frac >= (nano_ ? 1'000'000'000U : 1'000'000U))
    return corrupt(start, Recovery::next_record,
                   fmt::format("timestamp fraction {} is not below one second", frac));
  frame_.timestamp_ns = std::uint64_t{sec} * 1'000'000'000ULL + (nano_ ? frac : std::uint64_t{frac} * 1000U);
  if (incl > kCanFdMtu)
    return corrupt(start, Recovery::next_record,
                   fmt::format("record of {} bytes is longer than any SocketCAN packet", incl));
  const std::string_view why = decode_socketcan_packet(std::span<const std::uint8_t>(packet.data(), want), frame_);
  if (!why.empty()) return corrupt(start, Recovery::next_record, std::string(why));
  return Status::frame;
}

// ---- writer ----

PcapWriter::PcapWriter(std::ostream& out, PcapWriterOptions options) : StreamCaptureWriter(out, "pcap"), options_(options) {
  std::array<std::uint8_t, 24> h{};
  detail::store_u32le(h.data(), options_.nanosecond ? kMagicNano : kMagicMicro);
  detail::store_u16le(h.data() + 4, 2);
  detail::store_u16le(h.data() + 6, 4);
  // thiszone and sigfigs stay 0
  detail::store_u32le(h.data() + 16, detail::kSnaplen);
  detail::store_u32le(h.data() + 20, kLinktypeCanSocketcan);
  detail::write_bytes(out_, h.data(), h.size());
  check_written();
}

void PcapWriter::write(const CanFrame& frame, std::string_view /*interface*/) {
  check_open();
  check_writable(frame);
  const std::uint64_t ns = frame.timestamp_ns.value_or(0);
  const std::uint64_t sec = ns / 1'000'000'000ULL;
  if (sec > 0xFFFF'FFFFULL) throw std::invalid_argument("pcap: timestamp after the year 2106 does not fit");
  const std::uint64_t frac = options_.nanosecond ? ns % 1'000'000'000ULL : ns % 1'000'000'000ULL / 1000U;
  std::array<std::uint8_t, 32> r{};
  detail::store_u32le(r.data(), static_cast<std::uint32_t>(sec));
  detail::store_u32le(r.data() + 4, static_cast<std::uint32_t>(frac));
  detail::store_u32le(r.data() + 8, 16);
  detail::store_u32le(r.data() + 12, 16);
  const auto packet = encode_socketcan_packet(frame);
  for (std::size_t i = 0; i < packet.size(); ++i) r[16 + i] = packet[i];
  detail::write_bytes(out_, r.data(), r.size());
  check_written();
}

}  // namespace saul::host
