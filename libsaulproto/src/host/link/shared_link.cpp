// Shared CAN and serial links (shared_link.hpp) on the machinery of share_core.hpp.
#include "saulproto/host/link/shared_link.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <exception>
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

// A process's queue of bytes read for it; when full its oldest bytes go.
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

std::vector<std::uint8_t> frame_message(const CanFrame& f) { return Out(Msg::frame).frame(f).u32(0).u64(0).take(); }

/// One process's end of a shared device, CAN or serial: the owner, which holds the device and serves it (OwnerCore),
/// or a client of the saulctl that holds it (`sock_` set). A client whose owner exits takes the device over or joins
/// the next owner, says so in one line, and repeats the call that met the owner's exit (call()). The CAN and serial
/// ends derive from it; what they read waits in a queue of theirs under `inbox_mu_`.
class ShareEnd : protected OwnerCore {
 protected:
  ShareEnd(std::string device, std::string link_text, Hello hello)
      : OwnerCore(device, std::move(link_text)), device_(std::move(device)), hello_(std::move(hello)) {}

  /// Joins an owner, or becomes one (open_device(), then serving it); while another saulctl holds the device but is
  /// not serving yet (starting, or handing over), tries again for up to two seconds.
  void attach() {
    const auto deadline = steady_clock::now() + seconds(2);
    const auto retry = [&](bool busy) {
      if (!busy || steady_clock::now() > deadline) return false;
      const auto holders = device_holders(device_);
      return std::any_of(holders.begin(), holders.end(), [](const DeviceHolder& h) { return h.is_saulctl(); });
    };
    for (;;) {
      if ((sock_ = ClientSocket::connect(device_, hello_))) return;
      try {
        start_serving(open_device());
        return;
      } catch (const LinkError& e) {
        if (!retry(e.kind() == LinkError::Kind::busy)) throw;
      } catch (const SerialError& e) {
        if (!retry(e.kind() == SerialError::Kind::busy)) throw;
      }
      std::this_thread::sleep_for(milliseconds(5));  // the holder is about to serve, or just left
    }
  }

  /// Runs `f`; when it meets the owner's exit, takes over (attach()) and runs it again.
  /// A take-over that failed (the device went with its owner) leaves neither an owner's device nor a client's
  /// socket: every later call throws its error again instead of reaching a device not there.
  template <class F>
  auto call(F&& f) {
    for (int attempt = 0;; ++attempt) {
      if (lost_) std::rethrow_exception(lost_);
      try {
        return f();
      } catch (const OwnerLeft& e) {
        if (attempt >= 3) throw LinkError(LinkError::Kind::gone, std::string(e.what()) + ", and taking over failed");
        sock_.reset();
        try {
          attach();
        } catch (...) {
          lost_ = std::current_exception();
          throw;
        }
        notice(fmt::format("{}; {}", e.what(),
                           sock_ ? "now " + sharing_line()
                                 : fmt::format("{} now holds {} and shares it", self_text(), device_)));
      }
    }
  }

  /// Waits up to `timeout` for `take_one` (run under inbox_mu_) to find something read for this process; returns
  /// its first non-empty answer, or an empty one on timeout. Meanwhile the owner waits for its serving thread's
  /// wake-up (and throws the device's error once it went); a client reads its owner's messages (take()).
  template <class Take>
  auto read_input(milliseconds timeout, Take&& take_one) {
    return call([&] {
      const auto deadline = steady_clock::now() + timeout;
      for (;;) {
        {
          std::lock_guard lock(inbox_mu_);
          if (auto got = take_one()) return got;
        }
        if (!sock_) {
          if (auto g = gone()) throw *g;
          if (!inbox_.wait(deadline)) return decltype(take_one()){};
          continue;
        }
        const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
        if (left.count() < 0 || !sock_->next(msg_, left)) return decltype(take_one()){};
        In in(msg_);
        dispatch(in.type(), in);
      }
    });
  }

  /// A client's send, `m` carrying `token`: waits up to `timeout` + `slack` for the owner's Msg::sent of `token`,
  /// handing everything else to take(). Returns the latency the owner measured; throws the owner's error as a
  /// LinkError, or timeout.
  std::uint64_t send_confirmed(const std::vector<std::uint8_t>& m, std::uint32_t token, milliseconds timeout,
                               milliseconds slack) {
    const auto deadline = steady_clock::now() + timeout + slack;
    sock_->send(m, timeout);
    for (;;) {
      const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
      if (left.count() < 0)
        throw LinkError(LinkError::Kind::timeout,
                        fmt::format("{} did not confirm the write in time", sock_->owner().owner_text()));
      if (!sock_->next(msg_, left)) continue;
      In in(msg_);
      const Msg type = in.type();
      if (type != Msg::sent) {
        dispatch(type, in);
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

  /// The owner: runs `f` on the device (under io_); the error it threw, a SerialError as a LinkError, or none.
  template <class F>
  std::optional<LinkError> on_device(F&& f) {
    std::lock_guard lock(io_);
    try {
      f();
    } catch (const LinkError& e) {
      return e;
    } catch (const SerialError& e) {
      return to_link_error(e);
    }
    return std::nullopt;
  }

  /// The owner's side of a client's send: `write` on the device, answered with Msg::sent; true when it went.
  template <class Write>
  bool confirm(Client& from, std::uint32_t token, std::uint64_t client_ns, Write&& write) {
    const auto error = on_device(write);
    const std::uint64_t now = steady_ns();
    send_control(from, Out(Msg::sent)
                           .u32(token)
                           .u8(error ? 0 : 1)
                           .u64(now > client_ns ? now - client_ns : 0)
                           .u8(static_cast<std::uint8_t>(error ? error->kind() : LinkError::Kind::io))
                           .str(error ? error->what() : "")
                           .take());
    return !error;
  }

  /// sharing(): "shared with 2 other saulctl" (the owner), "through saulctl monitor (pid 77)" (a client).
  [[nodiscard]] std::string sharing_line() const {
    return sock_ ? "through " + sock_->owner().owner_text() : sharing_text();
  }
  [[nodiscard]] int input_fd() const { return sock_ ? sock_->fd() : inbox_.fd(); }

  /// Opens the device for this process (throws its busy error while another holds it); returns its poll handle.
  virtual int open_device() = 0;
  /// A client: a message from the owner (frame, bytes, stats).
  virtual void take(Msg type, In& in) = 0;

  std::unique_ptr<ClientSocket> sock_;  ///< a client's connection to the owner; null while this process owns
  std::exception_ptr lost_;             ///< the error of a take-over that failed: the link is gone
  mutable std::mutex inbox_mu_;         ///< guards the derived end's queue
  std::uint32_t token_ = 0;             ///< a client's last send

 private:
  // A client told by Msg::bye: the device's error when it went, else OwnerLeft (call() takes over).
  void dispatch(Msg type, In& in) {
    if (type != Msg::bye) return take(type, in);
    const auto reason = static_cast<ByeReason>(in.u8());
    const std::string text = in.str();
    if (reason == ByeReason::gone) throw LinkError(LinkError::Kind::gone, text);
    throw OwnerLeft(text);
  }

  std::string device_;
  Hello hello_;
  std::vector<std::uint8_t> msg_;  ///< the owner's last message
};

// ---- CAN ------------------------------------------------------------------------------------------------------------

class SharedCanLink final : public CanLink, private ShareEnd {
 public:
  SharedCanLink(const LinkSpec& spec, bool listen_only, const std::vector<CanFilter>& filters, bool paced)
      : ShareEnd(spec.device, spec.text(), {.kind = Kind::can, .command = self_command(), .rate = spec.bitrate}),
        spec_(spec),
        listen_only_(listen_only),
        paced_(paced),
        name_("slcan:" + spec.device),
        filters_(filters) {
    attach();
  }
  ~SharedCanLink() override { shutdown(); }

  void send(const CanFrame& frame, milliseconds timeout) override {
    call([&] {
      const auto t0 = steady_clock::now();
      if (sock_) {
        if (frame.error || !frame.valid())
          throw LinkError(LinkError::Kind::unsupported, fmt::format("{}: cannot send an error or invalid frame", name_));
        const std::uint32_t token = ++token_;
        last_send_ns_ = send_confirmed(Out(Msg::frame).frame(frame).u32(token).u64(steady_ns()).take(), token,
                                       timeout, milliseconds(500));
        return;
      }
      {
        std::lock_guard lock(io_);
        if (listen_only_ && is_estop(frame)) leave_listen_only("this process");
        real_->send(frame, timeout);
      }
      last_send_ns_ = static_cast<std::uint64_t>(duration_cast<nanoseconds>(steady_clock::now() - t0).count());
      CanFrame looped = frame;
      looped.timestamp_ns = realtime_ns();
      post_broadcast(frame_message(looped));
    });
  }

  std::optional<CanFrame> receive(milliseconds timeout) override {
    return read_input(timeout, [&]() -> std::optional<CanFrame> {
      if (queue_.empty()) return std::nullopt;
      CanFrame f = queue_.front();
      queue_.pop_front();
      if (holding_ && queue_.size() <= kHoldFrames / 2) {
        holding_ = false;
        wake_serving();
      }
      return f;
    });
  }

  void set_filters(const std::vector<CanFilter>& filters) override {
    std::lock_guard lock(inbox_mu_);
    filters_ = filters;
  }
  [[nodiscard]] LinkStats stats() const override {
    LinkStats s = sock_ || lost_ ? owner_stats_ : device_stats();
    std::lock_guard lock(inbox_mu_);
    s.rx_dropped += owner_dropped_ + dropped_;
    s.last_send_ns = last_send_ns_;
    return s;
  }
  [[nodiscard]] const std::string& name() const override { return name_; }
  [[nodiscard]] TimestampSource timestamp_source() const override { return TimestampSource::host_read; }  // slcan's
  [[nodiscard]] int poll_handle() const override { return input_fd(); }
  [[nodiscard]] std::string sharing() const override { return sharing_line(); }

 private:
  int open_device() override {
    real_ = open_slcan(spec_.device, {.bitrate = spec_.bitrate, .listen_only = listen_only_});
    return real_->poll_handle();
  }
  void close_device() override { real_.reset(); }  // closes the channel and the device

  void take(Msg type, In& in) override {
    if (type == Msg::frame) {
      const CanFrame f = in.frame();
      deliver(std::span<const CanFrame>(&f, 1));
    } else if (type == Msg::stats) {
      owner_stats_ = in.stats();
      owner_dropped_ = in.u64();
    }
  }

  /// Queues the frames that pass the filters for this process's receive(), and wakes the owner's reader once.
  void deliver(std::span<const CanFrame> frames) {
    bool queued = false;
    {
      std::lock_guard lock(inbox_mu_);
      for (const CanFrame& f : frames) {
        if (!passes(filters_, f)) continue;
        if (queue_.size() >= kMaxQueuedFrames) {
          queue_.pop_front();
          ++dropped_;
        }
        queue_.push_back(f);
        queued = true;
      }
    }
    if (queued && !sock_) inbox_.signal();
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
    real_->reopen();  // slcan: "C\rO\r", the channel reopened in normal mode
    listen_only_ = false;
    notice(fmt::format("{}: left listen-only to put an ESTOP from {} on the bus", real_->name(), who));
  }

  bool pump_device() override {
    std::vector<CanFrame>& got = pumped_;
    got.clear();
    const auto error = on_device([&] {
      while (got.size() < 512) {
        auto f = real_->receive(milliseconds(0));
        if (!f) break;
        got.push_back(*f);
      }
    });
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
    const bool sent = confirm(from, token, in.u64(), [&] {
      if (listen_only_ && !is_estop(f))
        throw LinkError(LinkError::Kind::unsupported,
                        fmt::format("{} holds {} listen-only: it sends nothing but an ESTOP (stop it, or run without "
                                    "--listen-only)", self_text(), real_->name()));
      if (listen_only_) leave_listen_only(from.text());
      real_->send(f, milliseconds(200));
    });
    if (!sent) return;
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
    if (h.rate != spec_.bitrate)
      return fmt::format("{} is held by {} at {} bit/s, not {} bit/s: use --link {}", real_->name(), self_text(),
                         spec_.bitrate, h.rate, link_text());
    return "";
  }

  const LinkSpec spec_;
  std::atomic<bool> listen_only_;  ///< no ESTOP sent yet (a client leaves it: a take-over opens the adapter as asked)
  const bool paced_;  ///< LinkOpenOptions::paced
  const std::string name_;
  std::unique_ptr<CanLink> real_;  ///< the owner's adapter
  std::vector<CanFilter> filters_;  // inbox_mu_ guards it and what follows
  std::deque<CanFrame> queue_;
  std::uint64_t dropped_ = 0;
  bool holding_ = false;          ///< device_held() said so; receive() wakes the serving thread when half is taken
  LinkStats owner_stats_;         ///< a client: the adapter's, as its owner last told
  std::uint64_t owner_dropped_ = 0;
  std::vector<CanFrame> pumped_;  ///< the serving thread's: one read of the device
  std::atomic<std::uint64_t> last_send_ns_{0};
};

// ---- serial ---------------------------------------------------------------------------------------------------------

// The share's errors as the port's (same kind, same message).
template <class F>
auto as_serial(F&& f) { return rethrow_as(to_serial_error, std::forward<F>(f)); }

class SharedSerialPort final : public SerialPort, private ShareEnd {
 public:
  SharedSerialPort(const std::string& path, const SerialSettings& settings)
      : ShareEnd(path, fmt::format("serial:{}@{}:{}", path, settings.baud, to_string(settings)),
                 {.kind = Kind::serial, .command = self_command(), .rate = settings.baud,
                  .format = to_string(settings)}),
        path_(path),
        settings_(settings) {
    as_serial([&] { attach(); });
  }
  ~SharedSerialPort() override { shutdown(); }

  std::size_t read(std::span<std::uint8_t> buf, milliseconds timeout) override {
    return as_serial([&] { return read_input(timeout, [&] { return pop_bytes(bytes_, buf); }); });
  }
  void write(std::span<const std::uint8_t> data, milliseconds timeout) override {
    as_serial([&] {
      call([&] {
        if (!sock_) {
          std::lock_guard lock(io_);
          return real_->write(data, timeout);
        }
        const std::uint32_t token = ++token_;
        send_confirmed(Out(Msg::bytes).u32(token).bytes(data).take(), token, timeout, milliseconds(1000));
      });
    });
  }
  void set_modem_lines(bool dtr, bool rts) override {
    if (sock_)
      throw SerialError(SerialError::Kind::config,
                        fmt::format("{}: the modem lines belong to {}, which holds the port", path_,
                                    sock_->owner().owner_text()));
    if (lost_) std::rethrow_exception(lost_);
    std::lock_guard lock(io_);
    real_->set_modem_lines(dtr, rts);
  }
  void set_baud(std::uint32_t baud) override {
    if (sock_) return SerialPort::set_baud(baud);
    if (lost_) std::rethrow_exception(lost_);
    std::lock_guard lock(io_);
    real_->set_baud(baud);
  }
  [[nodiscard]] const std::string& path() const override { return path_; }
  [[nodiscard]] const SerialSettings& settings() const override { return real_ ? real_->settings() : settings_; }
  [[nodiscard]] const char* backend() const override { return real_ ? real_->backend() : "shared"; }
  [[nodiscard]] int poll_handle() const override { return input_fd(); }
  [[nodiscard]] std::string sharing() const override { return sharing_line(); }

 private:
  int open_device() override {
    real_ = open_serial(path_, settings_);
    return real_->poll_handle();
  }
  void close_device() override { real_.reset(); }

  void take(Msg type, In& in) override {
    if (type != Msg::bytes) return;
    in.u32();
    std::lock_guard lock(inbox_mu_);
    push_bytes(bytes_, in.bytes());
  }

  bool pump_device() override {
    std::array<std::uint8_t, 4096> buf{};
    std::size_t n = 0;
    const auto error = on_device([&] { n = real_->read(buf, milliseconds(0)); });
    if (n > 0) {
      {
        std::lock_guard lock(inbox_mu_);
        push_bytes(bytes_, std::span<const std::uint8_t>(buf.data(), n));
      }
      inbox_.signal();
      broadcast(Out(Msg::bytes).u32(0).bytes(std::span<const std::uint8_t>(buf.data(), n)).take(), nullptr);
    }
    if (error) set_gone(LinkError::Kind::gone, error->what());
    return n == buf.size();
  }

  void on_message(Client& from, Msg type, In& in) override {
    if (type != Msg::bytes) return;
    const std::uint32_t token = in.u32();
    const auto data = in.bytes();
    confirm(from, token, steady_ns(), [&] { real_->write(data, milliseconds(1000)); });
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

  const std::string path_;
  const SerialSettings settings_;
  std::unique_ptr<SerialPort> real_;  ///< the owner's port
  std::deque<std::uint8_t> bytes_;    ///< inbox_mu_ guards it
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

std::unique_ptr<SerialPort> open_shared_serial(const std::string& path, const SerialSettings& settings) {
  return std::make_unique<share::SharedSerialPort>(path, settings);
}

}  // namespace saul::host
