// Who has a serial device open: the answer to "busy" that names the program, read from /proc.
//
// A serial adapter has one owner at a time (serial_port.cpp holds it with TIOCEXCL and an advisory flock; other
// saulctl processes reach it through the owner, shared_link.hpp). When it is taken, the message names the holder:
// "/dev/ttyACM0 is held by minicom (pid 4121)". Only processes this user may inspect are seen (root sees all).
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace saul::host {

struct DeviceHolder {
  int pid = 0;
  std::string name;     ///< the program, from /proc/PID/comm ("minicom", "saulctl")
  std::string command;  ///< for a saulctl, its verb too ("saulctl monitor"); else the same as name
  [[nodiscard]] std::string text() const;  ///< "minicom (pid 4121)"
  [[nodiscard]] bool is_saulctl() const { return name == "saulctl"; }
};

/// Other processes that have `device` open (symlinks resolved: /dev/serial/by-id/... finds /dev/ttyACM0).
/// This process is left out, and so is a process that holds the other end of a pseudo-terminal (its master, as
/// the simulator and the test fakes do): that process is the device, not a competitor.
std::vector<DeviceHolder> device_holders(const std::string& device);

/// A UUCP lock file (/run/lock/LCK..ttyACM0 or /var/lock/LCK..ttyACM0) naming a live process other than this
/// one, as minicom, cu and others leave them.
std::optional<DeviceHolder> uucp_lock_holder(const std::string& device);

/// "minicom (pid 4121)", "cat (pid 80) and saulctl sniff (pid 81)"; "" for none.
std::string describe_holders(const std::vector<DeviceHolder>& holders);

/// A process's program and its first argument unless that is an option (a saulctl's verb), from /proc/PID/cmdline
/// ("self": this process): "saulctl monitor"; "?" when it cannot be read.
std::string process_command(const std::string& pid);

/// The device's canonical path (symlinks resolved), or the path itself when it does not exist.
std::string canonical_device(const std::string& device);

}  // namespace saul::host
