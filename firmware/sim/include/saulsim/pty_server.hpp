// The simulated robot shown to the world as hardware: a CANable2 with the slcan firmware on a pseudo-terminal,
// each board's USB console on its own pseudo-terminal, and the simulator's control console on a fourth.
// Anything that speaks slcan (saulctl --link slcan:PTY, python-can's slcan interface, slcand) connects unchanged.
//
// The virtual CANable behaves like the stock firmware: C/O/L/M1/S<n> are obeyed silently (no CR/BEL replies),
// frames are forwarded only while the channel is open, V answers a version line, and when the host stops
// reading, frames that do not fit the pty are dropped and counted, like an adapter's overflow.
#pragma once

#include <cstdint>
#include <string>

#include "saulproto/core/slcan.hpp"
#include "saulsim/world.hpp"

namespace saul::sim {

struct PtyPaths {
  std::string can, balance, io, control;
};

class PtyServer {
 public:
  /// Opens the four pseudo-terminals. Throws std::runtime_error when the system has no ptys.
  explicit PtyServer(World& world);
  ~PtyServer();
  PtyServer(const PtyServer&) = delete;
  PtyServer& operator=(const PtyServer&) = delete;

  [[nodiscard]] const PtyPaths& paths() const { return paths_; }

  /// Moves bytes both ways once (non-blocking): host -> world and world -> host.
  void service();
  /// Waits up to timeout_ms for input on any pty.
  void wait_input(int timeout_ms);

  [[nodiscard]] std::uint64_t frames_to_host() const { return frames_to_host_; }
  [[nodiscard]] std::uint64_t frames_from_host() const { return frames_from_host_; }
  [[nodiscard]] std::uint64_t dropped() const { return dropped_; }
  [[nodiscard]] bool channel_open() const { return open_; }

 private:
  struct End {
    int master = -1;
    int slave = -1;  // kept open so the pty survives clients coming and going
    std::string path;
    std::string line;  // partial input line (control console)
    /// Console output the pty did not take yet (a reader that fell behind), written first on the next service():
    /// the USB console's buffers on the real board, so a slow reader gets every record late, not a cut one.
    std::string pending;
  };
  /// More than this waiting for a reader (nobody reading the console) and further output is dropped, counted.
  static constexpr std::size_t kMaxPending = 1 << 20;
  void flush_pending(End& e);
  void open_end(End& e);
  void on_slcan_event(const slcan::Event& e);
  void write_host(End& e, const std::string& text);

  World& world_;
  End can_, balance_, io_, control_;
  PtyPaths paths_;
  slcan::LineDecoder decoder_;
  bool open_ = false;
  std::uint64_t frames_to_host_ = 0;
  std::uint64_t frames_from_host_ = 0;
  std::uint64_t dropped_ = 0;
};

}  // namespace saul::sim
