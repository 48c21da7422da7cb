// A CAN link through an slcan adapter on a serial port (CANable2 with the slcan firmware, or the simulator's).
// Opening sends "C\r", "S<n>\r", then "O\r" (or the listen-only sequence); closing sends "C\r". The stock
// CANable firmwares never answer a command, so nothing waits for an answer; input is parsed in bulk.
#pragma once

#include <memory>
#include <string>

#include "saulproto/host/link/can_link.hpp"

namespace saul::host {

struct SlcanOptions {
  std::uint32_t bitrate = 500'000;
  /// Listen only (no ACKs, no transmissions). Sent as "L" (Lawicel) when the adapter's version reply looks
  /// Lawicel, else "M1" (CANable stock firmware); the version is asked for first.
  bool listen_only = false;
};

std::unique_ptr<CanLink> open_slcan(const std::string& path, const SlcanOptions& options = {});

}  // namespace saul::host
