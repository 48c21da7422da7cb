#include "saulproto/host/link/socketcan.hpp"

#include <dirent.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/netlink.h>
#include <linux/can/raw.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <ctime>
#include <thread>

#include "../util.hpp"

namespace saul::host {

const char* to_string(ControllerState s) {
  switch (s) {
    case ControllerState::unknown: return "unknown";
    case ControllerState::active: return "error-active";
    case ControllerState::warning: return "error-warning";
    case ControllerState::passive: return "error-passive";
    case ControllerState::bus_off: return "bus-off";
  }
  return "?";
}

const char* to_string(TimestampSource s) {
  switch (s) {
    case TimestampSource::kernel: return "kernel";
    case TimestampSource::host_read: return "host-read";
  }
  return "?";
}

std::uint64_t realtime_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL + static_cast<std::uint64_t>(ts.tv_nsec);
}

ControllerState state_after_error_frame(ControllerState current, const CanFrame& f) {
  if (!f.error) return current;
  if (f.id & CAN_ERR_BUSOFF) return ControllerState::bus_off;
  if (f.id & CAN_ERR_RESTARTED) return ControllerState::active;
  if (f.id & CAN_ERR_CRTL) {
    const std::uint8_t c = f.data[1];
    if (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) return ControllerState::passive;
    if (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) return ControllerState::warning;
    if (c & CAN_ERR_CRTL_ACTIVE) return ControllerState::active;
  }
  return current;
}

namespace {

class SocketCanLink final : public CanLink {
 public:
  SocketCanLink(std::string interface, const SocketCanOptions& options) : name_(std::move(interface)) {
    fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
    if (fd_ < 0) {
      const int e = errno;
      if (e == EAFNOSUPPORT || e == EPROTONOSUPPORT)
        throw LinkError(LinkError::Kind::unsupported,
                        fmt::format("{}: this kernel has no SocketCAN (try: sudo modprobe can_raw), or use "
                                    "slcan:/dev/ttyACM0 with the slcan firmware",
                                    name_));
      throw LinkError(LinkError::Kind::io, fmt::format("{}: cannot create a CAN socket: {}", name_, std::strerror(e)));
    }
    const auto fail = [this](LinkError::Kind kind, const std::string& text) {
      ::close(fd_);
      return LinkError(kind, text);
    };
    const unsigned index = ::if_nametoindex(name_.c_str());
    if (index == 0)
      throw fail(LinkError::Kind::not_found, fmt::format("{}: no such CAN interface: plug the CANable2 (candleLight) "
                                                         "in, then sudo ip link set {} up type can bitrate 500000",
                                                         name_, name_));
    const can_err_mask_t err_mask = CAN_ERR_MASK;
    ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask);
    const int one = 1;
    ::setsockopt(fd_, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one);
    ::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
    if (options.receive_own) ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &one, sizeof one);
    // Filters before bind: a socket receives from the moment it is bound, so a filter set later lets every frame
    // queued in between through (seen on a busy bus: other ids printed by sniff --id).
    if (!options.filters.empty()) set_filters(options.filters);
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = static_cast<int>(index);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
      throw fail(LinkError::Kind::io, fmt::format("{}: cannot bind: {}", name_, std::strerror(errno)));
    ifreq ifr{};
    std::snprintf(ifr.ifr_name, IFNAMSIZ, "%s", name_.c_str());
    if (::ioctl(fd_, SIOCGIFFLAGS, &ifr) == 0 && !(ifr.ifr_flags & IFF_UP))
      throw fail(LinkError::Kind::down,
                 fmt::format("{}: interface is down: sudo ip link set {} up type can bitrate 500000", name_, name_));
  }
  ~SocketCanLink() override { ::close(fd_); }

  void send(const CanFrame& frame, std::chrono::milliseconds timeout) override {
    if (frame.error || !frame.valid())
      throw LinkError(LinkError::Kind::unsupported, fmt::format("{}: refusing to send an error or invalid frame", name_));
    can_frame cf{};
    cf.can_id = frame.id | (frame.extended ? CAN_EFF_FLAG : 0U) | (frame.remote ? CAN_RTR_FLAG : 0U);
    cf.len = frame.dlc;
    std::memcpy(cf.data, frame.data.data(), 8);
    const auto start = std::chrono::steady_clock::now();
    const auto deadline = start + timeout;
    bool retried = false;
    for (;;) {
      const ssize_t n = ::send(fd_, &cf, sizeof cf, MSG_DONTWAIT);
      if (n == static_cast<ssize_t>(sizeof cf)) {
        ++stats_.tx_frames;
        stats_.last_send_ns = static_cast<std::uint64_t>(
            std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start).count());
        return;
      }
      const int e = errno;
      if (e == ENOBUFS || e == EAGAIN) {
        // Transmit queue full: back-pressure. Wait for room until the caller's deadline.
        if (!retried) ++stats_.tx_retries;
        retried = true;
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0)
          throw LinkError(LinkError::Kind::timeout,
                          fmt::format("{}: transmit queue full for {} ms (no ACK on the bus? bus-off?)", name_,
                                      timeout.count()));
        pollfd p{fd_, POLLOUT, 0};
        if (::poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 10))) == 0)
          std::this_thread::yield();  // ENOBUFS is not signalled by POLLOUT on all kernels; re-try shortly
        continue;
      }
      if (e == EINTR) continue;
      throw failure(e, "send");
    }
  }

  std::optional<CanFrame> receive(std::chrono::milliseconds timeout) override {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      auto f = receive_one(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()));
      // As the kernel filter is set (set_filters): data frames only; remote frames do not pass a filter.
      if (!f || filters_.empty() || (!f->remote && passes(filters_, *f))) return f;
      ++stats_.filtered_late;  // the kernel's filter let it through: only possible when it was set after bind
    }
  }

  std::optional<CanFrame> receive_one(std::chrono::milliseconds timeout) {
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(std::clamp<long long>(timeout.count(), 0, INT_MAX)));
    if (r < 0) {
      if (errno == EINTR) return std::nullopt;
      throw LinkError(LinkError::Kind::io, fmt::format("{}: poll failed: {}", name_, std::strerror(errno)));
    }
    if (r == 0) return std::nullopt;
    // On POLLERR or POLLHUP, reading gives the pending socket error (ENETDOWN when the link went down).
    can_frame cf{};
    iovec iov{&cf, sizeof cf};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t))];
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
    if (n < 0) {
      const int e = errno;
      if (e == EAGAIN || e == EINTR) return std::nullopt;
      throw failure(e, "receive");
    }
    if (n != static_cast<ssize_t>(sizeof cf)) return std::nullopt;  // CAN FD frames are not enabled; ignore
    CanFrame f;
    f.error = (cf.can_id & CAN_ERR_FLAG) != 0;
    f.extended = !f.error && (cf.can_id & CAN_EFF_FLAG) != 0;
    f.remote = !f.error && (cf.can_id & CAN_RTR_FLAG) != 0;
    f.id = cf.can_id & (f.error ? CAN_ERR_MASK : f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    f.dlc = cf.len > 8 ? 8 : cf.len;
    std::memcpy(f.data.data(), cf.data, 8);
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMPNS) {
        timespec ts{};
        std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
        f.timestamp_ns = static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL + static_cast<std::uint64_t>(ts.tv_nsec);
      } else if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
        std::uint32_t drops = 0;
        std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
        stats_.rx_dropped = drops;
      }
    }
    if (!f.timestamp_ns) f.timestamp_ns = realtime_ns();
    if (f.error) {
      ++stats_.error_frames;
      const auto before = stats_.state;
      stats_.state = state_after_error_frame(stats_.state, f);
      if (stats_.state == ControllerState::bus_off && before != ControllerState::bus_off) ++stats_.bus_off_events;
    } else {
      ++stats_.rx_frames;
      if (stats_.state == ControllerState::unknown) stats_.state = ControllerState::active;
    }
    return f;
  }

  void set_filters(const std::vector<CanFilter>& filters) override {
    filters_ = filters;
    std::vector<can_filter> k;
    for (const auto& f : filters) {
      can_filter cf{};
      cf.can_id = f.id | (f.extended ? CAN_EFF_FLAG : 0U);
      cf.can_mask = f.mask | CAN_EFF_FLAG | CAN_RTR_FLAG;  // match the format exactly, and data frames only
      k.push_back(cf);
    }
    if (k.empty()) {
      can_filter all{0, 0};
      k.push_back(all);
    }
    ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, k.data(), static_cast<socklen_t>(k.size() * sizeof(can_filter)));
  }

  [[nodiscard]] LinkStats stats() const override { return stats_; }
  [[nodiscard]] const std::string& name() const override { return name_; }
  [[nodiscard]] TimestampSource timestamp_source() const override { return TimestampSource::kernel; }
  [[nodiscard]] int poll_handle() const override { return fd_; }

 private:
  // A send or receive that failed with errno `e`: the interface went down, the adapter went away, or another error.
  [[nodiscard]] LinkError failure(int e, const char* what) const {
    if (e == ENETDOWN) return {LinkError::Kind::down, fmt::format("{}: interface went down", name_)};
    if (e == ENODEV || e == ENXIO)
      return {LinkError::Kind::gone, fmt::format("{}: adapter disappeared (unplugged?)", name_)};
    return {LinkError::Kind::io, fmt::format("{}: {} failed: {}", name_, what, std::strerror(e))};
  }

  std::string name_;
  int fd_ = -1;
  LinkStats stats_;
  std::vector<CanFilter> filters_;
};

}  // namespace

std::unique_ptr<CanLink> open_socketcan(const std::string& interface, const SocketCanOptions& options) {
  return std::make_unique<SocketCanLink>(interface, options);
}

namespace netlink_info {  // named: the library is compiled in unity batches

// Walks up from the interface's device in sysfs to the USB device that holds idVendor/idProduct.
void usb_identity(CanInterfaceInfo& info) {
  char resolved[PATH_MAX];
  const std::string dev = "/sys/class/net/" + info.name + "/device";
  if (!::realpath(dev.c_str(), resolved)) return;
  const std::string driver = resolved + std::string("/driver");
  char drv[PATH_MAX];
  if (::realpath(driver.c_str(), drv)) {
    const std::string d = drv;
    info.driver = d.substr(d.find_last_of('/') + 1);
  }
  std::string dir = resolved;
  for (int up = 0; up < 4 && dir.size() > 5; ++up) {
    const std::string vid = detail::first_line(dir + "/idVendor");
    const std::string pid = detail::first_line(dir + "/idProduct");
    if (!vid.empty() && !pid.empty()) {
      info.usb_vid = static_cast<int>(std::strtol(vid.c_str(), nullptr, 16));
      info.usb_pid = static_cast<int>(std::strtol(pid.c_str(), nullptr, 16));
      return;
    }
    dir = dir.substr(0, dir.find_last_of('/'));
  }
}

// The IFLA_LINKINFO nest: kind, and for CAN devices their bit timing and state.
void parse_linkinfo(const rtattr* nest, CanInterfaceInfo& info) {
  int left = static_cast<int>(RTA_PAYLOAD(nest));
  for (const rtattr* a = static_cast<const rtattr*>(RTA_DATA(nest)); RTA_OK(a, left); a = RTA_NEXT(a, left)) {
    if (a->rta_type == IFLA_INFO_KIND) {
      info.kind = std::string(static_cast<const char*>(RTA_DATA(a)), strnlen(static_cast<const char*>(RTA_DATA(a)), RTA_PAYLOAD(a)));
    } else if (a->rta_type == IFLA_INFO_DATA) {
      int dleft = static_cast<int>(RTA_PAYLOAD(a));
      for (const rtattr* d = static_cast<const rtattr*>(RTA_DATA(a)); RTA_OK(d, dleft); d = RTA_NEXT(d, dleft)) {
        if (d->rta_type == IFLA_CAN_BITTIMING && RTA_PAYLOAD(d) >= sizeof(can_bittiming)) {
          can_bittiming bt{};
          std::memcpy(&bt, RTA_DATA(d), sizeof bt);
          if (bt.bitrate != 0) info.bitrate = bt.bitrate;
        } else if (d->rta_type == IFLA_CAN_STATE && RTA_PAYLOAD(d) >= sizeof(std::uint32_t)) {
          // Indexed by CAN_STATE_ERROR_ACTIVE .. CAN_STATE_BUS_OFF; stopped (interface down) and sleeping stay unknown.
          constexpr ControllerState kStates[] = {ControllerState::active, ControllerState::warning,
                                                 ControllerState::passive, ControllerState::bus_off};
          std::uint32_t st = 0;
          std::memcpy(&st, RTA_DATA(d), sizeof st);
          if (st <= CAN_STATE_BUS_OFF) info.state = kStates[st];
        }
      }
    }
  }
}

}  // namespace netlink_info

std::optional<CanInterfaceInfo> can_interface_info(const std::string& interface) {
  const unsigned index = ::if_nametoindex(interface.c_str());
  if (index == 0) return std::nullopt;
  CanInterfaceInfo info;
  info.name = interface;
  netlink_info::usb_identity(info);
  const int fd = ::socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd < 0) return info;
  struct {
    nlmsghdr h;
    ifinfomsg i;
  } req{};
  req.h.nlmsg_len = NLMSG_LENGTH(sizeof(ifinfomsg));
  req.h.nlmsg_type = RTM_GETLINK;
  req.h.nlmsg_flags = NLM_F_REQUEST;
  req.h.nlmsg_seq = 1;
  req.i.ifi_family = AF_UNSPEC;
  req.i.ifi_index = static_cast<int>(index);
  alignas(nlmsghdr) char buf[16384];
  if (::send(fd, &req, req.h.nlmsg_len, 0) >= 0) {
    pollfd p{fd, POLLIN, 0};
    const ssize_t n = ::poll(&p, 1, 1000) > 0 ? ::recv(fd, buf, sizeof buf, 0) : -1;
    int len = static_cast<int>(n);
    for (const nlmsghdr* h = reinterpret_cast<const nlmsghdr*>(buf); n > 0 && NLMSG_OK(h, static_cast<unsigned>(len));
         h = NLMSG_NEXT(h, len)) {
      if (h->nlmsg_type != RTM_NEWLINK) continue;
      const auto* ifi = static_cast<const ifinfomsg*>(NLMSG_DATA(h));
      info.up = (ifi->ifi_flags & IFF_UP) != 0;
      int alen = static_cast<int>(IFLA_PAYLOAD(h));
      for (const rtattr* a = IFLA_RTA(ifi); RTA_OK(a, alen); a = RTA_NEXT(a, alen))
        if (a->rta_type == IFLA_LINKINFO) netlink_info::parse_linkinfo(a, info);
    }
  }
  ::close(fd);
  return info;
}

std::vector<CanInterfaceInfo> list_can_interfaces() {
  std::vector<CanInterfaceInfo> out;
  DIR* d = ::opendir("/sys/class/net");
  if (!d) return out;
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name;
    if (name == "." || name == "..") continue;
    if (detail::first_line("/sys/class/net/" + name + "/type") != "280") continue;  // ARPHRD_CAN
    if (auto info = can_interface_info(name)) out.push_back(*info);
  }
  ::closedir(d);
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  return out;
}

}  // namespace saul::host
