// saulctl wireshark: writes the Lua dissector of the robot's CAN frames, made by the host library from the core's
// message descriptions (saulproto/host/report/wireshark.hpp).
#include <fmt/core.h>

#include <cstdio>
#include <fstream>
#include <memory>

#include "commands.hpp"
#include "saulproto/host/report/wireshark.hpp"

namespace saulctl {
namespace {

int write_dissector(const std::string& path, bool fields) {
  std::string text;
  if (fields) {
    for (const auto& name : saul::host::wireshark_field_names()) text += name + "\n";
  } else {
    text = saul::host::wireshark_dissector_lua();
  }
  if (path.empty() || path == "-") {
    fmt::print("{}", text);
    return std::fflush(stdout) == 0 ? kOk : kFailure;
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (out) return kOk;
  say("cannot write '{}'", path);
  return kFailure;
}

}  // namespace

void add_wireshark_command(CLI::App& app, Runner& run) {
  auto output = std::make_shared<std::string>();
  auto fields = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand("wireshark", "Write a Wireshark dissector (Lua) for the robot's CAN frames");
  cmd->footer(
      "\nA post-dissector for SocketCAN captures (pcap/pcapng, link type 227): every SAUL frame (0x300-0x303,\n"
      "0x400-0x402) and VESC frame gets a tree of its signals in physical units, and fields saul.message,\n"
      "saul.problem and saul.<message>.<key> holding what `saulctl decode --json` prints. Generated from the\n"
      "same message descriptions the codecs use.\n"
      "\nExamples:\n"
      "  saulctl wireshark -o saul.lua && wireshark -X lua_script:saul.lua run.pcapng\n"
      "  tshark -X lua_script:saul.lua -r run.pcapng -Y saul.message -T fields -e saul.telemetry_a.pitch\n"
      "  cp saul.lua ~/.local/lib/wireshark/plugins/            for every capture\n"
      "  saulctl wireshark --fields                             the field names\n");
  cmd->add_option("-o,--output", *output, "file to write (default: standard output)");
  cmd->add_flag("--fields", *fields, "list the fields the dissector registers instead");
  cmd->callback([output, fields, &run] { run = [output, fields] { return write_dissector(*output, *fields); }; });
}

}  // namespace saulctl
