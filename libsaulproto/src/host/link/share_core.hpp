// The machinery behind shared_link.hpp, private to src/host/link: the messages between saulctl processes, the
// owner's serving thread (OwnerCore) and the client's socket (ClientSocket). The CAN and serial shares build on it
// in shared_link.cpp.
//
// Messages are SOCK_SEQPACKET datagrams on an AF_UNIX socket (one message per send, boundaries kept), fields in
// the host's byte order (both ends are on this machine), first byte the type:
//   hello    client -> owner   version, kind, probe, command, rate, serial format
//   welcome  owner -> client   owner pid, owner command, link text, clients
//   refuse   owner -> client   why (one line); the owner closes the connection after it
//   frame    both ways         a CAN frame; from a client with a token and its send time (steady clock)
//   sent     owner -> client   token, ok, latency (client's send time -> device write), error kind and text
//   bytes    both ways         serial bytes; from a client with a token
//   stats    owner -> client   the adapter's LinkStats and the frames dropped for this client
//   bye      owner -> client   reason (exit / gone) and one line
#pragma once

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/link/shared_link.hpp"

namespace saul::host::share {

inline constexpr std::uint16_t kVersion = 2;
enum class Msg : std::uint8_t { hello = 1, welcome, refuse, frame, sent, bytes, stats, bye };
enum class Kind : std::uint8_t { can = 0, serial = 1 };
enum class ByeReason : std::uint8_t { exit = 0, gone = 1 };

/// A client's owner left without the device going away: the client takes over (ShareEnd::call()).
struct OwnerLeft : std::runtime_error {
  explicit OwnerLeft(const std::string& who) : std::runtime_error(who) {}
};

class Out {
 public:
  explicit Out(Msg m) { b_.push_back(static_cast<std::uint8_t>(m)); }
  Out& u8(std::uint8_t v) { b_.push_back(v); return *this; }
  Out& u16(std::uint16_t v) { return raw(&v, sizeof v); }
  Out& u32(std::uint32_t v) { return raw(&v, sizeof v); }
  Out& u64(std::uint64_t v) { return raw(&v, sizeof v); }
  Out& str(const std::string& s);
  Out& bytes(std::span<const std::uint8_t> d);
  Out& frame(const CanFrame& f);
  Out& stats(const LinkStats& s);
  [[nodiscard]] std::vector<std::uint8_t> take() { return std::move(b_); }

 private:
  Out& raw(const void* p, std::size_t n);
  std::vector<std::uint8_t> b_;
};

/// Reads a message; a short or malformed one throws std::out_of_range (the peer is then dropped).
class In {
 public:
  explicit In(std::span<const std::uint8_t> m) : m_(m) {}
  Msg type() { return static_cast<Msg>(u8()); }
  std::uint8_t u8() { return get<std::uint8_t>(); }
  std::uint16_t u16() { return get<std::uint16_t>(); }
  std::uint32_t u32() { return get<std::uint32_t>(); }
  std::uint64_t u64() { return get<std::uint64_t>(); }
  std::string str();
  std::vector<std::uint8_t> bytes();
  CanFrame frame();
  LinkStats stats();

 private:
  template <class T>
  T get() {
    T v{};
    take(&v, sizeof v);
    return v;
  }
  void take(void* p, std::size_t n);
  std::span<const std::uint8_t> m_;
  std::size_t pos_ = 0;
};

/// 0x302 with mode 3: what always goes first.
bool is_estop(const CanFrame& f);

/// CLOCK_MONOTONIC in ns: the same clock in every process of this machine.
std::uint64_t steady_ns();
/// "saulctl monitor" for this process (from /proc/self/cmdline), and "saulctl monitor (pid 77)".
std::string self_command();
std::string self_text();
/// The notice sink (shared_link.hpp).
void notice(const std::string& text);

/// Sends one message without blocking: sent, full (try later) or closed (the peer is gone).
enum class SendResult { sent, full, closed };
SendResult send_message(int fd, const std::vector<std::uint8_t>& m);
/// Receives one message without blocking: true with `m` filled; false when none is waiting; `closed` set on EOF.
bool receive_message(int fd, std::vector<std::uint8_t>& m, bool& closed);
/// Waits up to `timeout` for fd to poll `events`; false on timeout or a signal.
bool wait_fd_event(int fd, short events, std::chrono::milliseconds timeout);

/// An eventfd that wakes a thread: signal() from any thread; the thread waits in wait(), or polls fd() and take()s.
class EventFd {
 public:
  EventFd();
  ~EventFd();
  EventFd(const EventFd&) = delete;
  EventFd& operator=(const EventFd&) = delete;
  void signal() const;
  void take() const;
  /// Waits for a signal until `deadline` and takes it; false on timeout or a signal of the process (a poll).
  bool wait(std::chrono::steady_clock::time_point deadline) const;
  [[nodiscard]] int fd() const { return fd_; }

 private:
  int fd_;
};

/// The hello a client sends and the owner checks.
struct Hello {
  Kind kind = Kind::can;
  bool probe = false;  ///< doctor: only asks, does not join
  std::string command{};
  std::uint32_t rate = 0;  ///< CAN bitrate, or serial baud rate
  std::string format{};    ///< serial: "8N1"
};

/// The owner's side: the listening socket, the clients, and a thread that polls the device and the sockets.
/// The shared CAN and serial ends (shared_link.cpp) derive from it and implement the hooks; the hooks run on the
/// serving thread.
class OwnerCore {
 public:
  OwnerCore(const OwnerCore&) = delete;
  OwnerCore& operator=(const OwnerCore&) = delete;

 protected:
  struct Client {
    int fd = -1;
    pid_t pid = 0;
    std::string command;
    bool greeted = false;
    bool dead = false;
    std::deque<std::vector<std::uint8_t>> outbox;  ///< answers that must arrive (sent, stats, bye)
    std::uint64_t dropped = 0;                      ///< frames or bytes it was too slow to take
    std::chrono::steady_clock::time_point next_stats{};
    [[nodiscard]] std::string text() const;
  };

  OwnerCore(std::string device, std::string link_text);
  virtual ~OwnerCore() = default;

  /// Creates the socket (when the directory is not private: a notice, and nothing is shared) and starts the serving
  /// thread, which polls `device_fd`.
  void start_serving(int device_fd);
  /// What a derived destructor calls first: stops the thread and removes the socket, closes the device, then tells
  /// the clients why (the owner stopped, or the device's error), so that one of them can take the device over.
  void shutdown();
  virtual void close_device() = 0;
  /// On the serving thread, the device went away: remembered for the owner's own calls (gone()) and its reader
  /// woken; the clients are told, the socket goes and the device is no longer polled.
  void set_gone(LinkError::Kind kind, const std::string& text);
  [[nodiscard]] std::optional<LinkError> gone() const;

  /// Hooks, on the serving thread.
  /// The device polled readable (or hung up): read it; true when there may be more already read and waiting.
  virtual bool pump_device() = 0;
  /// True while the device should stay unread (the owner's own reader is behind and nobody else is attached): the
  /// frames wait in the device instead of being read only to be dropped. Asked again every 5 ms and on wake_serving().
  virtual bool device_held() { return false; }
  virtual void on_message(Client& from, Msg type, In& in) = 0;
  /// The Msg::stats for `c`, every 250 ms; none when empty.
  virtual std::vector<std::uint8_t> stats_for(const Client&) { return {}; }
  /// "" to accept a hello, else why not.
  virtual std::string refuse_reason(const Hello& h) = 0;

  /// For the hooks: answers that must arrive; frames or bytes that may be dropped for a slow client.
  void send_control(Client& c, std::vector<std::uint8_t> m);
  void send_droppable(Client& c, const std::vector<std::uint8_t>& m);
  /// Every greeted client but `except`.
  void broadcast(const std::vector<std::uint8_t>& m, const Client* except);
  /// From any thread: broadcast `m` from the serving thread (the owner's own sends, looped back to clients).
  void post_broadcast(std::vector<std::uint8_t> m);
  /// From any thread: the serving thread looks at the device again now (device_held() may have changed).
  void wake_serving() { wake_.signal(); }
  /// On the serving thread: whether any client is attached (greeted or not), without a lock.
  [[nodiscard]] bool has_clients() const { return !clients_.empty(); }

  /// What a shared owner's sharing() says: "shared with 2 other saulctl"; "" when not serving.
  [[nodiscard]] std::string sharing_text() const;
  [[nodiscard]] const std::string& link_text() const { return link_text_; }

  mutable std::mutex io_;  ///< the device: the serving thread's reads, every write
  EventFd inbox_;          ///< wakes this process's reader

 private:
  void run();
  void accept_client();
  void read_client(Client& c, std::vector<std::pair<Client*, std::vector<std::uint8_t>>>& batch);
  void handle(Client& c, const std::vector<std::uint8_t>& m);
  void flush(Client& c);
  /// Closes and removes the listening socket: no new clients.
  void close_listener();
  /// Tells every client why the owner leaves (after the device is closed, so one can take it over) and closes them.
  void release_clients(ByeReason reason, const std::string& text);

  std::string device_;
  std::string link_text_;
  std::string socket_path_;
  int listen_fd_ = -1;
  EventFd wake_;
  int device_fd_ = -1;
  std::vector<std::unique_ptr<Client>> clients_;
  std::atomic<int> clients_count_{0};
  mutable std::mutex gone_mu_;
  std::optional<LinkError> gone_;
  std::mutex posted_mu_;
  std::deque<std::vector<std::uint8_t>> posted_;
  std::atomic<bool> stopping_{false};
  std::atomic<bool> serving_{false};
  std::thread thread_;
};

/// The client's side: a connected, greeted socket.
class ClientSocket {
 public:
  /// Connects to the owner of `device` and says hello. nullptr when nobody serves it (no socket, or a stale one).
  /// Throws LinkError(permission) when another user serves it or the owner refuses this user, LinkError(busy) when
  /// the owner refuses the hello (another kind or rate, another version).
  static std::unique_ptr<ClientSocket> connect(const std::string& device, const Hello& hello);
  ~ClientSocket();
  ClientSocket(const ClientSocket&) = delete;
  ClientSocket& operator=(const ClientSocket&) = delete;

  [[nodiscard]] int fd() const { return fd_; }
  /// Sends, waiting up to `timeout` for room; throws OwnerLeft when the owner has gone.
  void send(const std::vector<std::uint8_t>& m, std::chrono::milliseconds timeout);
  /// Waits up to `timeout` for one message; false on timeout or a signal. Throws OwnerLeft on EOF.
  bool next(std::vector<std::uint8_t>& m, std::chrono::milliseconds timeout);

  const ShareInfo& owner() const { return info_; }

 private:
  explicit ClientSocket(int fd) : fd_(fd) {}
  int fd_ = -1;
  ShareInfo info_;
};

}  // namespace saul::host::share
