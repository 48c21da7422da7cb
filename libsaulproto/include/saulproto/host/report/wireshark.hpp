// A Wireshark dissector for the robot's CAN frames, written as a Lua script from the core's message descriptions
// (core/signals*.hpp, the same ones the codecs are held to): one source of truth, no second table.
//
// The script is a post-dissector for SocketCAN captures (pcap and pcapng with link type 227, as saulctl record,
// candump -> convert, tcpdump -i can0 and python-can write them). For a classic data frame whose 11-bit id is a
// SAUL frame (0x300-0x303, 0x400-0x402) or whose 29-bit id is a VESC command (id bits 15..8, the controller in
// bits 7..0), it adds a "SAUL-TEE" tree with every signal in physical units, value names and fault-bit names, and
// the fields
//   saul.message                the message name ("telemetry_a", "vesc_status_1")
//   saul.<message>.<key>        each signal, with the value `saulctl decode --json` gives it (same key, same form:
//                               the wire integer, the value's name, or the physical value)
//   saul.problem                why saulctl's decoder rejects the frame (wrong_dlc, out_of_range), with an expert
//                               warning
// so that `tshark -X lua_script:saul.lua -r run.pcapng -T fields -e saul.telemetry_a.pitch_x100` prints what decode
// prints. Lua 5.2 (Wireshark 3.x and 4.x); numbers are doubles, exact for the 32-bit signals the robot has.
#pragma once

#include <string>
#include <vector>

namespace saul::host {

/// The whole script.
std::string wireshark_dissector_lua();

/// The names of the fields the script registers ("saul.message", "saul.telemetry_a.pitch_x100", ...), in order.
std::vector<std::string> wireshark_field_names();

}  // namespace saul::host
