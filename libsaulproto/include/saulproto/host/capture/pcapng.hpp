// pcapng capture files whose interfaces have LINKTYPE_CAN_SOCKETCAN (227), packets as in pcap (pcap.hpp); what is
// read and how: docs/captures.md. Several sections in either byte order, if_name, if_tsresol and if_tsoffset are
// read; unknown blocks and packets of non-CAN interfaces are skipped by their length. A block with bad content but
// a sane length is reported and skipped; a bad block length or a file that ends inside a block stops reading.
// Writing: one little-endian section, an IDB per interface name at its first frame (ns resolution), an EPB per frame.
#pragma once

#include <cstdint>
#include <istream>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/interface_index.hpp"

namespace saul::host {

/// The most interfaces of one section that the reader reads and the writer writes (each is a name in memory: a
/// hostile file must not grow it without end). The reader reports the declarations after them as corrupt; the
/// writer's write() throws std::invalid_argument.
inline constexpr std::size_t kPcapngMaxInterfaces = 65536;

class PcapngReader final : public RecordCaptureReader {
 public:
  /// Reads the first Section Header Block; throws CaptureOpenError when the stream does not start with one.
  explicit PcapngReader(std::istream& in);
  /// The same over bytes in memory (they must outlive the reader): packets are read in place, not copied.
  explicit PcapngReader(std::span<const std::uint8_t> bytes);

  /// Fills `batch` (cleared first) with what next() would give, up to `max` frames and corrupt records; false at the
  /// end. Over bytes in memory the usual packet is decoded in place (~4x faster than next()).
  bool next_batch(FrameBatch& batch, std::size_t max);
  bool next_batch(FrameBatch& batch) override { return next_batch(batch, FrameBatch::kMax); }
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::pcapng; }

 private:
  Status next() override;
  struct Interface {
    std::uint16_t linktype = 0;
    std::uint8_t tsresol = 6;  ///< if_tsresol as stored: bit 7 clear = 10^-n s, set = 2^-n s
    std::int64_t tsoffset = 0;  ///< if_tsoffset, seconds
    std::uint32_t snaplen = 0;  ///< 0: no limit
    std::string name;
  };

  Step block(std::uint64_t start, std::uint32_t type, std::uint32_t length, std::uint32_t header_bytes);
  Step interface_block(std::uint64_t start);
  Step packet_block(std::uint64_t start);
  Step simple_packet_block(std::uint64_t start);
  /// The packet at offset_ into `batch` when it is the usual clean one (next_batch); false, nothing read, else.
  bool usual_packet(FrameBatch& batch);
  /// An Enhanced Packet Block's time in ns since 1970 from its ticks, in the interface's resolution and offset.
  static std::uint64_t packet_time(const Interface& iface, std::uint64_t ticks);
  Step socketcan_packet(std::uint64_t start, const Interface& iface, std::span<const std::uint8_t> packet);
  Step corrupt(std::uint64_t offset, Recovery recovery, std::string message);
  void open();
  /// Up to n bytes into dst (from the stream or memory), counted in offset_; returns how many.
  std::size_t take(std::uint8_t* dst, std::size_t n);
  /// The next n bytes as body_view_ (in memory: in place; else read into body_), counted; returns how many.
  std::size_t take_body(std::size_t n);
  std::uint64_t skip(std::uint64_t n);

  std::istream* in_ = nullptr;               ///< the stream, or
  std::span<const std::uint8_t> mem_;        ///< the bytes in memory
  std::span<const std::uint8_t> body_view_;  ///< the block being parsed (in body_ or in mem_)
  std::uint64_t offset_ = 0;
  bool big_ = false;
  bool stopped_ = false;
  std::vector<Interface> interfaces_;
  std::vector<std::uint8_t> body_;  ///< the block being parsed; bounded by the largest block accepted
};

class PcapngWriter final : public StreamCaptureWriter {
 public:
  /// Writes the Section Header Block at once.
  explicit PcapngWriter(std::ostream& out);
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::pcapng; }

 private:
  void put(const CanFrame& frame, std::string_view interface) override;
  InterfaceIndex interfaces_;  ///< index = pcapng interface id
};

}  // namespace saul::host
