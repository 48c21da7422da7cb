#include "saulsim/pty_server.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace saul::sim {

PtyServer::PtyServer(World& world) : world_(world) {
  for (End* e : {&can_, &balance_, &io_, &control_}) open_end(*e);
  paths_ = {can_.path, balance_.path, io_.path, control_.path};
}

PtyServer::~PtyServer() {
  for (End* e : {&can_, &balance_, &io_, &control_}) {
    if (e->master >= 0) ::close(e->master);
    if (e->slave >= 0) ::close(e->slave);
  }
}

void PtyServer::open_end(End& e) {
  char name[128] = {};
  if (::openpty(&e.master, &e.slave, name, nullptr, nullptr) != 0)
    throw std::runtime_error(std::string("cannot open a pseudo-terminal: ") + std::strerror(errno));
  termios t{};
  ::tcgetattr(e.slave, &t);
  ::cfmakeraw(&t);
  ::tcsetattr(e.slave, TCSANOW, &t);
  ::fcntl(e.master, F_SETFL, ::fcntl(e.master, F_GETFL) | O_NONBLOCK);
  e.path = name;
}

void PtyServer::flush_pending(End& e) {
  if (e.pending.empty()) return;
  const ssize_t n = ::write(e.master, e.pending.data(), e.pending.size());
  if (n > 0) e.pending.erase(0, static_cast<std::size_t>(n));
}

void PtyServer::write_host(End& e, const std::string& text) {
  flush_pending(e);
  if (e.pending.size() + text.size() > kMaxPending) {
    ++dropped_;  // nobody reading: the pty and the buffer behind it are full
    return;
  }
  e.pending += text;
  flush_pending(e);
}

void PtyServer::on_slcan_event(const slcan::Event& e) {
  using Kind = slcan::Event::Kind;
  if (e.kind == Kind::frame) {
    if (open_) {
      world_.send_can(e.frame);
      ++frames_from_host_;
    }
    return;
  }
  if (e.kind == Kind::version) {
    write_host(can_, "Vsaul-sim 1.0\r");
    return;
  }
  if (e.kind != Kind::rejected) return;
  const std::string cmd(e.text);
  if (cmd == "O" || cmd == "L") open_ = true;
  else if (cmd == "C") open_ = false;
  // S<n>, M<n>, A<n>, F and the rest are accepted silently, as the stock CANable firmware does.
}

void PtyServer::service() {
  std::array<char, 4096> buf{};
  // host -> virtual CANable
  for (;;) {
    const ssize_t n = ::read(can_.master, buf.data(), buf.size());
    if (n <= 0) break;
    decoder_.push(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(buf.data()), static_cast<std::size_t>(n)),
                  [&](const slcan::Event& e) { on_slcan_event(e); });
  }
  for (End* e : {&balance_, &io_, &control_}) flush_pending(*e);
  // host -> consoles
  for (auto [end, board] : {std::pair<End*, const char*>{&balance_, "balance"}, {&io_, "io"}}) {
    for (;;) {
      const ssize_t n = ::read(end->master, buf.data(), buf.size());
      if (n <= 0) break;
      world_.console_input(board, std::string(buf.data(), static_cast<std::size_t>(n)));
    }
    const std::string out = world_.take_console_output(board);
    if (!out.empty()) write_host(*end, out);
  }
  // host -> control console, one command per line
  for (;;) {
    const ssize_t n = ::read(control_.master, buf.data(), buf.size());
    if (n <= 0) break;
    control_.line.append(buf.data(), static_cast<std::size_t>(n));
  }
  for (std::size_t nl; (nl = control_.line.find_first_of("\r\n")) != std::string::npos;) {
    const std::string cmd = control_.line.substr(0, nl);
    control_.line.erase(0, nl + 1);
    if (cmd.find_first_not_of(" \t") == std::string::npos) continue;
    write_host(control_, world_.command(cmd));
  }
  // world -> host: frames on the bus, as the adapter reports them
  const auto frames = world_.take_can_output();
  if (open_) {
    std::string out;
    std::array<char, slcan::kMaxClassicLine + 1> line{};
    for (const auto& f : frames) {
      const auto n = slcan::encode_frame(f, line);
      if (n) out.append(line.data(), *n);
    }
    if (!out.empty()) {
      const ssize_t n = ::write(can_.master, out.data(), out.size());
      if (n < 0 || static_cast<std::size_t>(n) < out.size()) dropped_ += frames.size();
      else frames_to_host_ += frames.size();
    }
  }
}

void PtyServer::wait_input(int timeout_ms) {
  pollfd fds[4] = {{can_.master, POLLIN, 0}, {balance_.master, POLLIN, 0}, {io_.master, POLLIN, 0},
                   {control_.master, POLLIN, 0}};
  ::poll(fds, 4, timeout_ms);
}

}  // namespace saul::sim
