// One classic CAN frame, as every transport, capture format and codec in the toolkit passes it around.
//
// A plain value (48 bytes), copyable, comparable, no allocation. The robot's bus is classic CAN at 500 kbit/s:
// the ESP32-S3 TWAI controller, the SN65HVD230 and the VESCs cannot do CAN FD, so there is no FD variant.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>

#include "saulproto/core/result.hpp"

namespace saul {

struct CanFrame {
  static constexpr std::uint32_t kMaxStandardId = 0x7FF;
  static constexpr std::uint32_t kMaxExtendedId = 0x1FFF'FFFF;
  static constexpr std::uint8_t kMaxDlc = 8;

  std::uint32_t id = 0;      ///< 11-bit (extended == false) or 29-bit id; for error frames the error class bits
  bool extended = false;     ///< 29-bit identifier
  bool remote = false;       ///< remote transmission request: no data, dlc is the requested length
  bool error = false;        ///< SocketCAN error frame (id = error class, data = details), never on the wire
  std::uint8_t dlc = 0;      ///< 0..8; number of valid bytes in data (for remote frames: the requested length)
  std::array<std::uint8_t, 8> data{};
  /// When the frame was seen, in nanoseconds. Absent for frames built to send. The epoch is the source's
  /// (Unix time for captures and SocketCAN, a monotonic clock for some adapters): see the transport.
  std::optional<std::uint64_t> timestamp_ns;

  /// The bytes that are on the wire (empty for remote and error frames with dlc 0).
  [[nodiscard]] constexpr std::span<const std::uint8_t> payload() const noexcept {
    return {data.data(), remote ? 0U : (dlc > kMaxDlc ? kMaxDlc : dlc)};
  }

  /// True when id fits its format and dlc <= 8.
  [[nodiscard]] constexpr bool valid() const noexcept {
    if (dlc > kMaxDlc) return false;
    if (error) return id <= kMaxExtendedId;
    return id <= (extended ? kMaxExtendedId : kMaxStandardId);
  }

  /// Builds a data frame, checking the id range and the length. Cost O(bytes.size()).
  static constexpr Result<CanFrame> data_frame(std::uint32_t id, bool extended,
                                               std::span<const std::uint8_t> bytes) noexcept {
    CanFrame f;
    f.id = id;
    f.extended = extended;
    if (bytes.size() > kMaxDlc) return Reason::invalid_frame;
    f.dlc = static_cast<std::uint8_t>(bytes.size());
    for (std::size_t i = 0; i < bytes.size(); ++i) f.data[i] = bytes[i];
    if (!f.valid()) return Reason::invalid_frame;
    return f;
  }

  /// Equality of what is on the wire and of the timestamp.
  constexpr bool operator==(const CanFrame&) const = default;

  /// Equality of what is on the wire only (id, format, flags, dlc, payload bytes); timestamps ignored.
  [[nodiscard]] constexpr bool same_wire(const CanFrame& o) const noexcept {
    if (id != o.id || extended != o.extended || remote != o.remote || error != o.error || dlc != o.dlc) return false;
    auto a = payload();
    auto b = o.payload();
    for (std::size_t i = 0; i < a.size(); ++i)
      if (a[i] != b[i]) return false;
    return true;
  }
};

}  // namespace saul
