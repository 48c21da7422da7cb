#include "share_core.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>

#include "saulproto/core/saul_can.hpp"
#include "saulproto/host/link/device_holders.hpp"

namespace saul::host {

// ---- paths and rules (shared_link.hpp) ---------------------------------------------------------------------------

std::string share_directory_path() {
  if (const char* d = std::getenv("SAUL_RUNTIME_DIR"); d && *d) return d;
  if (const char* x = std::getenv("XDG_RUNTIME_DIR"); x && *x) return std::string(x) + "/saulctl";
  return fmt::format("/tmp/saulctl-{}", ::geteuid());
}

std::string share_directory() {
  const std::string dir = share_directory_path();
  if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST)
    throw LinkError(LinkError::Kind::io, fmt::format("cannot create {}: {}", dir, std::strerror(errno)));
  struct stat st {};
  if (::lstat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    throw LinkError(LinkError::Kind::permission, fmt::format("{} is not a directory: remove it", dir));
  if (st.st_uid != ::geteuid())
    throw LinkError(LinkError::Kind::permission,
                    fmt::format("{} belongs to uid {}, not to this user (uid {}): remove it", dir, st.st_uid, ::geteuid()));
  if ((st.st_mode & 077) != 0)
    throw LinkError(LinkError::Kind::permission,
                    fmt::format("{} can be entered by other users (mode {:o}): chmod 700 {}", dir, st.st_mode & 0777, dir));
  return dir;
}

std::string share_socket_path(const std::string& device) {
  std::string name = canonical_device(device);
  if (name.rfind("/dev/", 0) == 0) name = name.substr(5);
  while (!name.empty() && name.front() == '/') name.erase(0, 1);
  std::replace(name.begin(), name.end(), '/', '-');
  return share_directory_path() + "/" + name + ".sock";
}

bool share_peer_allowed(unsigned peer_uid, unsigned owner_uid) { return peer_uid == owner_uid; }

std::string ShareInfo::owner_text() const { return fmt::format("{} (pid {})", owner_command, owner_pid); }

namespace share {

using namespace std::chrono;

// ---- messages ------------------------------------------------------------------------------------------------------

Out& Out::raw(const void* p, std::size_t n) {
  const auto* b = static_cast<const std::uint8_t*>(p);
  b_.insert(b_.end(), b, b + n);
  return *this;
}
Out& Out::str(const std::string& s) { return bytes({reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}); }
Out& Out::bytes(std::span<const std::uint8_t> d) {
  u32(static_cast<std::uint32_t>(d.size()));
  return raw(d.data(), d.size());
}
Out& Out::frame(const CanFrame& f) {
  u32(f.id).u8(static_cast<std::uint8_t>((f.extended ? 1 : 0) | (f.remote ? 2 : 0) | (f.error ? 4 : 0))).u8(f.dlc);
  raw(f.data.data(), f.data.size());
  return u8(f.timestamp_ns ? 1 : 0).u64(f.timestamp_ns.value_or(0));
}
Out& Out::stats(const LinkStats& s) {
  for (std::uint64_t v : {s.rx_frames, s.tx_frames, s.rx_dropped, s.error_frames, s.bus_off_events, s.recoveries,
                          s.tx_retries, s.rejected_input, s.filtered_late})
    u64(v);
  return u8(static_cast<std::uint8_t>(s.state));
}

void In::take(void* p, std::size_t n) {
  if (m_.size() - pos_ < n) throw std::out_of_range("short sharing message");
  std::memcpy(p, m_.data() + pos_, n);
  pos_ += n;
}
std::string In::str() {
  const auto b = bytes();
  return std::string(b.begin(), b.end());
}
std::vector<std::uint8_t> In::bytes() {
  const std::uint32_t n = u32();
  if (m_.size() - pos_ < n) throw std::out_of_range("short sharing message");
  std::vector<std::uint8_t> v(m_.begin() + static_cast<std::ptrdiff_t>(pos_), m_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
  pos_ += n;
  return v;
}
CanFrame In::frame() {
  CanFrame f;
  f.id = u32();
  const std::uint8_t flags = u8();
  f.extended = (flags & 1) != 0;
  f.remote = (flags & 2) != 0;
  f.error = (flags & 4) != 0;
  f.dlc = u8();
  take(f.data.data(), f.data.size());
  const bool stamped = u8() != 0;
  const std::uint64_t t = u64();
  if (stamped) f.timestamp_ns = t;
  if (!f.valid()) throw std::out_of_range("invalid frame in a sharing message");
  return f;
}
LinkStats In::stats() {
  LinkStats s;
  for (std::uint64_t* v : {&s.rx_frames, &s.tx_frames, &s.rx_dropped, &s.error_frames, &s.bus_off_events,
                           &s.recoveries, &s.tx_retries, &s.rejected_input, &s.filtered_late})
    *v = u64();
  s.state = static_cast<ControllerState>(std::min<std::uint8_t>(u8(), static_cast<std::uint8_t>(ControllerState::bus_off)));
  return s;
}

bool is_estop(const CanFrame& f) {
  const auto m = saulcan::decode_mode_cmd(f);
  return m && m->mode == saulcan::Mode::estop;
}

std::string self_command() { return process_command("self"); }
std::string self_text() { return fmt::format("{} (pid {})", self_command(), ::getpid()); }

namespace {
std::mutex g_notice_mu;
std::function<void(const std::string&)> g_notice;
}  // namespace

void notice(const std::string& text) {
  std::lock_guard lock(g_notice_mu);
  if (g_notice) g_notice(text);
  else fmt::print(stderr, "saulctl: {}\n", text);
}

SendResult send_message(int fd, const std::vector<std::uint8_t>& m) {
  for (;;) {
    if (::send(fd, m.data(), m.size(), MSG_DONTWAIT | MSG_NOSIGNAL) >= 0) return SendResult::sent;
    if (errno == EINTR) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS) return SendResult::full;
    return SendResult::closed;
  }
}

bool receive_message(int fd, std::vector<std::uint8_t>& m, bool& closed) {
  m.resize(1 << 16);
  for (;;) {
    const ssize_t n = ::recv(fd, m.data(), m.size(), MSG_DONTWAIT);
    if (n > 0) {
      m.resize(static_cast<std::size_t>(n));
      return true;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK)) closed = true;
    m.clear();
    return false;
  }
}

bool wait_fd_event(int fd, short events, milliseconds timeout) {
  pollfd p{fd, events, 0};
  const int ms = static_cast<int>(std::clamp<long long>(timeout.count(), 0, INT_MAX));
  return ::poll(&p, 1, ms) > 0;  // a signal (EINTR) counts as a timeout: the caller's loop looks at its flag
}

EventFd::EventFd() : fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}
EventFd::~EventFd() { ::close(fd_); }

void EventFd::signal() const {
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(fd_, &one, sizeof one);
}

void EventFd::take() const {
  std::uint64_t n = 0;
  [[maybe_unused]] const auto got = ::read(fd_, &n, sizeof n);
}

bool EventFd::wait(steady_clock::time_point deadline) const {
  const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
  if (left.count() < 0 || !wait_fd_event(fd_, POLLIN, left)) return false;
  take();
  return true;
}

std::uint64_t steady_ns() {
  return static_cast<std::uint64_t>(duration_cast<nanoseconds>(steady_clock::now().time_since_epoch()).count());
}

namespace {

// Closing a socket with unread messages resets the connection, and the peer would lose the refusal or bye already
// sent: what it sent is read first (and dropped).
void discard_and_close(int fd) {
  std::vector<std::uint8_t> m;
  bool closed = false;
  for (int i = 0; i < 64 && receive_message(fd, m, closed);) ++i;
  ::close(fd);
}

bool priority(const std::vector<std::uint8_t>& m) {
  if (m.empty() || m[0] != static_cast<std::uint8_t>(Msg::frame)) return false;
  try {
    In in(m);
    in.type();
    return is_estop(in.frame());
  } catch (const std::out_of_range&) {
    return false;
  }
}

}  // namespace

// ---- the owner -----------------------------------------------------------------------------------------------------

std::string OwnerCore::Client::text() const { return fmt::format("{} (pid {})", command.empty() ? "?" : command, pid); }

OwnerCore::OwnerCore(std::string device, std::string link_text)
    : device_(canonical_device(device)), link_text_(std::move(link_text)) {}

std::string OwnerCore::sharing_text() const {
  if (!serving_) return "";
  const int clients = clients_count_;
  return clients == 0 ? std::string("shared, no other saulctl now") : fmt::format("shared with {} other saulctl", clients);
}

void OwnerCore::start_serving(int device_fd) {
  device_fd_ = device_fd;
  try {
    const std::string dir = share_directory();
    const std::string path = share_socket_path(device_);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path.size() >= sizeof addr.sun_path)
      throw LinkError(LinkError::Kind::io, fmt::format("the socket path {} is too long", path));
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    listen_fd_ = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (listen_fd_ < 0) throw LinkError(LinkError::Kind::io, fmt::format("socket: {}", std::strerror(errno)));
    // This process holds the device, so a socket file left there is a dead owner's: replace it.
    ::unlink(path.c_str());
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
        ::chmod(path.c_str(), 0600) != 0 || ::listen(listen_fd_, 16) != 0)
      throw LinkError(LinkError::Kind::io, fmt::format("cannot serve on {}: {}", path, std::strerror(errno)));
    socket_path_ = path;
    serving_ = true;
  } catch (const LinkError& e) {
    if (listen_fd_ >= 0) ::close(listen_fd_);
    listen_fd_ = -1;
    notice(fmt::format("not sharing {} with other saulctl commands: {}", device_, e.what()));
  }
  thread_ = std::thread([this] { run(); });
}

void OwnerCore::shutdown() {
  if (thread_.joinable()) {
    stopping_ = true;
    wake_serving();
    thread_.join();
  }
  close_listener();
  const auto g = gone();
  close_device();
  release_clients(g ? ByeReason::gone : ByeReason::exit,
                  g ? std::string(g->what()) : self_text() + " stopped");
}

void OwnerCore::set_gone(LinkError::Kind kind, const std::string& text) {
  {
    std::lock_guard lock(gone_mu_);
    gone_.emplace(kind, text);
  }
  inbox_.signal();
  release_clients(ByeReason::gone, text);
  device_fd_ = -1;
  close_listener();  // nothing left to share: new commands find the device missing themselves
}

std::optional<LinkError> OwnerCore::gone() const {
  std::lock_guard lock(gone_mu_);
  return gone_;
}

void OwnerCore::release_clients(ByeReason reason, const std::string& text) {
  const auto bye = Out(Msg::bye).u8(static_cast<std::uint8_t>(reason)).str(text).take();
  for (auto& c : clients_) {
    if (!c->dead) {
      for (int attempt = 0; attempt < 2; ++attempt) {  // one wait for room: a client that reads gets the reason
        const auto r = send_message(c->fd, bye);
        if (r != SendResult::full) break;
        wait_fd_event(c->fd, POLLOUT, milliseconds(50));
      }
    }
    discard_and_close(c->fd);
  }
  clients_.clear();
  clients_count_ = 0;
}

void OwnerCore::send_control(Client& c, std::vector<std::uint8_t> m) {
  if (c.dead) return;
  if (c.outbox.empty()) {
    const auto r = send_message(c.fd, m);
    if (r == SendResult::sent) return;
    if (r == SendResult::closed) {
      c.dead = true;
      return;
    }
  }
  if (c.outbox.size() >= 4096) {  // it has stopped reading altogether
    c.dead = true;
    return;
  }
  c.outbox.push_back(std::move(m));
}

void OwnerCore::send_droppable(Client& c, const std::vector<std::uint8_t>& m) {
  if (c.dead || !c.greeted) return;
  if (!c.outbox.empty()) {
    ++c.dropped;
    return;
  }
  const auto r = send_message(c.fd, m);
  if (r == SendResult::full) ++c.dropped;
  if (r == SendResult::closed) c.dead = true;
}

void OwnerCore::broadcast(const std::vector<std::uint8_t>& m, const Client* except) {
  for (auto& c : clients_)
    if (c.get() != except) send_droppable(*c, m);
}

void OwnerCore::post_broadcast(std::vector<std::uint8_t> m) {
  {
    std::lock_guard lock(posted_mu_);
    posted_.push_back(std::move(m));
  }
  wake_serving();
}

void OwnerCore::close_listener() {
  if (listen_fd_ >= 0) {
    ::close(listen_fd_);
    ::unlink(socket_path_.c_str());
    listen_fd_ = -1;
  }
  serving_ = false;
}

void OwnerCore::flush(Client& c) {
  while (!c.dead && !c.outbox.empty()) {
    const auto r = send_message(c.fd, c.outbox.front());
    if (r == SendResult::full) return;
    if (r == SendResult::closed) c.dead = true;
    else c.outbox.pop_front();
  }
}

void OwnerCore::accept_client() {
  for (;;) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;
    ucred cred{};
    socklen_t len = sizeof cred;
    const bool known = ::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0;
    if (!known || !share_peer_allowed(cred.uid, ::geteuid())) {
      // Another account on this machine: told why, and nothing it sends is read.
      const std::string why = fmt::format("{} is shared only with its owner's user (uid {}); uid {} may not use it",
                                          link_text_, ::geteuid(), known ? static_cast<long>(cred.uid) : -1L);
      send_message(fd, Out(Msg::refuse).u8(static_cast<std::uint8_t>(LinkError::Kind::permission)).str(why).take());
      discard_and_close(fd);
      notice(fmt::format("refused a connection to {} from uid {} (pid {}): another user", link_text_,
                         known ? static_cast<long>(cred.uid) : -1L, known ? static_cast<long>(cred.pid) : -1L));
      continue;
    }
    auto c = std::make_unique<Client>();
    c->fd = fd;
    c->pid = cred.pid;
    clients_.push_back(std::move(c));
  }
}

void OwnerCore::read_client(Client& c, std::vector<std::pair<Client*, std::vector<std::uint8_t>>>& batch) {
  for (int i = 0; i < 64; ++i) {  // a bounded share per round: every client gets its turn
    std::vector<std::uint8_t> m;
    bool closed = false;
    if (!receive_message(c.fd, m, closed)) {
      if (closed) c.dead = true;
      return;
    }
    batch.emplace_back(&c, std::move(m));
  }
}

void OwnerCore::handle(Client& c, const std::vector<std::uint8_t>& m) {
  try {
    In in(m);
    const Msg type = in.type();
    if (c.greeted) {
      on_message(c, type, in);
      return;
    }
    if (type != Msg::hello) {
      c.dead = true;
      return;
    }
    // The version first: another version may lay out the rest otherwise.
    std::string why;
    Hello h;
    if (const std::uint16_t version = in.u16(); version != kVersion) {
      why = fmt::format("{} is held by {}, a saulctl of another version (sharing protocol {}, this one {}): "
                        "use the same saulctl, or stop it",
                        device_, self_text(), kVersion, version);
    } else {
      h = Hello{.kind = static_cast<Kind>(in.u8()), .probe = in.u8() != 0, .command = in.str(), .rate = in.u32(),
                .format = in.str()};  // a braced list is evaluated in order: the fields as sent
      c.command = h.command;
      if (!h.probe) why = refuse_reason(h);
    }
    if (!why.empty()) {
      send_control(c, Out(Msg::refuse).u8(static_cast<std::uint8_t>(LinkError::Kind::busy)).str(why).take());
      flush(c);
      c.dead = true;
      return;
    }
    const int others = clients_count_.load();
    if (!h.probe) {  // counted before it hears back, so the owner's sharing() is right once the client is open
      c.greeted = true;
      c.next_stats = steady_clock::now();
      clients_count_ = others + 1;
    }
    send_control(c, Out(Msg::welcome)
                        .u32(static_cast<std::uint32_t>(::getpid()))
                        .str(self_command())
                        .str(link_text_)
                        .u32(static_cast<std::uint32_t>(others))
                        .take());
    if (h.probe) {
      flush(c);
      c.dead = true;
    }
  } catch (const std::out_of_range&) {
    c.dead = true;  // not a saulctl speaking our protocol
  }
}

void OwnerCore::run() {
  std::vector<pollfd> fds;
  std::vector<Client*> polled;
  bool more = false;
  while (!stopping_) {
    fds.clear();
    polled.clear();
    fds.push_back({wake_.fd(), POLLIN, 0});
    fds.push_back({listen_fd_, POLLIN, 0});
    // A held device is left out of the poll (a negative fd is ignored) and looked at again in 5 ms at the latest.
    const bool held = device_fd_ >= 0 && clients_.empty() && device_held();
    fds.push_back({held ? -1 : device_fd_, POLLIN, 0});
    for (auto& c : clients_) {
      fds.push_back({c->fd, static_cast<short>(POLLIN | (c->outbox.empty() ? 0 : POLLOUT)), 0});
      polled.push_back(c.get());
    }
    const int r = ::poll(fds.data(), fds.size(), held ? 5 : more ? 0 : 100);
    if (r < 0 && errno != EINTR) break;
    if (stopping_) break;
    if (fds[0].revents & POLLIN) {
      wake_.take();
      std::deque<std::vector<std::uint8_t>> posted;
      {
        std::lock_guard lock(posted_mu_);
        posted.swap(posted_);
      }
      for (const auto& m : posted) broadcast(m, nullptr);
    }
    // Clients first, and among their messages the ESTOPs first: nothing waiting may delay one.
    std::vector<std::pair<Client*, std::vector<std::uint8_t>>> batch;
    for (std::size_t i = 0; i < polled.size(); ++i) {
      const short rev = fds[3 + i].revents;
      if (rev & (POLLIN | POLLHUP | POLLERR)) read_client(*polled[i], batch);
      if (rev & POLLOUT) flush(*polled[i]);
    }
    std::stable_partition(batch.begin(), batch.end(), [](const auto& p) { return priority(p.second); });
    for (auto& [c, m] : batch)
      if (!c->dead) handle(*c, m);
    const bool pending = more && !held;
    more = held && more;
    if (device_fd_ >= 0 && (fds[2].revents || pending)) more = pump_device();
    if (listen_fd_ >= 0 && (fds[1].revents & POLLIN)) accept_client();
    const auto now = steady_clock::now();
    for (auto& c : clients_) {
      if (!c->greeted || c->dead || now < c->next_stats) continue;
      c->next_stats = now + milliseconds(250);
      if (c->outbox.empty()) {
        auto s = stats_for(*c);
        if (!s.empty()) send_control(*c, std::move(s));
      }
    }
    const auto dead = std::stable_partition(clients_.begin(), clients_.end(), [](const auto& c) { return !c->dead; });
    for (auto it = dead; it != clients_.end(); ++it) discard_and_close((*it)->fd);
    clients_.erase(dead, clients_.end());
    clients_count_ =
        static_cast<int>(std::count_if(clients_.begin(), clients_.end(), [](const auto& c) { return c->greeted; }));
  }
}

// ---- the client ----------------------------------------------------------------------------------------------------

std::unique_ptr<ClientSocket> ClientSocket::connect(const std::string& device, const Hello& hello) {
  const std::string path = share_socket_path(device);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) return nullptr;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  if (fd < 0) return nullptr;
  std::unique_ptr<ClientSocket> s(new ClientSocket(fd));
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return nullptr;  // nobody serves it
  ucred cred{};
  socklen_t len = sizeof cred;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0 || !share_peer_allowed(cred.uid, ::geteuid()))
    throw LinkError(LinkError::Kind::permission,
                    fmt::format("{} is served by uid {} (pid {}), not by this user (uid {}): not using it; "
                                "check the permissions of {}",
                                path, cred.uid, cred.pid, ::geteuid(), share_directory_path()));
  s->send(Out(Msg::hello)
              .u16(kVersion)
              .u8(static_cast<std::uint8_t>(hello.kind))
              .u8(hello.probe ? 1 : 0)
              .str(hello.command)
              .u32(hello.rate)
              .str(hello.format)
              .take(),
          milliseconds(1000));
  std::vector<std::uint8_t> m;
  const auto deadline = steady_clock::now() + seconds(2);
  try {
    while (steady_clock::now() < deadline) {
      if (!s->next(m, duration_cast<milliseconds>(deadline - steady_clock::now()))) continue;
      In in(m);
      const Msg type = in.type();
      if (type == Msg::refuse) {
        const auto kind = static_cast<LinkError::Kind>(in.u8());
        throw LinkError(kind == LinkError::Kind::permission ? kind : LinkError::Kind::busy, in.str());
      }
      if (type != Msg::welcome) continue;
      s->info_ = ShareInfo{.owner_pid = static_cast<int>(in.u32()), .owner_command = in.str(), .link = in.str(),
                           .clients = static_cast<int>(in.u32())};
      return s;
    }
  } catch (const OwnerLeft&) {
    return nullptr;  // it is leaving: the caller tries again
  } catch (const std::out_of_range&) {
    return nullptr;
  }
  return nullptr;
}

ClientSocket::~ClientSocket() {
  if (fd_ >= 0) ::close(fd_);
}

void ClientSocket::send(const std::vector<std::uint8_t>& m, milliseconds timeout) {
  const auto deadline = steady_clock::now() + timeout;
  for (;;) {
    const auto r = send_message(fd_, m);
    if (r == SendResult::sent) return;
    if (r == SendResult::closed) throw OwnerLeft(info_.owner_text() + " stopped");
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() <= 0)
      throw LinkError(LinkError::Kind::timeout,
                      fmt::format("{} holds the link but took nothing for {} ms", info_.owner_text(), timeout.count()));
    wait_fd_event(fd_, POLLOUT, left);
  }
}

bool ClientSocket::next(std::vector<std::uint8_t>& m, milliseconds timeout) {
  for (int round = 0; round < 2; ++round) {
    bool closed = false;
    if (receive_message(fd_, m, closed)) return true;
    if (closed) throw OwnerLeft(info_.owner_text() + " stopped");
    if (round == 0 && !wait_fd_event(fd_, POLLIN, timeout)) return false;
  }
  return false;
}

}  // namespace share

void set_share_notice(std::function<void(const std::string&)> sink) {
  std::lock_guard lock(share::g_notice_mu);
  share::g_notice = std::move(sink);
}

}  // namespace saul::host
