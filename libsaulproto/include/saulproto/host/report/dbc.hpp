// A DBC (Vector CANdb++ text) of the robot's bus, so cantools, SavvyCAN and CANalyzer decode the frames as saulctl
// does: the SAUL frames (docs/protocol.md §3) and, for the left and right VESC, SET_RPM and STATUS..STATUS_6 (§6).
// The choices DBC leaves open are written as comments inside the file: SAUL little-endian, VESC big-endian with
// bit 31 marking their 29-bit ids, 0x301 multiplexed by gain with float32 gains (SIG_VALTYPE_ 1).
#pragma once

#include <string>

namespace saul::host {

/// The whole DBC file, LF line ends, ending in a newline.
std::string make_dbc();

}  // namespace saul::host
