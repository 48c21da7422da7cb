// libpcap capture files with LINKTYPE_CAN_SOCKETCAN (227), as tcpdump, Wireshark and tshark read them (packet
// layout and choices: docs/captures.md). Each packet is the SocketCAN frame with its CAN id BIG-endian, unlike a
// live socket's can_frame; payload_length is authoritative (records of 16 bytes or of the payload alone).
// Reading: both byte orders, µs and ns magic. A record with bad content is reported and skipped; a truncated
// record or an implausible length stops reading. CAN FD packets are reported as unsupported. Every frame reads as
// "can0". PcapReader reads a file, a range of one or a stream.
// Writing: little-endian, microsecond magic unless asked for nanoseconds, snaplen 65535, 16-byte records.
#pragma once

#include <array>
#include <cstdint>
#include <istream>
#include <memory>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

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

/// The pcap reader: large reads into one buffer, records decoded in place, frames handed out in batches. Reads a
/// regular file with pread(2) (whole, or a range of it: a block of the read path) or a stream. Memory is one buffer
/// (block size + the longest record accepted), whatever the file size.
class PcapReader final : public CaptureReader {
 public:
  /// Reads the records from byte `begin` (a record's start, where CaptureBlocks cuts) to `end` of the regular file
  /// `fd` (not owned) of `size` bytes with pread(2), or from the file's bytes [begin, end) when they are in memory
  /// (`bytes`, kept alive by the caller: nothing is read but the header). The 24-byte file header is checked as a
  /// stream's is below (CaptureOpenError).
  PcapReader(int fd, std::uint64_t size, std::uint64_t begin, std::uint64_t end,
             std::span<const std::uint8_t> bytes = {}, std::size_t block_bytes = std::size_t{1} << 20);
  /// Reads `in` (kept alive by the caller) from its file header on, without seeking: throws CaptureOpenError when
  /// the 24-byte file header is missing, not pcap, or not link type 227.
  explicit PcapReader(std::istream& in, std::size_t block_bytes = std::size_t{64} << 10);

  /// Fills `batch` (cleared first) with up to FrameBatch::kMax records; false (batch empty) at the end.
  bool next_batch(FrameBatch& batch) override;
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::pcap; }
  [[nodiscard]] bool big_endian() const noexcept { return big_; }

 private:
  void read_header();
  std::size_t ensure(std::size_t n);
  void corrupt(FrameBatch& batch, std::uint64_t at, Recovery recovery, std::string message);

  int fd_ = -1;
  std::istream* in_ = nullptr;  // the stream read instead of fd_
  std::uint64_t size_;
  std::unique_ptr<std::uint8_t[]> buf_;
  const std::uint8_t* data_ = nullptr;  // buf_, or the bytes given
  std::size_t cap_;
  std::size_t block_;
  std::size_t head_ = 0, tail_ = 0;
  std::uint64_t offset_ = 24;   // file offset of data_[head_]
  std::uint64_t read_to_ = 24;  // file offset of data_[tail_]
  bool big_ = false;
  bool nano_ = false;
  bool stopped_ = false;
};

struct PcapWriterOptions {
  bool nanosecond = false;  ///< write the A1B23C4D magic and nanosecond fractions (tcpdump/Wireshark read both)
};

class PcapWriter final : public StreamCaptureWriter {
 public:
  /// Writes the file header at once.
  explicit PcapWriter(std::ostream& out, PcapWriterOptions options = {});
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::pcap; }

 private:
  /// `interface` is not stored: pcap has no interface names.
  void put(const CanFrame& frame, std::string_view interface) override;
  PcapWriterOptions options_;
};

}  // namespace saul::host
