#include "saulproto/host/link/slcan_link.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <deque>

#include "saulproto/core/slcan.hpp"
#include "saulproto/host/link/link_spec.hpp"

namespace saul::host {
namespace {

using namespace std::chrono;

// The serial port's errors as the link's (same kind, same message).
template <class F>
auto as_link(F&& f) { return rethrow_as(to_link_error, std::forward<F>(f)); }

class SlcanLink final : public CanLink {
 public:
  SlcanLink(std::unique_ptr<SerialPort> port, const SlcanOptions& options)
      : port_(std::move(port)), name_("slcan:" + port_->path()) {
    const auto preset = slcan::bitrate_preset(options.bitrate);
    if (!preset)
      throw LinkError(LinkError::Kind::unsupported,
                      fmt::format("{}: no slcan preset for {} bit/s (use 10k..500k or 1M)", name_, options.bitrate));
    std::string open = fmt::format("C\rS{}\r", *preset);
    if (options.listen_only) {
      as_link([&] { port_->write(open + "V\r", milliseconds(200)); });
      fill_until([this] { return version_seen_; }, milliseconds(200));
      open = lawicel_ ? "L\r" : "M1\rO\r";  // Lawicel's listen-only, else the CANable's
    } else {
      open += "O\r";
    }
    as_link([&] { port_->write(open, milliseconds(200)); });
  }

  ~SlcanLink() override {
    try {
      port_->write(std::string("C\r"), milliseconds(100));
    } catch (...) {  // the adapter may be gone; closing must not throw
    }
  }

  void send(const CanFrame& frame, milliseconds timeout) override {
    std::array<char, slcan::kMaxClassicLine + 1> line{};
    const auto n = slcan::encode_frame(frame, line);
    if (!n)
      throw LinkError(LinkError::Kind::unsupported,
                      fmt::format("{}: cannot send this frame: {}", name_, to_string(n.reason())));
    as_link([&] { port_->write(std::span(reinterpret_cast<const std::uint8_t*>(line.data()), *n), timeout); });
    ++stats_.tx_frames;
  }

  std::optional<CanFrame> receive(milliseconds timeout) override {
    if (!fill_until([this] { return !queue_.empty(); }, timeout)) return std::nullopt;
    const CanFrame f = queue_.front();
    queue_.pop_front();
    return f;
  }

  void set_filters(const std::vector<CanFilter>& filters) override { filters_ = filters; }

  void reopen() override {
    as_link([&] { port_->write(std::string("C\rO\r"), milliseconds(200)); });
    ++stats_.recoveries;
    stats_.state = ControllerState::unknown;
  }

  [[nodiscard]] LinkStats stats() const override {
    LinkStats s = stats_;
    s.rejected_input = decoder_.counters().rejected_lines + decoder_.counters().overlong_lines;
    return s;
  }
  [[nodiscard]] const std::string& name() const override { return name_; }
  [[nodiscard]] TimestampSource timestamp_source() const override { return TimestampSource::host_read; }
  [[nodiscard]] int poll_handle() const override { return port_->poll_handle(); }

 private:
  // Reads chunks and parses them until `done` holds; false when `timeout` passed first.
  template <class Done>
  bool fill_until(Done done, milliseconds timeout) {
    const auto deadline = steady_clock::now() + timeout;
    while (!done()) {
      const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
      std::array<std::uint8_t, 4096> buf{};
      const std::size_t n = left.count() < 0 ? 0 : as_link([&] { return port_->read(buf, left); });
      if (n == 0) return false;
      const std::uint64_t stamp = realtime_ns();  // one stamp per read: the stock firmwares send none
      decoder_.push(std::span<const std::uint8_t>(buf.data(), n), [&](const slcan::Event& e) { on_event(e, stamp); });
    }
    return true;
  }

  void on_event(const slcan::Event& e, std::uint64_t stamp) {
    switch (e.kind) {
      case slcan::Event::Kind::frame: {
        CanFrame f = e.frame;
        f.timestamp_ns = stamp;
        ++stats_.rx_frames;
        if (stats_.state == ControllerState::unknown) stats_.state = ControllerState::active;
        if (passes(filters_, f)) queue_.push_back(f);
        break;
      }
      case slcan::Event::Kind::status:
        // Lawicel F flags: bit3 data overrun (frame lost), bit5 error passive, bit2 warning, bit7 bus error.
        if (e.value & 0x08) ++stats_.rx_dropped;
        if (e.value & 0x20) stats_.state = ControllerState::passive;
        else if (e.value & 0x04) stats_.state = ControllerState::warning;
        break;
      case slcan::Event::Kind::bus_state:
        if (e.text[0] == 'b') {
          if (stats_.state != ControllerState::bus_off) ++stats_.bus_off_events;
          stats_.state = ControllerState::bus_off;
        } else if (e.text[0] == 'p') {
          stats_.state = ControllerState::passive;
        } else if (e.text[0] == 'w') {
          stats_.state = ControllerState::warning;
        } else if (e.text[0] == 'a') {
          stats_.state = ControllerState::active;
        }
        break;
      case slcan::Event::Kind::bus_error: ++stats_.error_frames; break;
      case slcan::Event::Kind::version: version_seen_ = true; lawicel_ = is_lawicel_version(e.text); break;
      default: break;
    }
  }

  static bool is_lawicel_version(std::string_view text) {
    // Lawicel answers "Vhhss": exactly four hex digits. The stock CANable firmware answers a git hash and more.
    return text.size() == 4 &&
           std::all_of(text.begin(), text.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
  }

  std::unique_ptr<SerialPort> port_;
  std::string name_;
  slcan::LineDecoder decoder_;
  std::deque<CanFrame> queue_;
  std::vector<CanFilter> filters_;
  LinkStats stats_;
  bool version_seen_ = false;
  bool lawicel_ = false;
};

}  // namespace

std::unique_ptr<CanLink> open_slcan(const std::string& path, const SlcanOptions& options) {
  SerialSettings s;
  s.baud = 115200;  // USB CDC ignores it; a real UART adapter would need the right value
  return as_link([&] { return std::make_unique<SlcanLink>(open_serial(path, s), options); });
}

}  // namespace saul::host
