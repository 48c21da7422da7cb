// One way to name a link everywhere (command line, config file, scripts):
//
//   can0, vcan0, socketcan:can0          SocketCAN interface (CANable2 with candleLight firmware)
//   slcan:/dev/ttyACM0[@500000]          slcan adapter on a serial port (CANable2 with slcan firmware), bitrate
//   serial:/dev/ttyUSB0@460800[:8N1]     a plain serial byte link (inter-board UART, CRSF 420000, Pride 38400:8E1)
#pragma once

#include <memory>
#include <stdexcept>
#include <string>

#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saul::host {

struct LinkSpec {
  enum class Kind { socketcan, slcan, serial };
  Kind kind = Kind::socketcan;
  std::string device;             ///< interface name or serial device path
  std::uint32_t bitrate = 500'000;  ///< slcan CAN bitrate
  SerialSettings serial;          ///< serial links
  SerialBackend backend = SerialBackend::automatic;
  [[nodiscard]] bool is_can() const { return kind != Kind::serial; }
  [[nodiscard]] std::string text() const;
};

/// Parses a link name; throws std::invalid_argument with a message that shows the accepted forms.
LinkSpec parse_link_spec(const std::string& text);

/// Opens a CAN link (SocketCAN or slcan). Throws LinkError; std::invalid_argument for a serial spec.
std::unique_ptr<CanLink> open_can_link(const LinkSpec& spec, bool listen_only = false);

}  // namespace saul::host
