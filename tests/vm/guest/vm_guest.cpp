// saul_vm_guest: what the real-kernel harness (tests/vm/run.sh) runs inside its QEMU guest besides saulctl and
// can-utils. Small tools that the guest's test script (tests/vm/guest/init.sh) combines with candump/cansend, and
// in-process checks of the SocketCAN transport. Every mode goes through the project's own transports.
//
//   saul_vm_guest can-recv IFACE COUNT TIMEOUT_MS [ID[:MASK]]...   open_socketcan, print each frame as ID#DATA
//   saul_vm_guest can-send IFACE FRAME...                         send candump-syntax frames through the transport
//   saul_vm_guest can-flood IFACE FRAME...                        send the frames in a loop, flat out, until killed
//   saul_vm_guest can-check NAME IFACE                            one in-process check of the transport
//   saul_vm_guest serial-check DEV BAUD FORMAT [BAUD_BASE]        libserialport on a real tty, bytes via echo-peer
//   saul_vm_guest fake-slcan DEV LOG [LINE:REPLY]...              a CANable on the USB gadget end (/dev/ttyGS0)
//   saul_vm_guest echo-peer SOCKET...                             on the host: far end of the guest's serial ports
//
// Exit codes: 0 ok, 1 check failed (the reason on stderr), 2 usage, 3 timeout.
#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/serial.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/link/serial_port.hpp"
#include "saulproto/host/link/socketcan.hpp"
#include "saulproto/host/report/frame_text.hpp"

namespace {

using namespace std::chrono;
using saul::CanFrame;
using saul::host::CanFilter;
using saul::host::CanLink;
using saul::host::ControllerState;
using saul::host::LinkError;

struct CheckFailed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

template <class... A>
[[noreturn]] void fail(const char* format, A... args) {
  if constexpr (sizeof...(A) == 0) {
    throw CheckFailed(format);  // no arguments: the text as it is, not a format
  } else {
    char buf[512];
    std::snprintf(buf, sizeof buf, format, args...);
    throw CheckFailed(buf);
  }
}

void expect(bool ok, const std::string& what) {
  if (!ok) throw CheckFailed(what);
}

std::uint32_t hex(const std::string& s, const std::string& whole) {
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(s, &used, 16);
  } catch (...) {
    used = 0;
  }
  if (s.empty() || used != s.size()) throw std::invalid_argument("bad hex '" + s + "' in '" + whole + "'");
  return static_cast<std::uint32_t>(v);
}

// "123#DEADBEEF", "12345678#01", "123#R", "123#R3": 3 hex digits = 11-bit, 8 = 29-bit, as cansend takes them.
CanFrame parse_frame(const std::string& text) {
  const auto hash = text.find('#');
  if (hash != 3 && hash != 8) throw std::invalid_argument("bad frame '" + text + "' (use 123#DATA or 12345678#DATA)");
  CanFrame f;
  f.id = hex(text.substr(0, hash), text);
  f.extended = hash == 8;
  const std::string data = text.substr(hash + 1);
  if (!data.empty() && (data[0] == 'R' || data[0] == 'r')) {
    f.remote = true;
    f.dlc = data.size() > 1 ? static_cast<std::uint8_t>(hex(data.substr(1), text)) : 0;
    return f;
  }
  if (data.size() % 2 != 0 || data.size() > 16) throw std::invalid_argument("bad data in '" + text + "'");
  f.dlc = static_cast<std::uint8_t>(data.size() / 2);
  for (std::size_t i = 0; i < f.dlc; ++i) f.data[i] = static_cast<std::uint8_t>(hex(data.substr(2 * i, 2), text));
  return f;
}

CanFilter parse_filter(const std::string& text) {
  const auto colon = text.find(':');
  const std::string id = text.substr(0, colon);
  CanFilter f;
  f.id = hex(id, text);
  f.extended = id.size() > 3;
  f.mask = colon == std::string::npos ? (f.extended ? 0x1FFFFFFFU : 0x7FFU) : hex(text.substr(colon + 1), text);
  return f;
}

std::string frame_text(const CanFrame& f) { return saul::host::format_candump_frame(f); }

// A frame must carry a kernel timestamp close to now (SO_TIMESTAMPNS).
void expect_kernel_stamp(const CanFrame& f, const CanLink& link) {
  expect(link.timestamp_source() == saul::host::TimestampSource::kernel, "timestamp source is not 'kernel'");
  expect(f.timestamp_ns.has_value(), "received frame has no timestamp");
  const auto now = static_cast<long long>(saul::host::realtime_ns());
  const auto diff = now - static_cast<long long>(*f.timestamp_ns);
  if (diff < 0 || diff > 5'000'000'000LL) fail("kernel timestamp %lld ns away from now", diff);
}

// ---- can-recv / can-send ------------------------------------------------------------------------------------

int can_recv(const std::vector<std::string>& a) {
  if (a.size() < 3) return 2;
  auto link = saul::host::open_socketcan(a[0]);
  const auto count = std::stoul(a[1]);
  const milliseconds timeout(std::stol(a[2]));
  std::vector<CanFilter> filters;
  for (std::size_t i = 3; i < a.size(); ++i) filters.push_back(parse_filter(a[i]));
  link->set_filters(filters);
  std::fprintf(stderr, "ready\n");
  std::fflush(stderr);
  const auto deadline = steady_clock::now() + timeout;
  for (unsigned long got = 0; got < count;) {
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() <= 0) {
      std::fprintf(stderr, "can-recv: timeout after %lu of %lu frames\n", got, count);
      return 3;
    }
    const auto f = link->receive(left);
    if (!f) continue;
    expect_kernel_stamp(*f, *link);
    ++got;
    if (f->error) {
      std::printf("%s state=%s %s\n", frame_text(*f).c_str(), saul::host::to_string(link->stats().state),
                  saul::host::describe_error_frame(*f).c_str());
    } else {
      std::printf("%s\n", frame_text(*f).c_str());
    }
    std::fflush(stdout);
  }
  return 0;
}

int can_send(const std::vector<std::string>& a) {
  if (a.empty()) return 2;
  auto link = saul::host::open_socketcan(a[0]);
  for (std::size_t i = 1; i < a.size(); ++i) link->send(parse_frame(a[i]), milliseconds(500));
  expect(link->stats().tx_frames == a.size() - 1, "tx_frames does not count the frames sent");
  return 0;
}

// Traffic already flowing: the frames in turn, as fast as the kernel takes them; "ready" on stderr after the first
// round. Raw socket writes, not the transport: ENOBUFS (queue full) just means try again.
int can_flood(const std::vector<std::string>& a) {
  if (a.size() < 2) return 2;
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  expect(fd >= 0, "cannot open a raw CAN socket");
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(::if_nametoindex(a[0].c_str()));
  expect(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0, "cannot bind the raw socket");
  std::vector<can_frame> frames;
  for (std::size_t i = 1; i < a.size(); ++i) {
    const CanFrame f = parse_frame(a[i]);
    can_frame cf{};
    cf.can_id = f.id | (f.extended ? CAN_EFF_FLAG : 0U);
    cf.len = f.dlc;
    std::memcpy(cf.data, f.data.data(), 8);
    frames.push_back(cf);
  }
  for (std::uint64_t n = 0;; ++n) {
    for (const auto& cf : frames)
      while (::write(fd, &cf, sizeof cf) != static_cast<ssize_t>(sizeof cf) && (errno == ENOBUFS || errno == EAGAIN))
        std::this_thread::yield();
    if (n == 0) {
      std::fprintf(stderr, "ready\n");
      std::fflush(stderr);
    }
  }
}

// ---- can-check: in-process checks against the real kernel ------------------------------------------------------

std::optional<CanFrame> next(CanLink& link, milliseconds timeout = milliseconds(1000)) {
  const auto deadline = steady_clock::now() + timeout;
  for (;;) {
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    if (auto f = link.receive(left)) return f;
  }
}

void check_loopback(const std::string& iface) {
  // Our own frames come back through the kernel (CAN_RAW_RECV_OWN_MSGS), exactly as sent.
  saul::host::SocketCanOptions o;
  o.receive_own = true;
  auto link = saul::host::open_socketcan(iface, o);
  const std::vector<std::string> frames = {"123#DEADBEEF", "1ABCDEF0#01", "456#R3", "1FFFFFFF#R", "7FF#", "000#0102030405060708"};
  for (const auto& t : frames) {
    const CanFrame sent = parse_frame(t);
    link->send(sent, milliseconds(500));
    const auto got = next(*link);
    if (!got) fail("%s: own frame did not come back", t.c_str());
    if (!got->same_wire(sent)) fail("sent %s, got back %s", t.c_str(), frame_text(*got).c_str());
    expect_kernel_stamp(*got, *link);
    std::printf("  %s came back, kernel timestamp\n", frame_text(*got).c_str());
  }
  const auto s = link->stats();
  if (s.tx_frames != frames.size() || s.rx_frames != frames.size())
    fail("stats tx %llu rx %llu, expected %zu each", static_cast<unsigned long long>(s.tx_frames),
         static_cast<unsigned long long>(s.rx_frames), frames.size());
  expect(s.state == ControllerState::active, "state is not error-active after good frames");
}

void check_refuse(const std::string& iface) {
  auto link = saul::host::open_socketcan(iface);
  auto refused = [&](CanFrame f, const char* what) {
    try {
      link->send(f, milliseconds(100));
    } catch (const LinkError& e) {
      expect(e.kind() == LinkError::Kind::unsupported, std::string(what) + ": wrong error kind");
      std::printf("  %s refused: %s\n", what, e.what());
      return;
    }
    fail("%s was sent", what);
  };
  CanFrame err;
  err.error = true;
  err.id = CAN_ERR_BUSOFF;
  refused(err, "an error frame");
  CanFrame big = parse_frame("7FF#01");
  big.id = 0x800;
  refused(big, "11-bit id 0x800");
  CanFrame long_dlc = parse_frame("123#01");
  long_dlc.dlc = 9;
  refused(long_dlc, "dlc 9");
  expect(link->stats().tx_frames == 0, "refused frames were counted as sent");
}

void check_filters(const std::string& iface) {
  auto rx = saul::host::open_socketcan(iface);
  auto tx = saul::host::open_socketcan(iface);
  // 0x300..0x30F standard data frames, and exactly the 29-bit id 0x12345678.
  rx->set_filters({{0x300, 0x7F0, false}, {0x12345678, 0x1FFFFFFF, true}});
  for (const char* t : {"123#01", "00000300#02", "301#R", "310#03", "12345679#04", "301#05", "12345678#06", "30F#07"})
    tx->send(parse_frame(t), milliseconds(500));
  std::vector<std::string> got;
  while (auto f = next(*rx, milliseconds(300))) got.push_back(frame_text(*f));
  const std::vector<std::string> want = {"301#05", "12345678#06", "30F#07"};
  std::string seen;
  for (const auto& g : got) seen += " " + g;
  if (got != want) fail("filtered receive got [%s ], want [ 301#05 12345678#06 30F#07 ]", seen.c_str());
  std::printf("  kernel filter passed exactly:%s\n", seen.c_str());
  // An empty filter list means everything again.
  rx->set_filters({});
  tx->send(parse_frame("123#08"), milliseconds(500));
  const auto f = next(*rx);
  if (!f || frame_text(*f) != "123#08") fail("after clearing the filters 123#08 did not arrive");
  std::printf("  filters cleared: 123#08 arrived\n");
}

// Filters before bind, with traffic already flowing (a can-flood of other ids runs): a socket receives from the
// moment it is bound, so a filter set after bind lets the frames queued in between through (saulctl sniff --id 400
// printed other ids on a busy bus). Many opens, each drained at once: with the filters given at open not one frame
// of another id may reach the socket (LinkStats::filtered_late counts those the software re-check caught). The same
// done the old way (open, then set_filters) is measured beside it, to show the race is there to be caught.
void check_filter_before_bind(const std::string& iface) {
  const std::vector<CanFilter> only_400 = {{0x400, 0x7FF, false}};
  constexpr int kOpens = 2000;
  std::uint64_t late_before = 0, late_after = 0, passed = 0;
  for (int i = 0; i < kOpens; ++i) {
    saul::host::SocketCanOptions o;
    o.filters = only_400;
    auto link = saul::host::open_socketcan(iface, o);
    while (auto f = link->receive(milliseconds(0)))
      if (!f->error) ++passed;  // nothing of the flood is 0x400: nothing may pass at all
    late_before += link->stats().filtered_late;

    auto old = saul::host::open_socketcan(iface);
    old->set_filters(only_400);
    while (old->receive(milliseconds(0))) {
    }
    late_after += old->stats().filtered_late;
  }
  std::printf("  %d opens under a flood of other ids: filters before bind let %llu frames in (%llu returned); set "
              "after bind (the old way) %llu\n",
              kOpens, static_cast<unsigned long long>(late_before), static_cast<unsigned long long>(passed),
              static_cast<unsigned long long>(late_after));
  if (late_before != 0 || passed != 0)
    fail("filters given at open let %llu frames of other ids reach the socket (%llu returned)",
         static_cast<unsigned long long>(late_before), static_cast<unsigned long long>(passed));
}

// What netlink says about a CAN interface: vcan0 is a "vcan", up, with no bit timing; a missing one is nullopt.
void check_netlink(const std::string& iface) {
  const auto info = saul::host::can_interface_info(iface);
  if (!info) fail("no interface info for %s", iface.c_str());
  if (info->kind != "vcan") fail("%s: kind '%s', want 'vcan'", iface.c_str(), info->kind.c_str());
  expect(info->up, iface + " is up but netlink says down");
  expect(!info->bitrate && !info->state, iface + ": a vcan has no bit timing or controller state");
  expect(info->usb_vid < 0, iface + ": a vcan has no USB identity");
  bool listed = false;
  for (const auto& i : saul::host::list_can_interfaces()) listed = listed || i.name == iface;
  expect(listed, iface + " is not in list_can_interfaces()");
  expect(!saul::host::can_interface_info("nosuch0"), "an interface that does not exist has info");
  std::printf("  %s: kind %s, up, no bit timing; listed\n", iface.c_str(), info->kind.c_str());
}

// Error frames: the kernel delivers frames with CAN_ERR_FLAG to sockets that asked for them (the transport asks
// for all). vcan cannot make bus errors, so a second raw socket writes them.
void check_error_frames(const std::string& iface) {
  auto link = saul::host::open_socketcan(iface);
  const int raw = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  expect(raw >= 0, "cannot open a raw CAN socket");
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(::if_nametoindex(iface.c_str()));
  expect(::bind(raw, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0, "cannot bind the raw socket");
  struct Step {
    std::uint32_t cls;
    std::uint8_t ctrl;
    ControllerState state;
    const char* text;
  };
  const Step steps[] = {
      {CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING, ControllerState::warning, "controller: tx-warning"},
      {CAN_ERR_CRTL, CAN_ERR_CRTL_RX_PASSIVE, ControllerState::passive, "controller: rx-passive"},
      {CAN_ERR_BUSOFF, 0, ControllerState::bus_off, "BUS-OFF"},
      {CAN_ERR_RESTARTED, 0, ControllerState::active, "controller restarted"},
      {CAN_ERR_ACK, 0, ControllerState::active, "no ACK"},
  };
  for (const auto& s : steps) {
    can_frame cf{};
    cf.can_id = CAN_ERR_FLAG | s.cls;
    cf.len = CAN_ERR_DLC;
    cf.data[1] = s.ctrl;
    if (::write(raw, &cf, sizeof cf) != static_cast<ssize_t>(sizeof cf))
      fail("the kernel refused to send an error frame on %s: %s", iface.c_str(), std::strerror(errno));
    const auto f = next(*link);
    if (!f) fail("error frame 0x%X did not arrive", s.cls);
    expect(f->error && f->id == s.cls, "received frame is not the error frame written");
    const auto st = link->stats().state;
    const auto d = saul::host::describe_error_frame(*f);
    if (st != s.state) fail("after %s the state is %s", d.c_str(), saul::host::to_string(st));
    if (d.find(s.text) == std::string::npos) fail("description '%s' lacks '%s'", d.c_str(), s.text);
    std::printf("  error frame %08X -> %s, state %s\n", f->id, d.c_str(), saul::host::to_string(st));
  }
  ::close(raw);
  const auto s = link->stats();
  expect(s.error_frames == 5, "error_frames is not 5");
  expect(s.bus_off_events == 1, "bus_off_events is not 1");
  expect(s.rx_frames == 0, "error frames were counted as data frames");
}

// The decoding functions alone, on frames written out here (what a real controller reports).
void check_decode(const std::string&) {
  auto ef = [](std::uint32_t cls, std::array<std::uint8_t, 8> data) {
    CanFrame f;
    f.error = true;
    f.id = cls;
    f.dlc = 8;
    f.data = data;
    return f;
  };
  using S = ControllerState;
  struct Case {
    S before;
    CanFrame f;
    S after;
    const char* text;
  };
  CanFrame data_frame = parse_frame("400#0102");
  const Case cases[] = {
      {S::active, ef(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_WARNING}), S::warning, "controller: rx-warning"},
      {S::warning, ef(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_TX_PASSIVE}), S::passive, "controller: tx-passive"},
      {S::active, ef(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_OVERFLOW}), S::active, "controller: rx-overflow"},
      {S::passive, ef(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_ACTIVE}), S::active, "back-to-error-active"},
      {S::passive, ef(CAN_ERR_BUSOFF, {}), S::bus_off, "BUS-OFF"},
      {S::bus_off, ef(CAN_ERR_RESTARTED, {}), S::active, "controller restarted"},
      {S::active, ef(CAN_ERR_ACK, {}), S::active, "no ACK"},
      {S::active, ef(CAN_ERR_LOSTARB, {5}), S::active, "lost arbitration at bit 5"},
      {S::active, ef(CAN_ERR_PROT | CAN_ERR_BUSERROR, {0, 0, CAN_ERR_PROT_BIT, CAN_ERR_PROT_LOC_ACK}), S::active,
       "protocol violation type 0x01 at 0x19, bus error"},
      {S::active, ef(CAN_ERR_TX_TIMEOUT, {}), S::active, "tx timeout"},
      {S::warning, data_frame, S::warning, ""},
  };
  for (const auto& c : cases) {
    const auto after = saul::host::state_after_error_frame(c.before, c.f);
    if (after != c.after)
      fail("%s -> %s, expected %s", saul::host::to_string(c.before), saul::host::to_string(after),
           saul::host::to_string(c.after));
    if (c.f.error) {
      const auto d = saul::host::describe_error_frame(c.f);
      if (d.find(c.text) == std::string::npos) fail("'%s' lacks '%s'", d.c_str(), c.text);
      std::printf("  %08X: %s\n", c.f.id, d.c_str());
    }
  }
}

int can_check(const std::vector<std::string>& a) {
  if (a.size() != 2) return 2;
  static const std::map<std::string, std::function<void(const std::string&)>> checks = {
      {"loopback", check_loopback}, {"refuse", check_refuse},   {"filters", check_filters},
      {"error-frames", check_error_frames}, {"decode", check_decode},
      {"filter-before-bind", check_filter_before_bind}, {"netlink", check_netlink}};
  const auto it = checks.find(a[0]);
  if (it == checks.end()) return 2;
  it->second(a[1]);
  return 0;
}

// ---- serial-check: libserialport on a real kernel tty, the host's echo-peer at the far end ---------------------

speed_t speed_of(std::uint32_t baud) {
  switch (baud) {
    case 9600: return B9600;
    case 38400: return B38400;
    case 115200: return B115200;
    case 460800: return B460800;
    case 921600: return B921600;
    default: return 0;
  }
}

std::uint32_t baud_of(speed_t s) {
  for (std::uint32_t b : {9600U, 38400U, 115200U, 460800U, 921600U})
    if (speed_of(b) == s) return b;
  return 0;
}

constexpr std::uint8_t kEchoXor = 0x5A;  // the echo peer answers every byte XOR this: not an accidental loopback

int serial_check(const std::vector<std::string>& a) {
  if (a.size() < 3) return 2;
  const std::string& dev = a[0];
  saul::host::SerialSettings s;
  s.baud = static_cast<std::uint32_t>(std::stoul(a[1]));
  if (!saul::host::parse_frame_format(a[2], s)) return 2;
  if (a.size() > 3) {
    // The 8250's clock decides the fastest rate: raise baud_base (QEMU's isa-serial.baudbase must match).
    const int fd = ::open(dev.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    expect(fd >= 0, "cannot open " + dev + " for TIOCSSERIAL");
    serial_struct ss{};
    expect(::ioctl(fd, TIOCGSERIAL, &ss) == 0, "TIOCGSERIAL failed");
    ss.baud_base = std::stoi(a[3]);
    if (::ioctl(fd, TIOCSSERIAL, &ss) != 0) fail("TIOCSSERIAL baud_base %d: %s", ss.baud_base, std::strerror(errno));
    ::close(fd);
    std::printf("  baud_base set to %d\n", ss.baud_base);
  }
  auto port = saul::host::open_serial(dev, s, saul::host::SerialBackend::libserialport);
  expect(std::string(port->backend()) == "libserialport", "backend is not libserialport");

  // What the driver really set, read back through a second descriptor (termios is per tty).
  const int fd = ::open(dev.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  expect(fd >= 0, "cannot open " + dev + " to read the settings back");
  termios t{};
  expect(::tcgetattr(fd, &t) == 0, "tcgetattr failed");
  ::close(fd);
  const std::uint32_t baud = baud_of(::cfgetospeed(&t));
  const int bits = (t.c_cflag & CSIZE) == CS8 ? 8 : (t.c_cflag & CSIZE) == CS7 ? 7 : (t.c_cflag & CSIZE) == CS6 ? 6 : 5;
  const char parity = !(t.c_cflag & PARENB) ? 'N' : (t.c_cflag & PARODD) ? 'O' : 'E';
  const int stop = (t.c_cflag & CSTOPB) ? 2 : 1;
  char got[64];
  std::snprintf(got, sizeof got, "%u %d%c%d", baud, bits, parity, stop);
  const std::string want = std::to_string(s.baud) + " " + saul::host::to_string(s);
  std::printf("  read back: %s (requested %s)%s\n", got, want.c_str(), (t.c_cflag & CRTSCTS) ? " CRTSCTS!" : "");
  if (want != got) fail("%s: requested %s, the driver has %s", dev.c_str(), want.c_str(), got);
  expect(!(t.c_cflag & CRTSCTS), "hardware flow control is on");

  // Find the echo peer: a probe byte until its answer comes (bytes sent before the host end connects are lost).
  std::array<std::uint8_t, 512> buf{};
  bool synced = false;
  for (int i = 0; i < 50 && !synced; ++i) {
    const std::uint8_t probe = 0xA5;
    port->write(std::span<const std::uint8_t>(&probe, 1), milliseconds(500));
    const auto n = port->read(buf, milliseconds(200));
    for (std::size_t k = 0; k < n; ++k) synced = synced || buf[k] == (0xA5 ^ kEchoXor);
  }
  expect(synced, "no answer from the host's echo peer within 10 s");
  while (port->read(buf, milliseconds(150)) > 0) {
  }
  std::array<std::uint8_t, 256> out{};
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<std::uint8_t>(i);
  const auto t0 = steady_clock::now();
  port->write(out, milliseconds(2000));
  std::vector<std::uint8_t> in;
  const auto deadline = steady_clock::now() + seconds(5);
  while (in.size() < out.size() && steady_clock::now() < deadline) {
    const auto n = port->read(buf, milliseconds(200));
    in.insert(in.end(), buf.begin(), buf.begin() + static_cast<long>(n));
  }
  if (in.size() != out.size()) fail("%zu of 256 bytes came back", in.size());
  for (std::size_t i = 0; i < in.size(); ++i)
    if (in[i] != (out[i] ^ kEchoXor)) fail("byte %zu came back as 0x%02X, expected 0x%02X", i, in[i], out[i] ^ kEchoXor);
  std::printf("  256 bytes out and 256 back intact in %lld ms\n",
              static_cast<long long>(duration_cast<milliseconds>(steady_clock::now() - t0).count()));
  return 0;
}

// ---- fake-slcan: the device end of the USB gadget plays a CANable with the slcan firmware -----------------------

// Arguments after DEV and LOG are LINE:REPLY pairs: when the host sends the command line LINE (without its '\r'),
// answer REPLY + '\r', once. The stock firmware answers no command itself; replies stand for bus traffic.
int fake_slcan(const std::vector<std::string>& a) {
  if (a.size() < 2) return 2;
  std::vector<std::pair<std::string, std::string>> replies;
  for (std::size_t i = 2; i < a.size(); ++i) {
    const auto colon = a[i].find(':');
    if (colon == std::string::npos) return 2;
    replies.emplace_back(a[i].substr(0, colon), a[i].substr(colon + 1));
  }
  const int fd = ::open(a[0].c_str(), O_RDWR | O_NOCTTY);
  expect(fd >= 0, "cannot open " + a[0] + ": " + std::strerror(errno));
  termios t{};
  expect(::tcgetattr(fd, &t) == 0, "tcgetattr failed on " + a[0]);
  ::cfmakeraw(&t);
  expect(::tcsetattr(fd, TCSANOW, &t) == 0, "tcsetattr failed on " + a[0]);
  ::tcflush(fd, TCIOFLUSH);
  const int log = ::open(a[1].c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  expect(log >= 0, "cannot create " + a[1]);
  std::fprintf(stderr, "ready\n");
  std::fflush(stderr);
  std::string line;
  const auto end = steady_clock::now() + seconds(60);  // never outlive the test that started it
  while (steady_clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) continue;
    char buf[512];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) continue;
    if (::write(log, buf, static_cast<std::size_t>(n)) != n) return 1;
    for (ssize_t i = 0; i < n; ++i) {
      if (buf[i] != '\r') {
        line += buf[i];
        continue;
      }
      for (auto& [when, reply] : replies) {
        if (when != line) continue;
        const std::string out = reply + "\r";
        if (::write(fd, out.data(), out.size()) != static_cast<ssize_t>(out.size())) return 1;
        when = std::string(1, '\0');  // once: no command line holds a NUL
      }
      line.clear();
    }
  }
  return 0;
}

// ---- echo-peer (host side) -------------------------------------------------------------------------------------

int echo_peer(const std::vector<std::string>& a) {
  if (a.empty()) return 2;
  std::vector<std::thread> threads;
  for (const auto& path : a) {
    threads.emplace_back([path] {
      const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
      sockaddr_un addr{};
      addr.sun_family = AF_UNIX;
      std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
      bool connected = false;
      for (int i = 0; i < 1500 && !connected; ++i) {  // QEMU creates the socket at start: up to 30 s
        connected = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
        if (!connected) std::this_thread::sleep_for(milliseconds(20));
      }
      if (!connected) {
        std::fprintf(stderr, "echo-peer: cannot connect to %s\n", path.c_str());
        return;
      }
      unsigned long long total = 0;
      std::uint8_t buf[4096];
      for (;;) {
        const ssize_t n = ::read(fd, buf, sizeof buf);
        if (n <= 0) break;
        for (ssize_t i = 0; i < n; ++i) buf[i] ^= kEchoXor;
        ssize_t off = 0;
        while (off < n) {
          const ssize_t w = ::write(fd, buf + off, static_cast<std::size_t>(n - off));
          if (w <= 0) break;
          off += w;
        }
        total += static_cast<unsigned long long>(n);
      }
      std::fprintf(stderr, "echo-peer: %s: %llu bytes echoed\n", path.c_str(), total);
      ::close(fd);
    });
  }
  for (auto& t : threads) t.join();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: saul_vm_guest can-recv|can-send|can-check|serial-check|fake-slcan|echo-peer ...\n");
    return 2;
  }
  const std::string mode = argv[1];
  const std::vector<std::string> args(argv + 2, argv + argc);
  static const std::map<std::string, std::function<int(const std::vector<std::string>&)>> modes = {
      {"can-recv", can_recv},   {"can-send", can_send},     {"can-check", can_check}, {"can-flood", can_flood},
      {"serial-check", serial_check}, {"fake-slcan", fake_slcan}, {"echo-peer", echo_peer}};
  const auto it = modes.find(mode);
  if (it == modes.end()) {
    std::fprintf(stderr, "saul_vm_guest: unknown mode '%s'\n", mode.c_str());
    return 2;
  }
  try {
    const int rc = it->second(args);
    if (rc == 2) std::fprintf(stderr, "saul_vm_guest %s: bad arguments\n", mode.c_str());
    return rc;
  } catch (const CheckFailed& e) {
    std::fprintf(stderr, "FAIL: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "saul_vm_guest %s: %s\n", mode.c_str(), e.what());
    return 1;
  }
}
