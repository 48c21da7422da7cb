#include "saulproto/host/link/device_holders.hpp"

#include <dirent.h>
#include <signal.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "../util.hpp"

namespace saul::host {
namespace holders {  // named: the library is compiled in unity batches

bool all_digits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

std::string read_link(const std::string& path) {
  char buf[PATH_MAX];
  const ssize_t n = ::readlink(path.c_str(), buf, sizeof buf - 1);
  if (n <= 0) return {};
  return std::string(buf, static_cast<std::size_t>(n));
}

// "/dev/pts/7" -> 7; -1 for anything else.
int pts_index(const std::string& canonical) {
  if (canonical.rfind("/dev/pts/", 0) != 0) return -1;
  const std::string n = canonical.substr(9);
  return all_digits(n) ? std::atoi(n.c_str()) : -1;
}

// The pseudo-terminal index a ptmx descriptor stands for (/proc/PID/fdinfo/FD, "tty-index:"), -1 when none.
int ptmx_index(const std::string& pid, const std::string& fd) {
  std::ifstream f("/proc/" + pid + "/fdinfo/" + fd);
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("tty-index:", 0) == 0) return std::atoi(line.c_str() + 10);
  return -1;
}

DeviceHolder holder_of(int pid) {
  DeviceHolder h;
  h.pid = pid;
  h.name = detail::first_line(fmt::format("/proc/{}/comm", pid));
  if (h.name.empty()) h.name = "?";
  h.command = h.is_saulctl() ? process_command(std::to_string(pid)) : h.name;
  return h;
}

}  // namespace holders

std::string process_command(const std::string& pid) {
  std::ifstream f("/proc/" + pid + "/cmdline", std::ios::binary);
  std::string arg0, arg1;
  std::getline(f, arg0, '\0');
  std::getline(f, arg1, '\0');
  std::string s = arg0.substr(arg0.find_last_of('/') + 1);
  if (!arg1.empty() && arg1[0] != '-') s += " " + arg1;
  return s.empty() ? "?" : s;
}

std::string DeviceHolder::text() const { return fmt::format("{} (pid {})", command, pid); }

std::string canonical_device(const std::string& device) {
  char resolved[PATH_MAX];
  return ::realpath(device.c_str(), resolved) ? std::string(resolved) : device;
}

std::vector<DeviceHolder> device_holders(const std::string& device) {
  const std::string target = canonical_device(device);
  const int pts = holders::pts_index(target);
  const int self = static_cast<int>(::getpid());
  std::vector<DeviceHolder> out;
  DIR* proc = ::opendir("/proc");
  if (!proc) return out;
  while (const dirent* e = ::readdir(proc)) {
    if (!holders::all_digits(e->d_name)) continue;
    const int pid = std::atoi(e->d_name);
    if (pid == self) continue;
    const std::string fd_dir = std::string("/proc/") + e->d_name + "/fd";
    DIR* fds = ::opendir(fd_dir.c_str());
    if (!fds) continue;  // another user's process (or gone): not visible to us
    bool holds = false;
    bool far_end = false;
    while (const dirent* fe = ::readdir(fds)) {
      if (!holders::all_digits(fe->d_name)) continue;
      const std::string link = holders::read_link(fd_dir + "/" + fe->d_name);
      if (link == target) holds = true;
      else if (pts >= 0 && (link == "/dev/ptmx" || link == "/dev/pts/ptmx") && holders::ptmx_index(e->d_name, fe->d_name) == pts)
        far_end = true;
    }
    ::closedir(fds);
    if (holds && !far_end) out.push_back(holders::holder_of(pid));
  }
  ::closedir(proc);
  return out;
}

std::optional<DeviceHolder> uucp_lock_holder(const std::string& device) {
  const std::string target = canonical_device(device);
  const std::string base = target.substr(target.find_last_of('/') + 1);
  for (const char* dir : {"/run/lock/", "/var/lock/"}) {
    const std::string line = detail::first_line(std::string(dir) + "LCK.." + base);
    const long pid = std::strtol(line.c_str(), nullptr, 10);
    if (pid <= 0 || pid > INT_MAX || pid == ::getpid()) continue;
    if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) continue;  // a stale lock file
    return holders::holder_of(static_cast<int>(pid));
  }
  return std::nullopt;
}

std::string describe_holders(const std::vector<DeviceHolder>& list) {
  std::string s;
  for (std::size_t i = 0; i < list.size(); ++i) {
    if (i > 0) s += i + 1 == list.size() ? " and " : ", ";
    s += list[i].text();
  }
  return s;
}

}  // namespace saul::host
