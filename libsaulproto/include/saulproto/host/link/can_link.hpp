// A live CAN bus, whatever the adapter (SocketCAN, or slcan over a serial port), behind one small interface.
// Errors are LinkError exceptions with a one-line message naming the device and the likely fix.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"

namespace saul::host {

class LinkError : public std::runtime_error {
 public:
  enum class Kind { not_found, permission, busy, down, gone, unsupported, timeout, io };
  LinkError(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  [[nodiscard]] Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

/// CAN controller error state, as the kernel or adapter reports it.
enum class ControllerState : std::uint8_t { unknown, active, warning, passive, bus_off };
const char* to_string(ControllerState s);

/// Where a received frame's timestamp came from.
enum class TimestampSource : std::uint8_t {
  kernel,     ///< SocketCAN SO_TIMESTAMPNS (CLOCK_REALTIME at reception in the kernel)
  host_read,  ///< the host's realtime clock when read() returned: the stock CANable firmwares send no stamps
};
const char* to_string(TimestampSource s);

struct LinkStats {
  std::uint64_t rx_frames = 0;
  std::uint64_t tx_frames = 0;
  std::uint64_t rx_dropped = 0;      ///< frames the kernel or adapter lost (SO_RXQ_OVFL, overflow flags)
  std::uint64_t error_frames = 0;    ///< error frames received
  std::uint64_t bus_off_events = 0;  ///< transitions into bus-off
  std::uint64_t recoveries = 0;      ///< channel reopenings (reopen())
  std::uint64_t tx_retries = 0;      ///< sends that met a full queue (ENOBUFS) and waited
  std::uint64_t rejected_input = 0;  ///< adapter output that could not be parsed (slcan)
  std::uint64_t filtered_late = 0;   ///< frames the kernel passed that the filters refuse (re-checked in software)
  /// The last send(): from the call to the frame's write to the device returning, in ns (0 = not measured). Through
  /// a shared link (shared_link.hpp) it is measured to the owner's write, so it includes the hop between processes.
  std::uint64_t last_send_ns = 0;
  ControllerState state = ControllerState::unknown;
};

/// Filter: a frame passes when (frame.id & mask) == (id & mask) and its format (extended) matches.
struct CanFilter {
  std::uint32_t id = 0;
  std::uint32_t mask = 0;
  bool extended = false;
};

class CanLink {
 public:
  virtual ~CanLink() = default;
  /// Queues a frame for the bus; waits (back-pressure) up to timeout when the transmit queue is full, then
  /// throws LinkError(timeout). Error frames and invalid frames are refused (LinkError(unsupported)).
  virtual void send(const CanFrame& frame, std::chrono::milliseconds timeout) = 0;
  /// The next frame (error frames included), or nullopt when none came within timeout.
  /// Throws LinkError(gone/down) when the adapter disappears.
  virtual std::optional<CanFrame> receive(std::chrono::milliseconds timeout) = 0;
  /// Restricts what receive() returns (where the transport can, in the kernel). Empty = everything.
  virtual void set_filters(const std::vector<CanFilter>& filters) = 0;
  /// slcan: closes and reopens the channel, in normal mode (out of listen-only or bus-off); counted in
  /// stats().recoveries. Other links do nothing (a SocketCAN restart goes through netlink and needs root), and so
  /// does the shared link open_can_link() gives: its owner reopens the device's own link itself, when an ESTOP must
  /// leave listen-only (shared_link.cpp).
  virtual void reopen() {}
  [[nodiscard]] virtual LinkStats stats() const = 0;
  [[nodiscard]] virtual const std::string& name() const = 0;
  [[nodiscard]] virtual TimestampSource timestamp_source() const = 0;
  /// A descriptor that polls readable when receive() may have a frame (-1 when there is none).
  [[nodiscard]] virtual int poll_handle() const { return -1; }
  /// How this link is shared with other saulctl processes (shared_link.hpp): "" when it is not,
  /// "shared with 2 other saulctl", "through saulctl monitor (pid 77)".
  [[nodiscard]] virtual std::string sharing() const { return {}; }
};

// CAN id filters (can_filter.cpp): `--id` of sniff, record and replay, the kernel's and the software check.

/// Parses a CAN id: 1 to 8 hex digits ("0x" allowed); more than 3 digits or a value above 0x7FF means 29-bit
/// (`extended` set). `whole` is what an error message quotes. Throws std::invalid_argument.
std::uint32_t parse_can_id(std::string_view text, std::string_view whole, bool& extended);
/// Parses "300" or "300:7F0" (ID[:MASK], hex, like `saulctl sniff --id`): without a mask, every id bit of the
/// id's format. Throws std::invalid_argument.
CanFilter parse_id_filter(std::string_view text);
/// Software filter check, shared by the transports that cannot filter in hardware: true when `filters` is empty,
/// for an error frame, or when one filter matches (same format, (id & mask) equal).
bool passes(const std::vector<CanFilter>& filters, const CanFrame& frame);

/// Realtime clock now, in ns since the Unix epoch.
std::uint64_t realtime_ns();

}  // namespace saul::host
