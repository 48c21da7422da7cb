// A Wireshark post-dissector for the robot's CAN frames (SocketCAN pcap/pcapng, link type 227), written as Lua from
// the core's message descriptions. For a SAUL or VESC data frame it adds a tree with every signal in physical units
// and the fields saul.message, saul.<message>.<key> (the value `decode --json` gives under that key) and
// saul.problem (why saulctl rejects the frame), so tshark -T fields prints what decode prints. Lua 5.2.
#pragma once

#include <string>
#include <vector>

namespace saul::host {

/// The whole script.
std::string wireshark_dissector_lua();

/// The names of the fields the script registers ("saul.message", "saul.telemetry_a.pitch", ...), in order.
std::vector<std::string> wireshark_field_names();

}  // namespace saul::host
