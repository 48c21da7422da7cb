#include "live.hpp"

#include <fmt/core.h>
#include <poll.h>
#include <unistd.h>

#include <array>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <mutex>

#include "commands.hpp"
#include "saulproto/core/saul_can.hpp"
#include "saulproto/core/trace.hpp"
#include "saulproto/host/flash/esp_flasher.hpp"
#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/link/shared_link.hpp"

namespace saulctl {

std::atomic<bool> g_interrupted{false};

namespace {
void on_signal(int) { g_interrupted = true; }
// The shared link's notices while a view is up (they may come from the owner's serving thread).
std::mutex g_view_notice_mu;
std::string g_view_notice;
}  // namespace

void install_signal_handlers() {
  struct sigaction sa {};  // sa_flags 0, no SA_RESTART: a blocking poll returns EINTR so loops notice at once
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}

saul::host::LinkSpec resolve_link(const std::string& link) {
  std::string text = link;
  if (const char* env = std::getenv("SAUL_LINK"); text.empty() && env) text = env;
  if (const char* home = std::getenv("HOME"); text.empty() && home) {
    std::ifstream f(std::string(home) + "/.config/saulctl/link");
    std::getline(f, text);
  }
  if (text.empty())
    throw CLI::ValidationError("--link",
                               "no link given: pass --link can0 or --link slcan:/dev/ttyACM0, or set SAUL_LINK "
                               "(saulctl ports lists serial adapters)");
  try {
    return saul::host::parse_link_spec(text);
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--link", e.what());
  }
}

std::string raise_cap_hint(const std::string& port) {
  std::string steps;
  for (int pct = 30; pct <= saul::trace::kExciteMinCapPct; pct += 10) steps += fmt::format(", {}", pct);
  return fmt::format("disarm, then 'saulctl console {} speed_limit 20'{} (one 10 % step per command, only while "
                     "disarmed), and arm again",
                     port, steps);
}

bool confirm_motion(bool yes, const std::string& what) {
  if (yes) return true;
  if (!::isatty(STDIN_FILENO)) {
    say("refusing to {} without confirmation: this can make the motors move; add --yes", what);
    return false;
  }
  fmt::print(stderr, "This can make the motors move. Type 'yes' to {}: ", what);
  std::string answer;
  std::getline(std::cin, answer);
  if (answer == "yes") return true;
  say("not confirmed, nothing sent");
  return false;
}

int report_error(const std::exception& e) {
  say("{}", e.what());
  if (dynamic_cast<const CLI::ValidationError*>(&e)) return kUsage;
  const auto* le = dynamic_cast<const saul::host::LinkError*>(&e);
  const auto* fe = dynamic_cast<const saul::host::FlashError*>(&e);
  if ((le && le->kind() == saul::host::LinkError::Kind::timeout) ||
      (fe && fe->kind() == saul::host::FlashError::Kind::no_answer))
    return kTimeout;
  return kFailure;
}

tui::Style bus_style(saul::host::ControllerState s) {
  using CS = saul::host::ControllerState;
  using tui::Style;
  return s == CS::bus_off || s == CS::passive ? Style::bad : s == CS::warning ? Style::warn : Style::normal;
}

ViewCommands::ViewCommands(saul::host::CanLink& link) : link_(&link) {
  saul::host::set_share_notice([](const std::string& text) {
    std::lock_guard lock(g_view_notice_mu);
    g_view_notice = text;
  });
}

ViewCommands::~ViewCommands() {
  saul::host::set_share_notice(nullptr);
  std::lock_guard lock(g_view_notice_mu);
  if (!g_view_notice.empty()) say("{}", g_view_notice);  // the view is gone: say it once
  g_view_notice.clear();
}

void ViewCommands::send(std::uint8_t mode, const char* what) {
  const auto t0 = std::chrono::steady_clock::now();
  last_what_ = what;
  try {
    link_->send(saul::saulcan::encode(saul::saulcan::ModeCmd{static_cast<saul::saulcan::Mode>(mode)}),
                std::chrono::milliseconds(100));
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    last_result_ = fmt::format("sent ({:.2f} ms), waiting for the 0x402", ms);
    last_bad_ = false;
    waiting_since_ = t0;
  } catch (const std::exception& e) {
    last_result_ = fmt::format("NOT SENT: {}", e.what());
    last_bad_ = true;
  }
  std::lock_guard lock(g_view_notice_mu);
  g_view_notice.clear();  // the command is the news now
}

bool ViewCommands::key(int k) {
  if (k == 'e' || k == 'E' || k == ' ') {
    ++estops_;
    send(3, "ESTOP");
  } else if (k == 'o' || k == 'O') {
    send(0, "mode off");
  }
  return k == 'q' || k == 'Q';
}

void ViewCommands::frame(const saul::CanFrame& f) {
  if (!waiting_since_) return;
  const auto ack = saul::saulcan::decode_command_ack(f);
  if (!ack || ack->command != 0x02) return;
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - *waiting_since_).count();
  last_bad_ = ack->result != saul::saulcan::AckResult::applied;
  last_result_ = last_bad_ ? fmt::format("{} ({:.1f} ms)", saul::saulcan::to_string(ack->result), ms)
                           : fmt::format("acknowledged ({:.1f} ms)", ms);
  waiting_since_.reset();
}

std::string ViewCommands::status() const {
  {
    std::lock_guard lock(g_view_notice_mu);
    if (!g_view_notice.empty()) return g_view_notice;
  }
  if (last_what_.empty()) return "";
  if (waiting_since_ && std::chrono::steady_clock::now() - *waiting_since_ > std::chrono::seconds(1))
    return last_what_ + ": sent, no acknowledgement within 1 s (is BALANCE on the bus?)";
  return last_what_ + ": " + last_result_;
}

tui::Style ViewCommands::status_style() const {
  if (last_bad_ || (waiting_since_ && std::chrono::steady_clock::now() - *waiting_since_ > std::chrono::seconds(1)))
    return tui::Style::bad;
  return last_what_ == "ESTOP" ? tui::Style::warn : tui::Style::normal;
}

std::string ViewCommands::summary() const {
  if (last_what_.empty()) return "";
  return fmt::format("{} ESTOP{} sent from the keyboard; last: {}: {}", estops_, estops_ == 1 ? "" : "s", last_what_,
                     last_result_);
}

LiveView::LiveView(saul::host::CanLink& link, bool plain) : screen(plain ? nullptr : tui::Screen::open()) {
  if (screen) keys.emplace(link);
}

int LiveView::run(std::unique_ptr<saul::host::CanLink>& link, const std::string& duration, const Frame& frame,
                  const Tick& tick, const Reopen& reopen) {
  using namespace std::chrono;
  const auto start = steady_clock::now();
  const bool limited = !duration.empty();
  const milliseconds limit = limited ? parse_duration(duration) : milliseconds(0);
  auto next_reopen = start;
  int status = kOk;
  while (!g_interrupted) {
    const auto now = steady_clock::now();
    if (limited && now - start >= limit) break;
    std::array<pollfd, 2> fds{
        {{screen ? STDIN_FILENO : -1, POLLIN, 0}, {lost.empty() ? link->poll_handle() : -1, POLLIN, 0}}};
    ::poll(fds.data(), fds.size(), 50);
    if (screen) {
      bool quit = false;
      for (int k; (k = screen->key()) >= 0;) quit = quit || keys->key(k);
      if (quit) break;
    }
    if (lost.empty()) {
      try {
        while (auto f = link->receive(milliseconds(0))) {
          if (keys) keys->frame(*f);
          if (!frame(*f)) return status;
        }
      } catch (const std::exception& e) {
        if (!screen) return report_error(e);
        lost = e.what();  // keep showing what was known, say so
        status = kFailure;
      }
    } else if (reopen && now >= next_reopen) {
      next_reopen = now + seconds(1);
      try {
        link = reopen();
        keys->relink(*link);
        lost.clear();
        status = kOk;
      } catch (const std::exception&) {  // still gone: the view says so already
      }
    }
    tick(steady_clock::now());
  }
  return status;
}

}  // namespace saulctl
