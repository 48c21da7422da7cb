// saulctl ports: which serial ports exist, and which of them are ours (CANable, the boards' USB consoles).
#include <fmt/core.h>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saulctl {
namespace {

int run_ports(bool json) {
  const auto ports = saul::host::list_serial_ports();
  if (json) {
    nlohmann::json arr = nlohmann::json::array();
    for (const auto& p : ports) {
      nlohmann::json j{{"path", p.path}, {"description", p.description}, {"role", p.role}};
      if (p.usb_vid >= 0)
        j.update({{"usb_vid", p.usb_vid}, {"usb_pid", p.usb_pid}, {"manufacturer", p.manufacturer},
                  {"product", p.product}, {"serial_number", p.serial_number}});
      arr.push_back(j);
    }
    fmt::print("{}\n", arr.dump(2));
    return kOk;
  }
  if (ports.empty())
    fmt::print("no serial ports found (is the adapter plugged in? a candleLight CANable shows up as can0: "
               "ip link show)\n");
  for (const auto& p : ports) {
    if (p.usb_vid >= 0) {
      fmt::print("{:<16} {:04x}:{:04x} {} {} serial={}{}\n", p.path, p.usb_vid, p.usb_pid, p.manufacturer, p.product,
                 p.serial_number, p.role.empty() ? "" : "  <- " + p.role);
    } else {
      fmt::print("{:<16} {}\n", p.path, p.description);
    }
  }
  return kOk;
}

}  // namespace

void add_ports_command(CLI::App& app, Runner& run) {
  auto [cmd, json] = add_verb<bool>(app, run, "ports", "List serial ports with their USB identity", run_ports, false);
  cmd->add_flag("--json", *json, "JSON array");
  cmd->footer("\nRecognised: CANable2 slcan (16d0:117e), CANable candleLight (1d50:606f, appears as can0 instead),\n"
              "ESP32-S3 USB-Serial/JTAG (303a:1001, IO board), WCH CH343 (1a86:55d3, BALANCE board).\n");
}

}  // namespace saulctl
