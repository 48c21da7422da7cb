// A DBC (Vector CANdb++ text) describing the robot's bus, so cantools, SavvyCAN, python-can and CANalyzer decode
// the same frames as saulctl: the SAUL frames 0x300-0x303 and 0x400-0x402 (docs/protocol.md §3) and, per VESC
// controller, SET_RPM and the status frames STATUS..STATUS_6 (§6).
//
// Choices the DBC format leaves open, made here (they are repeated as comments inside the file):
// - SAUL frames are little-endian (@1), VESC frames big-endian (@0, Motorola: the start bit is the position of the
//   most significant bit in DBC's sawtooth numbering, 8 * byte + 7 for a field starting at a byte boundary).
// - 29-bit VESC ids carry bit 31 (0x80000000), as DBC marks extended ids.
// - 0x301 is multiplexed: gain (byte 0) is the multiplexer M, and each gain (kp m0, ki m1, kd m2) is a
//   32-bit IEEE float in bytes 4-7 declared with SIG_VALTYPE_ 1.
// - Scaled integers keep saulctl's raw meaning with a DBC factor (pitch_x100 -> pitch, factor 0.01, "deg").
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace saul::host {

struct DbcOptions {
  /// VESC controller ids to describe (each gets SET_RPM and STATUS..STATUS_6): the robot's left and right motors.
  std::vector<std::uint8_t> vesc_controllers{68, 56};
};

/// The whole DBC file, LF line ends, ending in a newline.
std::string make_dbc(const DbcOptions& options = {});

}  // namespace saul::host
