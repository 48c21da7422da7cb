// Vector BLF (binary logging format), as CANoe/CANalyzer, python-can's BLFWriter and SavvyCAN write it: a file
// header, then log containers (zlib-compressed or stored) holding a stream of objects, all little-endian (layout and
// choices: docs/captures.md "Vector BLF").
// Reading: CAN_MESSAGE and CAN_MESSAGE2 as frames, CAN_ERROR and CAN_ERROR_EXT as a bus error (0x080, 8 zero
// bytes), CAN_FD_MESSAGE and CAN_FD_MESSAGE_64 as classic frames when their EDL flag is clear (else reported as CAN
// FD), every other object counted (skipped_objects()) and skipped. Channel N reads as "can<N-1>", a DLC of 9..15
// as 8 bytes; times are read as UTC.
// Hostile files: every length is checked against what is left; a container may declare at most kMaxContainerBytes
// uncompressed and must inflate to exactly that, an object may be at most kMaxObjectBytes; after a corrupt object or
// container the reader carries on at the next "LOBJ". Memory stays below a few containers whatever the file.
// Writing: CAN_MESSAGE and CAN_ERROR_EXT objects (1 ns times) in 128 KiB zlib containers, channels numbered in order
// of first appearance; close() fixes the header's sizes, count and stop time when the stream can seek back (a file).
#pragma once

#include <cstdint>
#include <istream>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/interface_index.hpp"

namespace saul::host {

class BlfReader final : public RecordCaptureReader {
 public:
  static constexpr std::uint32_t kMaxContainerBytes = 16U << 20;  ///< uncompressed or compressed
  static constexpr std::uint32_t kMaxObjectBytes = 1U << 20;

  /// Reads the file header; throws CaptureOpenError when the stream does not start with one.
  explicit BlfReader(std::istream& in);

  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::blf; }

  /// Objects of types that are not CAN frames (markers, statistics, other buses ...), skipped.
  [[nodiscard]] std::uint64_t skipped_objects() const { return skipped_objects_; }

  /// One inflated container: its bytes, or what is wrong with it; `offset` is where it starts in the file.
  struct Container {
    std::uint64_t offset = 0;
    std::vector<std::uint8_t> bytes;
    std::string error;
    bool starts_fresh = false;  ///< a container after a gap (a corrupt one before it): no object continues into it
  };

 private:
  enum class Step { frame, corrupt, skipped, need_more };
  Status next() override;
  enum class Load { loaded, corrupt, none };
  Status corrupt(std::uint64_t position, Recovery recovery, std::string message);
  /// A corrupt object of the container under way; reading goes on after it.
  Step bad_object(std::string message);
  Step object();
  Step can_object(std::uint32_t type, const std::uint8_t* body, std::uint32_t length, std::uint64_t time_ns);
  Load load_container();
  std::optional<Container> read_top_level();
  std::size_t read_top(std::uint8_t* dst, std::size_t n);
  std::uint64_t resync_top();

  std::istream& in_;
  std::uint64_t offset_ = 0;           // bytes taken from the stream
  std::vector<std::uint8_t> look_;     // bytes taken but to be read again (a resync found "LOBJ")
  std::uint64_t start_ns_ = 0;
  bool top_ended_ = false;
  std::vector<std::uint8_t> buf_;  // the object stream: a tail of the previous container + the current one
  std::size_t pos_ = 0;
  std::uint64_t container_offset_ = 0;  // file offset of the container the bytes at pos_ came from
  bool ended_ = false;
  std::uint64_t skipped_objects_ = 0;
};

class BlfWriter final : public StreamCaptureWriter {
 public:
  static constexpr std::size_t kContainerBytes = 128 * 1024;
  explicit BlfWriter(std::ostream& out) : StreamCaptureWriter(out, "BLF") {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::blf; }
  void flush() override;

 private:
  void put(const CanFrame& frame, std::string_view interface) override;
  void finish() override;
  void write_header(std::uint64_t file_size);
  void write_container();
  InterfaceIndex channels_;
  std::vector<std::uint8_t> buffer_;  // uncompressed objects not yet in a container
  std::optional<std::uint64_t> start_ns_;
  std::uint64_t stop_ns_ = 0;
  std::uint64_t file_bytes_ = 0;
  std::uint64_t uncompressed_bytes_ = 0;
  std::uint32_t objects_ = 0;
  bool header_written_ = false;
};

}  // namespace saul::host
