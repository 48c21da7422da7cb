// SocketCAN raw socket: can0 (CANable2 with candleLight firmware), vcan0, any Linux CAN netdev.
//
// Kernel timestamps (SO_TIMESTAMPNS), kernel drops counted (SO_RXQ_OVFL), every error frame, the controller state
// tracked from them, filters in the kernel (CAN_RAW_FILTER). A kernel without CAN fails to open with a clear
// message (tests/vm runs these paths against vcan in a real kernel).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "saulproto/host/link/can_link.hpp"

namespace saul::host {

struct SocketCanOptions {
  bool receive_own = false;  ///< CAN_RAW_RECV_OWN_MSGS: see our own frames (for tests)
  /// Installed before the socket is bound, so not one frame of another id is queued for it; receive() checks them
  /// again in software (LinkStats::filtered_late counts what the kernel let through).
  std::vector<CanFilter> filters;
};

std::unique_ptr<CanLink> open_socketcan(const std::string& interface, const SocketCanOptions& options = {});

/// Updates a controller state from one SocketCAN error frame (class bits in id, details in data). Pure.
ControllerState state_after_error_frame(ControllerState current, const CanFrame& error_frame);

/// A CAN network interface as the kernel describes it (netlink RTM_GETLINK, and sysfs for the USB identity).
struct CanInterfaceInfo {
  std::string name;
  std::string kind;                       ///< "can" (a real controller: gs_usb, ...), "vcan", "slcan", ...
  bool up = false;
  std::optional<std::uint32_t> bitrate;   ///< IFLA_CAN_BITTIMING, when the driver has one
  std::optional<ControllerState> state;   ///< IFLA_CAN_STATE; nullopt for stopped, sleeping or unknown
  std::string driver;                     ///< the device's kernel driver (gs_usb for the candleLight CANable2)
  int usb_vid = -1;
  int usb_pid = -1;
};

/// Every CAN interface of this machine (sysfs type 280), described; empty when the kernel has none.
std::vector<CanInterfaceInfo> list_can_interfaces();
/// One interface; nullopt when there is no interface of that name.
std::optional<CanInterfaceInfo> can_interface_info(const std::string& interface);

}  // namespace saul::host
