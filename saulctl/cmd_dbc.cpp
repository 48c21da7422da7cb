// saulctl dbc: writes the DBC of the robot's bus (SAUL frames and the VESC frames), made by the host library
// (saulproto/host/report/dbc.hpp), for cantools, SavvyCAN and CANalyzer.
#include <fmt/core.h>

#include <fstream>

#include "commands.hpp"
#include "saulproto/host/report/dbc.hpp"

namespace saulctl {
namespace {

struct DbcCliOptions {
  std::string output;
};

int run_dbc(const DbcCliOptions& opt) {
  const std::string text = saul::host::make_dbc();
  if (opt.output.empty() || opt.output == "-") {
    fmt::print("{}", text);
    return std::fflush(stdout) == 0 ? kOk : kFailure;
  }
  std::ofstream out(opt.output, std::ios::binary | std::ios::trunc);
  if (!out) {
    say("cannot open '{}' for writing", opt.output);
    return kFailure;
  }
  out << text;
  out.close();
  if (!out) {
    say("writing '{}' failed", opt.output);
    return kFailure;
  }
  return kOk;
}

}  // namespace

void add_dbc_command(CLI::App& app, Runner& run) {
  auto [cmd, opt] = add_verb<DbcCliOptions>(
      app, run, "dbc", "Write a DBC of the robot's bus (SAUL frames, VESC SET_RPM and status)", run_dbc, false);
  cmd->footer(
      "\nThe DBC describes 0x300-0x303 and 0x400-0x402 (little-endian, scaled: pitch in deg, battery in V), with\n"
      "0x301 multiplexed by its gain index (kp/ki/kd as float32 signals), value tables for mode, state and ack\n"
      "result, and SET_RPM and STATUS..STATUS_6 of VESC controllers 68 and 56 (29-bit ids, big-endian).\n"
      "\nExamples:\n"
      "  saulctl dbc -o saul.dbc\n"
      "  python3 -m cantools decode saul.dbc < run.log      cantools reads candump logs\n"
      "  saulctl dbc | grep '^BO_'                          the messages\n");
  cmd->add_option("-o,--output", opt->output, "file to write (default: standard output)");
}

}  // namespace saulctl
