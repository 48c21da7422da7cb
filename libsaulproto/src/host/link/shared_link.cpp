// Shared CAN and serial links (shared_link.hpp) on the machinery of share_core.hpp.
#include "saulproto/host/link/shared_link.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <span>

#include "saulproto/host/link/device_holders.hpp"
#include "saulproto/host/link/slcan_link.hpp"
#include "share_core.hpp"

namespace saul::host {
namespace share {

using namespace std::chrono;

namespace {

constexpr std::size_t kMaxQueuedFrames = 8192;
// The owner's own reader is behind when this many frames wait for it; the device is read again once half are taken.
constexpr std::size_t kHoldFrames = 2048;
constexpr std::size_t kMaxQueuedBytes = 1 << 16;

// The queues of what was read for a process; when one is full its oldest goes (frames counted).
void push_frame(std::deque<CanFrame>& q, const CanFrame& f, std::uint64_t& dropped) {
  if (q.size() >= kMaxQueuedFrames) {
    q.pop_front();
    ++dropped;
  }
  q.push_back(f);
}
void push_bytes(std::deque<std::uint8_t>& q, std::span<const std::uint8_t> data) {
  q.insert(q.end(), data.begin(), data.end());
  if (q.size() > kMaxQueuedBytes)
    q.erase(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(q.size() - kMaxQueuedBytes));
}
std::size_t pop_bytes(std::deque<std::uint8_t>& q, std::span<std::uint8_t> buf) {
  const std::size_t n = std::min(buf.size(), q.size());
  std::copy_n(q.begin(), n, buf.begin());
  q.erase(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(n));
  return n;
}

// A client told by Msg::bye: the device's error when it went, else OwnerLeft (the handle takes over).
template <class GoneError>
[[noreturn]] void throw_bye(In& in) {
  const auto reason = static_cast<ByeReason>(in.u8());
  const std::string text = in.str();
  if (reason == ByeReason::gone) throw GoneError(GoneError::Kind::gone, text);
  throw OwnerLeft(text);
}

std::vector<std::uint8_t> frame_message(const CanFrame& f) { return Out(Msg::frame).frame(f).u32(0).u64(0).take(); }

// The answer to a client's send: Msg::sent with its token.
std::vector<std::uint8_t> sent_message(std::uint32_t token, std::uint64_t client_ns, const std::string& error,
                                       std::uint8_t kind) {
  const std::uint64_t now = steady_ns();
  return Out(Msg::sent)
      .u32(token)
      .u8(error.empty() ? 1 : 0)
      .u64(now > client_ns ? now - client_ns : 0)
      .u8(kind)
      .str(error)
      .take();
}

/// The client side of an answer to a send: waits for Msg::sent of `token`, handing everything else to `other`.
/// Returns the latency the owner measured; throws the owner's error as a LinkError, or timeout.
template <class Other>
std::uint64_t await_sent(ClientSocket& sock, std::uint32_t token, steady_clock::time_point deadline, Other&& other) {
  std::vector<std::uint8_t> m;
  for (;;) {
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() < 0)
      throw LinkError(LinkError::Kind::timeout,
                      fmt::format("{} did not confirm the write in time", sock.owner().owner_text()));
    if (!sock.next(m, left)) continue;
    In in(m);
    const Msg type = in.type();
    if (type != Msg::sent) {
      other(type, in);
      continue;
    }
    if (in.u32() != token) continue;
    const bool ok = in.u8() != 0;
    const std::uint64_t latency = in.u64();
    const auto kind = in.u8();
    const std::string text = in.str();
    if (!ok) throw LinkError(static_cast<LinkError::Kind>(kind), text);
    return latency;
  }
}

// ---- CAN ------------------------------------------------------------------------------------------------------------

class CanOwner final : public CanLink, private OwnerCore {
 public:
  CanOwner(std::unique_ptr<CanLink> real, const LinkSpec& spec, bool listen_only, std::vector<CanFilter> filters,
           bool paced)
      : OwnerCore(spec.device, spec.text(), listen_only),
        real_(std::move(real)),
        bitrate_(spec.bitrate),
        paced_(paced),
        filters_(std::move(filters)) {
    start_serving(real_->poll_handle());
  }
  ~CanOwner() override { shutdown(); }

  void send(const CanFrame& frame, milliseconds timeout) override {
    const auto t0 = steady_clock::now();
    {
      std::lock_guard lock(io_);
      if (listen_only_ && is_estop(frame)) leave_listen_only("this process");
      real_->send(frame, timeout);
    }
    last_send_ns_ = static_cast<std::uint64_t>(duration_cast<nanoseconds>(steady_clock::now() - t0).count());
    CanFrame looped = frame;
    looped.timestamp_ns = realtime_ns();
    post_broadcast(frame_message(looped));
  }

  std::optional<CanFrame> receive(milliseconds timeout) override {
    const auto deadline = steady_clock::now() + timeout;
    for (;;) {
      {
        std::lock_guard lock(inbox_mu_);
        if (!queue_.empty()) {
          CanFrame f = queue_.front();
          queue_.pop_front();
          if (holding_ && queue_.size() <= kHoldFrames / 2) {
            holding_ = false;
            wake_serving();
          }
          return f;
        }
      }
      if (auto g = gone()) throw *g;
      if (!inbox_.wait(deadline)) return std::nullopt;
    }
  }

  void set_filters(const std::vector<CanFilter>& filters) override {
    std::lock_guard lock(inbox_mu_);
    filters_ = filters;
  }
  bool recover(std::string& hint) override {
    std::lock_guard lock(io_);
    return real_->recover(hint);
  }
  [[nodiscard]] LinkStats stats() const override {
    LinkStats s = device_stats();
    std::lock_guard lock(inbox_mu_);
    s.rx_dropped += dropped_;
    s.last_send_ns = last_send_ns_;
    return s;
  }
  [[nodiscard]] const std::string& name() const override { return real_->name(); }
  [[nodiscard]] TimestampSource timestamp_source() const override { return real_->timestamp_source(); }
  [[nodiscard]] int poll_handle() const override { return inbox_.fd(); }
  [[nodiscard]] std::string sharing() const override { return sharing_text(); }

 private:
  void close_device() override { real_.reset(); }  // closes the channel and the device

  /// Queues the frames that pass the filters for this process's receive(), and wakes it once.
  void deliver(std::span<const CanFrame> frames) {
    bool queued = false;
    {
      std::lock_guard lock(inbox_mu_);
      for (const CanFrame& f : frames) {
        if (!passes(filters_, f)) continue;
        push_frame(queue_, f, dropped_);
        queued = true;
      }
    }
    if (queued) inbox_.signal();
  }

  // A burst is read whole, then handed over in one go: one wake-up of the reader per read of the device, not one
  // per frame (a wake-up costs more than decoding the frame). When paced, what the reader has not taken yet holds
  // the device.
  bool device_held() override {
    if (!paced_) return false;
    std::lock_guard lock(inbox_mu_);
    if (queue_.size() < kHoldFrames) return false;
    holding_ = true;
    return true;
  }

  void leave_listen_only(const std::string& who) {
    std::string hint;
    real_->recover(hint);  // slcan: "C\rO\r", the channel reopened in normal mode
    listen_only_ = false;
    notice(fmt::format("{}: left listen-only to put an ESTOP from {} on the bus", real_->name(), who));
  }

  bool pump_device() override {
    std::vector<CanFrame>& got = pumped_;
    got.clear();
    std::optional<LinkError> error;
    {
      std::lock_guard lock(io_);
      try {
        while (got.size() < 512) {
          auto f = real_->receive(milliseconds(0));
          if (!f) break;
          got.push_back(*f);
        }
      } catch (const LinkError& e) {
        error = e;
      }
    }
    deliver(got);
    if (has_clients())
      for (const auto& f : got) broadcast(frame_message(f), nullptr);
    if (error) set_gone(error->kind(), error->what());
    return got.size() >= 512;
  }

  void on_message(Client& from, Msg type, In& in) override {
    if (type != Msg::frame) return;
    CanFrame f = in.frame();
    const std::uint32_t token = in.u32();
    const std::uint64_t client_ns = in.u64();
    std::string error;
    auto kind = LinkError::Kind::io;
    if (listen_only_ && !is_estop(f)) {
      error = fmt::format("{} holds {} listen-only: it sends nothing but an ESTOP (stop it, or run without "
                          "--listen-only)", self_text(), real_->name());
      kind = LinkError::Kind::unsupported;
    } else {
      std::lock_guard lock(io_);
      try {
        if (listen_only_) leave_listen_only(from.text());
        real_->send(f, milliseconds(200));
      } catch (const LinkError& e) {
        error = e.what();
        kind = e.kind();
      }
    }
    send_control(from, sent_message(token, client_ns, error, static_cast<std::uint8_t>(kind)));
    if (!error.empty()) return;
    f.timestamp_ns = realtime_ns();
    deliver(std::span<const CanFrame>(&f, 1));
    broadcast(frame_message(f), &from);
  }

  std::vector<std::uint8_t> stats_for(const Client& c) override {
    return Out(Msg::stats).stats(device_stats()).u64(c.dropped).take();
  }

  [[nodiscard]] LinkStats device_stats() const {
    std::lock_guard lock(io_);
    return real_->stats();
  }

  std::string refuse_reason(const Hello& h) override {
    if (h.kind != Kind::can)
      return fmt::format("{} is held by {} as {}, a CAN link, not as a serial byte link", real_->name(), self_text(),
                         link_text());
    if (h.rate != bitrate_)
      return fmt::format("{} is held by {} at {} bit/s, not {} bit/s: use --link {}", real_->name(), self_text(),
                         bitrate_, h.rate, link_text());
    return "";
  }

  std::unique_ptr<CanLink> real_;
  std::uint32_t bitrate_;
  bool paced_;                   ///< LinkOpenOptions::paced
  mutable std::mutex inbox_mu_;  ///< guards what follows
  std::vector<CanFilter> filters_;
  std::deque<CanFrame> queue_;
  std::uint64_t dropped_ = 0;
  bool holding_ = false;          ///< device_held() said so; receive() wakes the serving thread when half is taken
  std::vector<CanFrame> pumped_;  ///< the serving thread's: one read of the device
  std::atomic<std::uint64_t> last_send_ns_{0};
};

class CanClient final : public CanLink {
 public:
  CanClient(std::unique_ptr<ClientSocket> sock, const LinkSpec& spec, std::vector<CanFilter> filters)
      : sock_(std::move(sock)), name_("slcan:" + spec.device), filters_(std::move(filters)) {}

  void send(const CanFrame& frame, milliseconds timeout) override {
    if (frame.error || !frame.valid())
      throw LinkError(LinkError::Kind::unsupported, fmt::format("{}: cannot send an error or invalid frame", name_));
    const auto t0 = steady_clock::now();
    const std::uint32_t token = ++token_;
    sock_->send(Out(Msg::frame).frame(frame).u32(token).u64(steady_ns()).take(), timeout);
    const auto other = [this](Msg type, In& in) { take(type, in); };
    last_send_ns_ = await_sent(*sock_, token, t0 + timeout + milliseconds(500), other);
  }

  std::optional<CanFrame> receive(milliseconds timeout) override {
    const auto deadline = steady_clock::now() + timeout;
    std::vector<std::uint8_t> m;
    while (queue_.empty()) {  // messages until a frame that passes the filters (or the time is up)
      const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
      if (left.count() < 0 || !sock_->next(m, left)) return std::nullopt;
      In in(m);
      take(in.type(), in);
    }
    const CanFrame f = queue_.front();
    queue_.pop_front();
    return f;
  }

  void set_filters(const std::vector<CanFilter>& filters) override { filters_ = filters; }
  bool recover(std::string& hint) override {
    hint = fmt::format("{} holds the adapter: recovery is its to do (or stop it and run this again)",
                       sock_->owner().owner_text());
    return false;
  }
  [[nodiscard]] LinkStats stats() const override {
    LinkStats s = stats_;
    s.rx_dropped += owner_dropped_ + dropped_;
    s.last_send_ns = last_send_ns_;
    return s;
  }
  [[nodiscard]] const std::string& name() const override { return name_; }
  [[nodiscard]] TimestampSource timestamp_source() const override { return TimestampSource::host_read; }
  [[nodiscard]] int poll_handle() const override { return sock_->fd(); }
  [[nodiscard]] std::string sharing() const override { return "through " + sock_->owner().owner_text(); }

 private:
  void take(Msg type, In& in) {
    switch (type) {
      case Msg::frame: {
        const CanFrame f = in.frame();
        if (passes(filters_, f)) push_frame(queue_, f, dropped_);
        return;
      }
      case Msg::stats:
        stats_ = in.stats();
        owner_dropped_ = in.u64();
        return;
      case Msg::bye: throw_bye<LinkError>(in);
      default: return;
    }
  }

  std::unique_ptr<ClientSocket> sock_;
  std::string name_;
  std::vector<CanFilter> filters_;
  std::deque<CanFrame> queue_;
  LinkStats stats_;
  std::uint64_t owner_dropped_ = 0;
  std::uint64_t dropped_ = 0;
  std::uint64_t last_send_ns_ = 0;
  std::uint32_t token_ = 0;
};

/// A handle that stays valid when the owner leaves: it joins the next owner or becomes it, says so in one line,
/// and repeats the call that met the owner's exit.
template <class T>
class Attachment {
 public:
  using Opener = std::function<std::unique_ptr<T>()>;
  Attachment(std::string device, Opener join, Opener own)
      : device_(std::move(device)), join_(std::move(join)), own_(std::move(own)), impl_(open()) {}
  template <class F>
  auto call(F&& f) {
    for (int attempt = 0;; ++attempt) {
      try {
        return f(*impl_);
      } catch (const OwnerLeft& e) {
        if (attempt >= 3) throw LinkError(LinkError::Kind::gone, std::string(e.what()) + ", and taking over failed");
        take_over(e.what());
      }
    }
  }
  T& impl() const { return *impl_; }

 private:
  // Joins an owner, or becomes one; while another saulctl holds the device but is not serving yet (starting, or
  // handing over), tries again for up to two seconds.
  std::unique_ptr<T> open() const {
    const auto deadline = steady_clock::now() + seconds(2);
    const auto retry = [&](bool busy) {
      if (!busy || steady_clock::now() > deadline) return false;
      const auto holders = device_holders(device_);
      return std::any_of(holders.begin(), holders.end(), [](const DeviceHolder& h) { return h.is_saulctl(); });
    };
    for (;;) {
      if (auto h = join_()) return h;
      try {
        return own_();
      } catch (const LinkError& e) {
        if (!retry(e.kind() == LinkError::Kind::busy)) throw;
      } catch (const SerialError& e) {
        if (!retry(e.kind() == SerialError::Kind::busy)) throw;
      }
      std::this_thread::sleep_for(milliseconds(5));  // the holder is about to serve, or just left
    }
  }

  void take_over(const std::string& why) {
    impl_.reset();
    impl_ = open();
    const std::string how = impl_->sharing();
    notice(fmt::format("{}; {}", why,
                       how.rfind("through ", 0) == 0
                           ? "now " + how
                           : fmt::format("{} now holds {} and shares it", self_text(), device_)));
  }

  std::string device_;
  Opener join_, own_;
  std::unique_ptr<T> impl_;
};

class SharedCanLink final : public CanLink {
 public:
  SharedCanLink(const LinkSpec& spec, bool listen_only, const std::vector<CanFilter>& filters, bool paced)
      : filters_(filters),
        link_(
            spec.device,
            [spec, this]() -> std::unique_ptr<CanLink> {
              const Hello h{.kind = Kind::can, .command = self_command(), .rate = spec.bitrate};
              auto sock = ClientSocket::connect(spec.device, h);
              if (!sock) return nullptr;
              return std::make_unique<CanClient>(std::move(sock), spec, filters_);
            },
            [spec, listen_only, paced, this]() -> std::unique_ptr<CanLink> {
              const SlcanOptions o{.bitrate = spec.bitrate, .listen_only = listen_only, .backend = spec.backend};
              return std::make_unique<CanOwner>(open_slcan(spec.device, o), spec, listen_only, filters_, paced);
            }) {}

  void send(const CanFrame& frame, milliseconds timeout) override {
    link_.call([&](CanLink& l) { l.send(frame, timeout); });
  }
  std::optional<CanFrame> receive(milliseconds timeout) override {
    return link_.call([&](CanLink& l) { return l.receive(timeout); });
  }
  void set_filters(const std::vector<CanFilter>& filters) override {
    filters_ = filters;
    link_.impl().set_filters(filters);
  }
  bool recover(std::string& hint) override { return link_.impl().recover(hint); }
  [[nodiscard]] LinkStats stats() const override { return link_.impl().stats(); }
  [[nodiscard]] const std::string& name() const override { return link_.impl().name(); }
  [[nodiscard]] TimestampSource timestamp_source() const override { return link_.impl().timestamp_source(); }
  [[nodiscard]] int poll_handle() const override { return link_.impl().poll_handle(); }
  [[nodiscard]] std::string sharing() const override { return link_.impl().sharing(); }

 private:
  std::vector<CanFilter> filters_;  // before link_: the openers read it
  Attachment<CanLink> link_;
};

// ---- serial ---------------------------------------------------------------------------------------------------------

std::string serial_text(const std::string& device, const SerialSettings& s) {
  return fmt::format("serial:{}@{}:{}", device, s.baud, to_string(s));
}

class SerialOwner final : public SerialPort, private OwnerCore {
 public:
  explicit SerialOwner(std::unique_ptr<SerialPort> real)
      : OwnerCore(real->path(), serial_text(real->path(), real->settings()), false), real_(std::move(real)) {
    start_serving(real_->poll_handle());
  }
  ~SerialOwner() override { shutdown(); }

  std::size_t read(std::span<std::uint8_t> buf, milliseconds timeout) override {
    const auto deadline = steady_clock::now() + timeout;
    for (;;) {
      {
        std::lock_guard lock(inbox_mu_);
        if (!bytes_.empty()) return pop_bytes(bytes_, buf);
      }
      if (auto g = gone()) throw SerialError(SerialError::Kind::gone, g->what());
      if (!inbox_.wait(deadline)) return 0;
    }
  }
  void write(std::span<const std::uint8_t> data, milliseconds timeout) override {
    std::lock_guard lock(io_);
    real_->write(data, timeout);
  }
  void set_modem_lines(bool dtr, bool rts) override {
    std::lock_guard lock(io_);
    real_->set_modem_lines(dtr, rts);
  }
  void set_baud(std::uint32_t baud) override {
    std::lock_guard lock(io_);
    real_->set_baud(baud);
  }
  [[nodiscard]] const std::string& path() const override { return real_->path(); }
  [[nodiscard]] const SerialSettings& settings() const override { return real_->settings(); }
  [[nodiscard]] const char* backend() const override { return real_->backend(); }
  [[nodiscard]] int poll_handle() const override { return inbox_.fd(); }
  [[nodiscard]] std::string sharing() const override { return sharing_text(); }

 private:
  void close_device() override { real_.reset(); }

  bool pump_device() override {
    std::array<std::uint8_t, 4096> buf{};
    std::size_t n = 0;
    std::string error;
    {
      std::lock_guard lock(io_);
      try {
        n = real_->read(buf, milliseconds(0));
      } catch (const SerialError& e) {
        error = e.what();
      }
    }
    if (n > 0) {
      {
        std::lock_guard lock(inbox_mu_);
        push_bytes(bytes_, std::span<const std::uint8_t>(buf.data(), n));
      }
      inbox_.signal();
      broadcast(Out(Msg::bytes).u32(0).bytes(std::span<const std::uint8_t>(buf.data(), n)).take(), nullptr);
    }
    if (!error.empty()) set_gone(LinkError::Kind::gone, error);
    return n == buf.size();
  }

  void on_message(Client& from, Msg type, In& in) override {
    if (type != Msg::bytes) return;
    const std::uint32_t token = in.u32();
    const auto data = in.bytes();
    const std::uint64_t client_ns = steady_ns();
    std::string error;
    auto kind = LinkError::Kind::io;
    {
      std::lock_guard lock(io_);
      try {
        real_->write(data, milliseconds(1000));
      } catch (const SerialError& e) {
        error = e.what();
        kind = to_link_error(e).kind();
      }
    }
    send_control(from, sent_message(token, client_ns, error, static_cast<std::uint8_t>(kind)));
  }

  std::string refuse_reason(const Hello& h) override {
    if (h.kind != Kind::serial)
      return fmt::format("{} is held by {} as {}, a serial byte link, not as a CAN adapter", real_->path(),
                         self_text(), link_text());
    if (h.rate != real_->settings().baud || h.format != to_string(real_->settings()))
      return fmt::format("{} is held by {} at {} {}, not {} {}", real_->path(), self_text(), real_->settings().baud,
                         to_string(real_->settings()), h.rate, h.format);
    return "";
  }

  std::unique_ptr<SerialPort> real_;
  mutable std::mutex inbox_mu_;
  std::deque<std::uint8_t> bytes_;
};

class SerialClient final : public SerialPort {
 public:
  SerialClient(std::unique_ptr<ClientSocket> sock, std::string path, const SerialSettings& settings)
      : sock_(std::move(sock)), path_(std::move(path)), settings_(settings) {}

  std::size_t read(std::span<std::uint8_t> buf, milliseconds timeout) override {
    const auto deadline = steady_clock::now() + timeout;
    std::vector<std::uint8_t> m;
    for (;;) {
      if (!bytes_.empty()) return pop_bytes(bytes_, buf);
      const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
      if (left.count() < 0 || !sock_->next(m, left)) return 0;
      In in(m);
      take(in.type(), in);
    }
  }
  void write(std::span<const std::uint8_t> data, milliseconds timeout) override {
    const std::uint32_t token = ++token_;
    const auto t0 = steady_clock::now();
    try {
      sock_->send(Out(Msg::bytes).u32(token).bytes(data).take(), timeout);
      const auto other = [this](Msg type, In& in) { take(type, in); };
      await_sent(*sock_, token, t0 + timeout + milliseconds(1000), other);
    } catch (const LinkError& e) {  // the owner's error, or a timeout
      throw to_serial_error(e);
    }
  }
  void set_modem_lines(bool, bool) override {
    throw SerialError(SerialError::Kind::config,
                      fmt::format("{}: the modem lines belong to {}, which holds the port", path_,
                                  sock_->owner().owner_text()));
  }
  [[nodiscard]] const std::string& path() const override { return path_; }
  [[nodiscard]] const SerialSettings& settings() const override { return settings_; }
  [[nodiscard]] const char* backend() const override { return "shared"; }
  [[nodiscard]] int poll_handle() const override { return sock_->fd(); }
  [[nodiscard]] std::string sharing() const override { return "through " + sock_->owner().owner_text(); }

 private:
  void take(Msg type, In& in) {
    if (type == Msg::bytes) {
      in.u32();
      push_bytes(bytes_, in.bytes());
    } else if (type == Msg::bye) {
      throw_bye<SerialError>(in);
    }
  }

  std::unique_ptr<ClientSocket> sock_;
  std::string path_;
  SerialSettings settings_;
  std::deque<std::uint8_t> bytes_;
  std::uint32_t token_ = 0;
};

class SharedSerialPort final : public SerialPort {
 public:
  SharedSerialPort(const std::string& path, const SerialSettings& settings, SerialBackend backend)
      : port_(
            path,
            [path, settings]() -> std::unique_ptr<SerialPort> {
              const Hello h{.kind = Kind::serial, .command = self_command(), .rate = settings.baud,
                            .format = to_string(settings)};
              std::unique_ptr<ClientSocket> sock;
              try {
                sock = ClientSocket::connect(path, h);
              } catch (const LinkError& e) {
                throw to_serial_error(e);
              }
              if (!sock) return nullptr;
              return std::make_unique<SerialClient>(std::move(sock), path, settings);
            },
            [path, settings, backend]() -> std::unique_ptr<SerialPort> {
              return std::make_unique<SerialOwner>(open_serial(path, settings, backend));
            }) {}

  std::size_t read(std::span<std::uint8_t> buf, milliseconds timeout) override {
    return port_.call([&](SerialPort& p) { return p.read(buf, timeout); });
  }
  void write(std::span<const std::uint8_t> data, milliseconds timeout) override {
    port_.call([&](SerialPort& p) { p.write(data, timeout); });
  }
  void set_modem_lines(bool dtr, bool rts) override { port_.impl().set_modem_lines(dtr, rts); }
  void set_baud(std::uint32_t baud) override { port_.impl().set_baud(baud); }
  [[nodiscard]] const std::string& path() const override { return port_.impl().path(); }
  [[nodiscard]] const SerialSettings& settings() const override { return port_.impl().settings(); }
  [[nodiscard]] const char* backend() const override { return port_.impl().backend(); }
  [[nodiscard]] int poll_handle() const override { return port_.impl().poll_handle(); }
  [[nodiscard]] std::string sharing() const override { return port_.impl().sharing(); }

 private:
  Attachment<SerialPort> port_;
};

}  // namespace
}  // namespace share

std::optional<ShareInfo> query_share(const std::string& device) {
  const auto sock = share::ClientSocket::connect(device, {.probe = true, .command = share::self_command()});
  if (!sock) return std::nullopt;
  return sock->owner();
}

std::unique_ptr<CanLink> open_shared_slcan(const LinkSpec& spec, bool listen_only,
                                           const std::vector<CanFilter>& filters, bool paced) {
  return std::make_unique<share::SharedCanLink>(spec, listen_only, filters, paced);
}

std::unique_ptr<SerialPort> open_shared_serial(const std::string& path, const SerialSettings& settings,
                                               SerialBackend backend) {
  return std::make_unique<share::SharedSerialPort>(path, settings, backend);
}

}  // namespace saul::host
