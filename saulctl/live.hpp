// What every saulctl verb that touches a live robot shares: choosing the link, asking before anything that
// can move a motor, and stopping cleanly on Ctrl-C.
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "commands.hpp"
#include "grammar.hpp"
#include "saulproto/host/link/link_spec.hpp"
#include "tui.hpp"

namespace saulctl {

/// Set by SIGINT/SIGTERM. Blocking waits return early (the handler does not restart system calls).
extern std::atomic<bool> g_interrupted;
/// g_interrupted as a function, for the library's cancel and stop hooks.
inline bool interrupted() { return g_interrupted.load(); }

/// Resolves the link text (option, environment, config file) or throws CLI::ValidationError-like usage errors.
saul::host::LinkSpec resolve_link(const std::string& link);

/// Asks "type yes" on a terminal; with --yes, or when stdin is no terminal and --yes is missing, decides without
/// asking (true / false). Prints why it refused.
bool confirm_motion(bool yes, const std::string& what);

/// How to raise BALANCE's speed cap over its console `port` to what a test signal needs (trace::kExciteMinCapPct),
/// for a one-line refusal: "disarm, then 'saulctl console PORT speed_limit 20', 30, 40 and 50 (...), and arm again".
std::string raise_cap_hint(const std::string& port);

/// The receive loop of the verbs that read a link until told to stop (sniff, record): take(wait) reads what comes
/// within `wait` (200 ms at most), until Ctrl-C, `duration` (--duration, "" for none) from `start`, or `count`
/// (--count, 0 for none) of what `taken` counts.
template <class Take>
void receive_until(const std::string& duration, std::chrono::steady_clock::time_point start, std::uint64_t count,
                   const std::uint64_t& taken, Take&& take) {
  using namespace std::chrono;
  const bool limited = !duration.empty();
  const milliseconds limit = limited ? parse_duration(duration) : milliseconds(0);
  while (!g_interrupted && (count == 0 || taken < count)) {
    auto wait = milliseconds(200);
    if (limited) {
      const auto left = duration_cast<milliseconds>(limit - (steady_clock::now() - start));
      if (left.count() <= 0) break;
      wait = std::min(wait, left);
    }
    take(wait);
  }
}

/// How a view shows the CAN controller's state: bus-off and error-passive red, error-warning yellow.
tui::Style bus_style(saul::host::ControllerState state);

/// The keys every full-screen view takes, and what became of them: e or space = ESTOP (always, at once: the frame
/// is written before the key is even shown), o = mode off, q = quit. The acknowledgements (0x402) come in through
/// frame(). Notices of the shared link are kept for the status line while it lives.
class ViewCommands {
 public:
  explicit ViewCommands(saul::host::CanLink& link);
  ~ViewCommands();
  ViewCommands(const ViewCommands&) = delete;
  ViewCommands& operator=(const ViewCommands&) = delete;

  /// A key from the view; true when it asks to quit.
  bool key(int k);
  /// Every frame the view receives (acknowledgements of what was sent).
  void frame(const saul::CanFrame& f);
  /// The link to use from now on (after the view reopened a lost one).
  void relink(saul::host::CanLink& link) { link_ = &link; }
  /// What was last sent and what became of it, or the latest notice; "" for nothing.
  [[nodiscard]] std::string status() const;
  [[nodiscard]] tui::Style status_style() const;
  [[nodiscard]] static const char* help() { return " e/space ESTOP   o mode off   q quit "; }
  /// The summary's line about them ("ESTOP sent 1 time, acknowledged"), "" when nothing was sent.
  [[nodiscard]] std::string summary() const;

 private:
  void send(std::uint8_t mode, const char* what);

  saul::host::CanLink* link_;
  int estops_ = 0;
  std::string last_what_;
  std::string last_result_;
  bool last_bad_ = false;
  std::optional<std::chrono::steady_clock::time_point> waiting_since_;
};

/// A full-screen view (monitor, sniff --top) with its keys, and the one loop it runs; without a terminal (or with
/// `plain`) the same loop with no screen, for the verb's plain form.
struct LiveView {
  LiveView(saul::host::CanLink& link, bool plain);

  std::unique_ptr<tui::Screen> screen;  ///< null: no view
  std::optional<ViewCommands> keys;     ///< the view's keys (with a screen)
  std::string lost;                     ///< why the link was lost under the view, "" while it lives

  using Frame = std::function<bool(const saul::CanFrame&)>;
  using Tick = std::function<void(std::chrono::steady_clock::time_point)>;
  using Reopen = std::function<std::unique_ptr<saul::host::CanLink>()>;
  /// Until Ctrl-C, `duration` (--duration, "" for none), q, or `frame` returning false: waits up to 50 ms for a key
  /// or a frame (ESTOP does not wait for a redraw), gives the keys to `keys`, every frame that came to `frame` and
  /// `keys`, then calls `tick(now)` to draw or print. A link error ends the loop without a screen (said; its exit
  /// code returned); a view keeps showing, with the error in `lost` (exit 1), and, given `reopen`, tries every
  /// second to open the link again.
  int run(std::unique_ptr<saul::host::CanLink>& link, const std::string& duration, const Frame& frame,
          const Tick& tick, const Reopen& reopen = {});
};

}  // namespace saulctl
