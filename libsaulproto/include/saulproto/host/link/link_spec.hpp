// One way to name a link everywhere (command line, config file, scripts):
//
//   can0, vcan0, socketcan:can0          SocketCAN interface (CANable2 with candleLight firmware)
//   slcan:/dev/ttyACM0[@500000]          slcan adapter on a serial port (CANable2 with slcan firmware), bitrate
//   serial:/dev/ttyUSB0@460800[:8N1]     a plain serial byte link (inter-board UART, CRSF 420000, Pride 38400:8E1)
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saul::host {

struct LinkSpec {
  enum class Kind { socketcan, slcan, serial };
  Kind kind = Kind::socketcan;
  std::string device;             ///< interface name or serial device path
  std::uint32_t bitrate = 500'000;  ///< slcan CAN bitrate
  SerialSettings serial;          ///< serial links
  [[nodiscard]] bool is_can() const { return kind != Kind::serial; }
  [[nodiscard]] std::string text() const;
};

/// A serial port's error as a link's, and back (same kind, or io; same message).
LinkError to_link_error(const SerialError& e);
SerialError to_serial_error(const LinkError& e);
/// Runs `f`; an error of the one kind it throws is thrown as the other (`convert`: one of the two above).
template <class To, class From, class F>
auto rethrow_as(To (*convert)(const From&), F&& f) {
  try {
    return f();
  } catch (const From& e) {
    throw convert(e);
  }
}

/// Parses a link name; throws std::invalid_argument with a message that shows the accepted forms.
LinkSpec parse_link_spec(const std::string& text);

struct LinkOpenOptions {
  bool listen_only = false;        ///< slcan: open the adapter silent
  std::vector<CanFilter> filters{};  ///< in force before the first frame is received (SocketCAN: set before bind)
  /// slcan: this process takes every frame it receives (sniff, record): while it owns the adapter with no other
  /// saulctl attached, the adapter is read only as fast as it takes the frames (shared_link.hpp). Off (commands that
  /// mostly send): the adapter is always read, and the oldest frames unread are dropped, counted.
  bool paced = false;
};

/// Opens a CAN link (SocketCAN, or slcan shared: shared_link.hpp). Throws LinkError; std::invalid_argument for a
/// serial spec.
std::unique_ptr<CanLink> open_can_link(const LinkSpec& spec, const LinkOpenOptions& options = {});

/// Opens a serial byte link (LinkSpec::Kind::serial), shared with other saulctl processes (shared_link.hpp).
/// Throws SerialError; std::invalid_argument for a CAN spec.
std::unique_ptr<SerialPort> open_serial_link(const LinkSpec& spec);

}  // namespace saul::host
