// saulctl doctor: checks what usually goes wrong at a bench, one line per check, and the single most likely fix
// for each failure. Only host-library calls (list_serial_ports, open_serial, open_can_link).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/link/link_spec.hpp"
#include "saulproto/host/link/device_holders.hpp"
#include "saulproto/host/link/serial_port.hpp"
#include "saulproto/host/link/shared_link.hpp"
#include "saulproto/host/link/socketcan.hpp"
#include "saulproto/core/saul_can.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;
using saul::host::LinkError;
using saul::host::SerialError;

struct DoctorOptions {
  std::string link;
  std::string wait = "1s";
  bool json = false;
  std::string sysroot = "/";  // --sysroot: where /proc and the udev rule folders are (tests give a fake one)
};

// Each check's outcome: a line (and its fix) for people, or, with --json, one element of the "checks" array.
struct Checks {
  bool json = false;
  int failures = 0;
  nlohmann::json list = nlohmann::json::array();
  void ok(const std::string& what, const std::string& detail) { add("ok", "ok  ", what, detail, ""); }
  void fail(const std::string& what, const std::string& detail, const std::string& fix) {
    ++failures;
    add("fail", "FAIL", what, detail, fix);
  }
  void skip(const std::string& what, const std::string& why) { add("skip", "-   ", what, why, ""); }
  void warn(const std::string& what, const std::string& detail, const std::string& fix) {
    add("warn", "WARN", what, detail, fix);
  }

 private:
  /// `result` for JSON, `tag` for people.
  void add(const char* result, const char* tag, const std::string& what, const std::string& detail,
           const std::string& fix) {
    if (json) {
      nlohmann::json j{{"check", what}, {"result", result}, {"detail", detail}};
      if (!fix.empty()) j["fix"] = fix;
      list.push_back(std::move(j));
      return;
    }
    fmt::print("{} {}: {}\n", tag, what, detail);
    if (!fix.empty()) fmt::print("     fix: {}\n", fix);
  }
};

/// Returns the ports listed (none when listing failed), for find_adapter.
std::vector<saul::host::PortInfo> check_ports(Checks& c, bool needed) {
  std::vector<saul::host::PortInfo> ports;
  try {
    ports = saul::host::list_serial_ports();
  } catch (const std::exception& e) {
    c.fail("serial ports", e.what(), "check that libserialport can read /sys/class/tty");
    return ports;
  }
  if (ports.empty()) {
    if (needed)
      c.fail("serial ports", "none found",
             "plug in the CANable2 / the boards' USB cables (a data cable, not a charge-only one); dmesg shows them");
    else
      c.skip("serial ports", "none found (not needed for a SocketCAN link)");
    return ports;
  }
  std::string list;
  for (const auto& p : ports)
    list += fmt::format("{}{}{}", list.empty() ? "" : ", ", p.path, p.role.empty() ? "" : " (" + p.role + ")");
  c.ok("serial ports", fmt::format("{} found: {}", ports.size(), list));
  return ports;
}

// Bus traffic, and the robot in it: BALANCE's 0x400 telemetry (10 Hz) within the wait.
void check_traffic(Checks& c, saul::host::CanLink& link, milliseconds wait) {
  const auto deadline = steady_clock::now() + wait;
  std::uint64_t frames = 0;
  std::optional<saul::saulcan::TelemetryA> robot;
  while (!g_interrupted && !robot) {
    const auto now = steady_clock::now();
    if (now >= deadline) break;
    if (auto f = link.receive(ceil<milliseconds>(deadline - now))) {
      ++frames;
      if (auto a = saul::saulcan::decode_telemetry_a(*f)) robot = *a;
    }
  }
  if (frames > 0) {
    c.ok("bus traffic", fmt::format("frames seen on {}", link.name()));
    if (robot)
      c.ok("robot", fmt::format("BALANCE sends telemetry (0x400), state {}", saul::saulcan::to_string(robot->state)));
    else
      c.fail("robot", fmt::format("{} frames but no 0x400 telemetry within {} ms: BALANCE is not on the bus", frames,
                                  wait.count()),
             "power the BALANCE board and check its CAN wiring ('saulctl sniff' shows which nodes do talk)");
  } else {
    c.fail("bus traffic", fmt::format("no frame on {} within {} ms: no robot found", link.name(), wait.count()),
           "power the robot and check CAN_H/CAN_L wiring, the 120 ohm termination and the bitrate (500 kbit/s)");
  }
  const auto state = link.stats().state;
  using saul::host::ControllerState;
  if (state == ControllerState::bus_off || state == ControllerState::passive)
    c.fail("error state", fmt::format("controller is {}", saul::host::to_string(state)),
           "wrong bitrate or wiring: every node must run 500 kbit/s and the bus needs termination at both ends");
  else if (state == ControllerState::warning)
    c.fail("error state", "controller in error-warning",
           "errors on the bus: check termination and CAN_H/CAN_L, then 'saulctl sniff' for error frames");
  else
    c.ok("error state", saul::host::to_string(state));
}

// Lawicel's V: a Lawicel-complete firmware answers "Vhhss"; the stock CANable slcan firmware answers nothing (or
// its own text). Either is fine; the answer is shown.
void check_slcan_version(Checks& c, saul::host::SerialPort& port) {
  port.write(std::string("V\r"), milliseconds(200));
  std::string got;
  const auto deadline = steady_clock::now() + milliseconds(300);
  std::array<std::uint8_t, 256> buf{};
  while (got.find('\r') == std::string::npos && steady_clock::now() < deadline) {
    const auto n = port.read(buf, ceil<milliseconds>(deadline - steady_clock::now()));
    got.append(reinterpret_cast<const char*>(buf.data()), n);
  }
  const auto v = got.find_first_of("Vv");
  const auto end = got.find('\r', v == std::string::npos ? 0 : v);
  if (v != std::string::npos && end != std::string::npos)
    c.ok("slcan firmware", "answers V with '" + got.substr(v, end - v) + "'");
  else
    c.skip("slcan firmware", "no answer to V within 300 ms (the stock CANable slcan firmware sends none; fine)");
}

// A saulctl of this user that holds the device and shares it is fine: the checks go through it (another program
// holding it is named by open_serial's error, with its pid).
enum class Sharing { none, shared, refused };
Sharing check_sharing(Checks& c, const std::string& dev) {
  std::optional<saul::host::ShareInfo> share;
  try {
    share = saul::host::query_share(dev);
  } catch (const LinkError& e) {
    c.fail("not busy", e.what(), "stop the other user's saulctl, or check " + saul::host::share_directory_path());
    return Sharing::refused;
  }
  if (!share) return Sharing::none;
  c.ok("port exists", dev);
  c.ok("not busy", fmt::format("{} is held by {} as {} and shared with this user's saulctl commands ({} other{} now)",
                               dev, share->owner_text(), share->link, share->clients, share->clients == 1 ? "" : "s"));
  return Sharing::shared;
}

std::string holder_fix(const std::string& dev) {
  const auto holders = saul::host::device_holders(dev);
  if (holders.empty()) return "find it with: sudo fuser -v " + dev;
  const auto& h = holders.front();
  return h.is_saulctl() ? fmt::format("stop it (kill {}), then run this again", h.pid)
                        : fmt::format("quit {} (or: kill {}); saulctl shares a port only with other saulctl commands",
                                      h.name, h.pid);
}

void check_slcan(Checks& c, const saul::host::LinkSpec& spec, milliseconds wait) {
  const std::string& dev = spec.device;
  const Sharing sharing = check_sharing(c, dev);
  if (sharing == Sharing::refused) return;
  try {
    if (sharing == Sharing::none) {
      auto port = saul::host::open_serial(dev, saul::host::SerialSettings{});
      c.ok("port exists", dev);
      c.ok("permission", "can open " + dev);
      c.ok("not busy", dev + " is free");
      check_slcan_version(c, *port);
    }
  } catch (const SerialError& e) {
    switch (e.kind()) {
      case SerialError::Kind::not_found:
        c.fail("port exists", dev + " not found",
               "plug in the CANable2 (slcan firmware) and find its path with 'saulctl ports'");
        return;
      case SerialError::Kind::permission:
        c.ok("port exists", dev);
        c.fail("permission", "permission denied on " + dev,
               "sudo usermod -aG dialout $USER, then log out and in again");
        return;
      case SerialError::Kind::busy:
        c.ok("port exists", dev);
        c.fail("not busy", e.what(), holder_fix(dev));
        return;
      default:
        c.fail("port exists", e.what(), "unplug and replug the adapter; dmesg shows what the kernel says");
        return;
    }
  }
  try {
    auto link = saul::host::open_can_link(spec);
    const auto how = link->sharing();
    c.ok("slcan channel", fmt::format("opened at {} bit/s{}", spec.bitrate, how.empty() ? "" : " (" + how + ")"));
    check_traffic(c, *link, wait);
  } catch (const std::exception& e) {
    c.fail("slcan channel", e.what(),
           "is this a CANable2 with slcan firmware? candleLight firmware shows up as a network interface (ip link)");
  }
}

std::string usb_text(int vid, int pid) { return vid < 0 ? "" : fmt::format(" {:04x}:{:04x}", vid, pid); }

// Without a link: the CANable2s plugged in, by USB id, on either firmware. The one adapter found is checked as the
// link; none is a failure (today's robot needs one), several are listed for --link.
std::optional<saul::host::LinkSpec> find_adapter(Checks& c, const std::vector<saul::host::PortInfo>& ports) {
  std::vector<std::string> found;
  std::vector<std::string> links;
  for (const auto& p : ports)
    if (p.role.find("slcan firmware") != std::string::npos) {
      found.push_back(fmt::format("{} ({:04x}:{:04x}, slcan firmware)", p.path, p.usb_vid, p.usb_pid));
      links.push_back("slcan:" + p.path);
    }
  for (const auto& i : saul::host::list_can_interfaces()) {
    if (i.usb_vid < 0) continue;  // vcan and other virtual interfaces are no adapter
    found.push_back(fmt::format("{} ({}{}, candleLight firmware{}{})", i.name, i.driver.empty() ? "?" : i.driver,
                                usb_text(i.usb_vid, i.usb_pid), i.up ? ", up" : ", down",
                                i.bitrate ? fmt::format(", {} bit/s", *i.bitrate) : ""));
    links.push_back(i.name);
  }
  if (found.empty()) {
    c.fail("adapter", "no CANable2 found: neither the slcan firmware (USB 16d0:117e, a serial port) nor candleLight "
                      "(1d50:606f, a CAN interface)",
           "plug the CANable2 in with a data cable (lsusb lists it), then: saulctl doctor --link slcan:/dev/ttyACM0 "
           "or --link can0");
    return std::nullopt;
  }
  c.ok("adapter", fmt::format("{}", fmt::join(found, ", ")));
  if (links.size() != 1) return std::nullopt;
  c.ok("link", "none given: checking " + links[0]);
  return saul::host::parse_link_spec(links[0]);
}

void check_socketcan(Checks& c, const saul::host::LinkSpec& spec, milliseconds wait) {
  const std::string& ifname = spec.device;
  try {
    auto link = saul::host::open_can_link(spec);
    c.ok("interface exists", ifname);
    c.ok("interface up", ifname);
    // What the kernel says about it (netlink): its kind, driver, bitrate and controller state.
    if (const auto info = saul::host::can_interface_info(ifname)) {
      const std::string what = fmt::format("{} ({}{}{})", ifname, info->kind.empty() ? "?" : info->kind,
                                           info->driver.empty() ? "" : ", " + info->driver,
                                           usb_text(info->usb_vid, info->usb_pid));
      if (info->bitrate && *info->bitrate != 500'000)
        c.fail("bitrate", fmt::format("{} runs at {} bit/s; the robot's bus is 500000", what, *info->bitrate),
               fmt::format("sudo ip link set {} down; sudo ip link set {} up type can bitrate 500000", ifname, ifname));
      else
        c.ok("bitrate", info->bitrate ? fmt::format("{} at {} bit/s", what, *info->bitrate)
                                      : what + ": no bit timing (a virtual interface)");
      if (info->state) {
        using saul::host::ControllerState;
        if (*info->state == ControllerState::bus_off || *info->state == ControllerState::passive)
          c.fail("controller", fmt::format("{} is {}", ifname, saul::host::to_string(*info->state)),
                 fmt::format("wrong bitrate or wiring; then: sudo ip link set {} type can restart", ifname));
        else
          c.ok("controller", saul::host::to_string(*info->state));
      }
    }
    check_traffic(c, *link, wait);
  } catch (const LinkError& e) {
    switch (e.kind()) {
      case LinkError::Kind::not_found:
        c.fail("interface exists", ifname + " not found",
               "plug in the CANable2 (candleLight firmware); 'ip link' lists CAN interfaces, 'saulctl ports' slcan ones");
        return;
      case LinkError::Kind::down:
        c.ok("interface exists", ifname);
        c.fail("interface up", ifname + " is down", "sudo ip link set " + ifname + " up type can bitrate 500000");
        return;
      case LinkError::Kind::unsupported:
        c.fail("interface exists", e.what(), "this kernel has no CAN support: sudo modprobe can-raw");
        return;
      default:
        c.fail("interface exists", e.what(), "check 'ip -details link show " + ifname + "'");
        return;
    }
  }
}

// ModemManager's AT-command probe of every new ttyACM garbles a CANable2 on slcan firmware (USB 16d0:117e). Any
// udev rules file naming 16d0, 117e and ID_MM_DEVICE_IGNORE (packaging/60-saulctl-canable.rules does) keeps it off.
bool modemmanager_running(const std::filesystem::path& root) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(root / "proc", ec)) {
    const auto name = entry.path().filename().string();
    if (name.empty() || !std::isdigit(static_cast<unsigned char>(name[0]))) continue;
    std::ifstream comm(entry.path() / "comm");
    std::string line;
    if (std::getline(comm, line) && line == "ModemManager") return true;
  }
  return false;
}

std::optional<std::filesystem::path> canable_mm_rule(const std::filesystem::path& root) {
  for (const char* dir : {"etc/udev/rules.d", "run/udev/rules.d", "usr/local/lib/udev/rules.d", "usr/lib/udev/rules.d",
                          "lib/udev/rules.d"}) {
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(root / dir, ec)) {
      if (entry.path().extension() != ".rules") continue;
      std::ifstream in(entry.path());
      std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      for (auto& ch : text) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
      if (text.find("16d0") != std::string::npos && text.find("117e") != std::string::npos &&
          text.find("id_mm_device_ignore") != std::string::npos)
        return entry.path();
    }
  }
  return std::nullopt;
}

void check_modemmanager(Checks& c, const std::filesystem::path& root) {
  if (!modemmanager_running(root)) {
    c.ok("ModemManager", "not running");
  } else if (const auto rule = canable_mm_rule(root)) {
    c.ok("ModemManager", "running; " + rule->string() + " keeps it off the CANable2 (slcan)");
  } else {
    c.warn("ModemManager", "running, and no udev rule keeps it off a CANable2 on slcan firmware (USB 16d0:117e): "
                           "its AT-command probe garbles slcan",
           "install the saulctl package (its udev rule sets ID_MM_DEVICE_IGNORE), or copy "
           "packaging/60-saulctl-canable.rules to /etc/udev/rules.d/ and run 'sudo udevadm control --reload-rules', "
           "then replug; or: sudo systemctl disable --now ModemManager");
  }
}

int run_doctor(const DoctorOptions& opt) {
  const auto wait = parse_duration(opt.wait);
  std::optional<saul::host::LinkSpec> spec;
  try {
    spec = resolve_link(opt.link);
  } catch (const CLI::ValidationError&) {
    if (!opt.link.empty()) throw;
  }
  Checks c{.json = opt.json};
  const auto ports = check_ports(c, !spec || spec->kind != saul::host::LinkSpec::Kind::socketcan);
  check_modemmanager(c, opt.sysroot.empty() ? "/" : opt.sysroot);
  if (!spec) spec = find_adapter(c, ports);
  if (!spec) {
    c.skip("link", "none given (--link or SAUL_LINK) and no single adapter to check");
  } else if (spec->kind == saul::host::LinkSpec::Kind::slcan) {
    check_slcan(c, *spec, wait);
  } else if (spec->kind == saul::host::LinkSpec::Kind::socketcan) {
    check_socketcan(c, *spec, wait);
  } else {
    try {
      auto port = saul::host::open_serial_link(*spec);
      const auto how = port->sharing();
      c.ok("serial link", spec->device + " opens" + (how.empty() ? "" : " (" + how + ")"));
    } catch (const std::exception& e) {
      c.fail("serial link", e.what(), "see 'saulctl ports' for the path; dialout group for permission");
    }
  }
  if (opt.json)
    fmt::print("{}\n", nlohmann::json{{"checks", c.list}, {"failed", c.failures}}.dump());
  else
    fmt::print("{}\n", c.failures == 0 ? "all checks passed" : fmt::format("{} check(s) failed", c.failures));
  return c.failures == 0 ? kOk : kFailure;
}

}  // namespace

void add_doctor_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<DoctorOptions>(
      app, run, "doctor", "Check the bench setup and print the most likely fix for each problem", run_doctor);
  add_link_option(cmd, o->link, true);
  cmd->add_option("--wait", o->wait, "how long to listen for bus traffic")->capture_default_str()->check(duration_check());
  cmd->add_flag("--json", o->json, "one JSON object: {\"checks\": [{check, result, detail, fix}], \"failed\": N}");
  cmd->add_option("--sysroot", o->sysroot, "the system root whose /proc and udev rules the ModemManager check reads")
      ->capture_default_str();
  cmd->footer(
      "\nChecks: serial ports present (CANable2 / ESP32 roles recognised); ModemManager (a warning when it runs\n"
      "without the CANable2 udev rule); without --link, the CANable2s plugged in (by USB id, both firmwares; the one\n"
      "found is checked); for slcan: port exists, permission, busy (and which program holds it), the firmware's\n"
      "answer to V, channel opens, bus traffic, the robot's telemetry, error state; for SocketCAN: interface exists,\n"
      "up, bitrate and controller state (netlink), bus traffic, the robot's telemetry, error state.\n"
      "\nExamples:\n  saulctl doctor --link slcan:/dev/ttyACM0\n  saulctl doctor --link can0\n"
      "\nExit codes: 0 all ok, 1 a check failed, 2 usage.\n");
}

}  // namespace saulctl
