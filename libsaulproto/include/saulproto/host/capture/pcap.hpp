// libpcap capture files with LINKTYPE_CAN_SOCKETCAN (227), as tcpdump, Wireshark and tshark read them.
//
// Each packet is the SocketCAN frame with its CAN id in BIG-endian (network) order, unlike the host-order
// can_frame of a live socket: u32 id + flags (0x80000000 EFF, 0x40000000 RTR, 0x20000000 ERR), u8 payload_length,
// u8 padding (CAN FD flags), u8 reserved, u8 reserved/len8_dlc, then the data. payload_length is authoritative:
// records may carry the full 8 data bytes (16-byte records, as Linux captures) or fewer.
//
// Reading: both byte orders, microsecond (A1B2C3D4) and nanosecond (A1B23C4D) magic. A record with bad content is
// reported and skipped (its length is known); a truncated record or an implausible record length stops reading.
// CAN FD packets are reported as unsupported: the robot's bus is classic CAN. Every frame reads as interface
// "can0" (pcap has no interface names).
// Writing: little-endian, microsecond magic unless asked for nanoseconds, snaplen 65535, 16-byte records.
#pragma once

#include <array>
#include <cstdint>
#include <istream>
#include <ostream>
#include <span>
#include <string_view>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/capture.hpp"

namespace saul::host {

inline constexpr std::uint32_t kLinktypeCanSocketcan = 227;

/// Parses one LINKTYPE_CAN_SOCKETCAN packet (id big-endian) into `out` (timestamp untouched). Returns an empty
/// view on success, else why the packet is not a classic CAN frame. Cost O(1), no allocation.
std::string_view decode_socketcan_packet(std::span<const std::uint8_t> packet, CanFrame& out) noexcept;

/// The 16-byte LINKTYPE_CAN_SOCKETCAN packet of a frame (CAN_MTU layout, id big-endian, data zero-padded; a remote
/// frame carries its requested length in payload_length, an error frame 8 as the kernel's CAN_ERR_DLC, which
/// Wireshark expects). The frame must be valid().
std::array<std::uint8_t, 16> encode_socketcan_packet(const CanFrame& frame) noexcept;

class PcapReader final : public CaptureReader {
 public:
  /// Reads the 24-byte file header; throws CaptureOpenError when it is missing, not pcap, or not link type 227.
  explicit PcapReader(std::istream& in);

  Status next() override;
  [[nodiscard]] const CanFrame& frame() const override { return frame_; }
  [[nodiscard]] std::string_view interface() const override { return "can0"; }
  [[nodiscard]] const CaptureError& error() const override { return error_; }
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::pcap; }

  [[nodiscard]] bool big_endian() const noexcept { return big_; }
  [[nodiscard]] bool nanosecond() const noexcept { return nano_; }

 private:
  Status corrupt(std::uint64_t offset, Recovery recovery, std::string message);

  std::istream& in_;
  std::uint64_t offset_ = 0;
  bool big_ = false;
  bool nano_ = false;
  bool stopped_ = false;
  CanFrame frame_;
  CaptureError error_;
};

struct PcapWriterOptions {
  bool nanosecond = false;  ///< write the A1B23C4D magic and nanosecond fractions (tcpdump/Wireshark read both)
};

class PcapWriter final : public StreamCaptureWriter {
 public:
  /// Writes the file header at once.
  explicit PcapWriter(std::ostream& out, PcapWriterOptions options = {});

  /// `interface` is not stored: pcap has no interface names.
  void write(const CanFrame& frame, std::string_view interface) override;
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::pcap; }

 private:
  PcapWriterOptions options_;
};

}  // namespace saul::host
