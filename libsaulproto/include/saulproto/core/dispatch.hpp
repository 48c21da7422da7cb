// One entry point for everything on the robot's CAN bus: a frame in, a typed message (or a reason) out.
//
// Standard (11-bit) ids are SAUL frames (saul_can.hpp). Extended (29-bit) ids are VESC frames (vesc.hpp).
// Firmware, saulctl and the simulator all call decode_bus_frame(), so they agree on every frame.
#pragma once

#include <variant>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/result.hpp"
#include "saulproto/core/saul_can.hpp"
#include "saulproto/core/vesc.hpp"

namespace saul {

/// Every message type the bus carries: the SAUL frames, then the VESC frames. Each alternative has kName and
/// fields(visitor), which the host formatters use to print any message without knowing its type.
/// sizeof(BusMessage) is that of the largest alternative (12 bytes) plus the index.
using BusMessage = std::variant<saulcan::VelocityCmd, saulcan::PidGain, saulcan::ModeCmd, saulcan::ConfigCmd,
                                saulcan::TelemetryA, saulcan::TelemetryB, saulcan::CommandAck,
                                vesc::SetDuty, vesc::SetCurrent, vesc::SetCurrentBrake, vesc::SetRpm, vesc::SetPos,
                                vesc::SetCurrentRel, vesc::Status1, vesc::Status2, vesc::Status3, vesc::Status4,
                                vesc::Status5, vesc::Status6, vesc::Ping, vesc::Pong>;

/// Decodes any frame seen on the bus: standard ids go to saulcan::decode(), extended ids to vesc::decode().
/// Fails with error_frame, invalid_frame (id too large for its format, DLC > 8), unknown_id, or the codec's own
/// reason (wrong_dlc, remote_frame, out_of_range, ...). O(1), no allocation.
Result<BusMessage> decode_bus_frame(const CanFrame& frame) noexcept;

/// The message's short name, e.g. "velocity_cmd".
const char* name_of(const BusMessage& message) noexcept;

/// decode_bus_frame()'s outcome with the message's name in place of the message: the same reason when it fails,
/// name_of() of its message when it decodes. The codecs' checks all run; no BusMessage is built, copied or visited.
Result<DecodedName> decode_bus_name(const CanFrame& frame) noexcept;

/// Encodes any bus message into the frame that carries it (saulcan::encode or vesc::encode, by the type).
CanFrame encode_bus_message(const BusMessage& message) noexcept;

}  // namespace saul
