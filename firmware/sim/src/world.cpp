#include "saulsim/world.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "saulproto/core/crsf.hpp"

namespace saul::sim {

WorldConfig::WorldConfig() {
  // Gains that balance this plant (a velocity-controlled wheel base needs the integral term as its restoring
  // force; found by simulating the plant, 20 seeds, tests/firmware/test_plant.cpp). The firmware's power-on gains
  // are for the real robot's tuning session. The plant keeps its QMI8658 noise, offsets and disturbances.
  balance.gains = saulcan::PidGains{100.0F, 500.0F, 3.0F};
  balance.filter_tau_s = 1.0F;
}

namespace {

// A queue-backed byte port: reads from `in`, writes to `out` (or nowhere when out is null or the wire is cut).
class QueuePort final : public fw::SerialPort {
 public:
  QueuePort(Bytes& in, Bytes* out, const bool* cut = nullptr, std::size_t room = static_cast<std::size_t>(-1))
      : in_(in), out_(out), cut_(cut), room_(room) {}
  std::size_t read(std::span<std::uint8_t> buf) override {
    std::size_t n = 0;
    while (n < buf.size() && !in_.empty()) {
      buf[n++] = in_.front();
      in_.pop_front();
    }
    return n;
  }
  std::size_t write(std::span<const std::uint8_t> data) override {
    if (out_ && !(cut_ && *cut_)) out_->insert(out_->end(), data.begin(), data.end());
    return data.size();
  }
  /// A USB transmit buffer that someone empties (take_console_output): the loop trace drops records when it is full.
  std::size_t write_room() override {
    const std::size_t used = out_ != nullptr ? out_->size() : 0;
    return used < room_ ? room_ - used : 0;
  }

 private:
  Bytes& in_;
  Bytes* out_;
  const bool* cut_;
  std::size_t room_;
};

/// BALANCE's console transmit buffer: 64 KiB, 1.6 s of the loop trace at 1 kHz for a reader that falls behind.
constexpr std::size_t kBalanceConsoleRoom = 64 * 1024;

}  // namespace

struct World::Hardware {
  // byte wires
  Bytes io_to_balance, balance_to_io;
  Bytes balance_console_in, balance_console_out, io_console_in, io_console_out;
  Bytes crsf_in, elrs_in;
  Bytes telemetry_out;  // IO -> transmitter, kept short
  // CAN
  std::deque<CanFrame> balance_rx;
  console::CanStats can_stats;
  // IO pins
  bool arm_button = false;
  bool kill_switch = false;
  std::array<std::uint16_t, fw::kPwmChannelCount> pwm{};
  std::array<bool, fw::kOutputPinCount> outputs{};
  std::uint16_t horn_hz = 0;
  std::vector<fw::Rgb> leds;
  fw::LcdView lcd{};
  fw::TimeUs now = 0;
  fw::TimeUs balance_fed_us = 0;
  std::deque<fw::ImuSample> imu;
  World* world = nullptr;
  bool* link_cut = nullptr;

  struct Imu final : fw::Imu {
    Hardware* h;
    bool read(fw::ImuSample& out) override {
      if (h->imu.empty()) return false;
      out = h->imu.front();
      h->imu.pop_front();
      return true;
    }
  } imu_port;
  struct Can final : fw::CanPort {
    Hardware* h;
    bool receive(CanFrame& out) override {
      if (h->balance_rx.empty()) return false;
      out = h->balance_rx.front();
      h->balance_rx.pop_front();
      ++h->can_stats.rx;
      return true;
    }
    bool send(const CanFrame& f) override {
      ++h->can_stats.tx;
      h->world->send_from_balance(f);
      return true;
    }
    console::CanStats stats() override { return h->can_stats; }
  } can_port;
  struct Watchdog final : fw::Watchdog {
    fw::TimeUs* fed;
    const fw::TimeUs* now;
    void feed() override { *fed = *now; }
  } balance_watchdog, io_watchdog;
  fw::TimeUs io_fed_us = 0;
  struct Display final : fw::Display {
    fw::LcdView* view;
    void show(const fw::LcdView& v) override { *view = v; }
  } display;
  fw::RetainedLimits retained{};  // kept across the simulated board's restarts, as RTC memory is across a reset
  struct Pwm final : fw::Pwm {
    std::array<std::uint16_t, fw::kPwmChannelCount>* pwm;
    void set(fw::PwmChannel c, std::uint16_t p) override { (*pwm)[static_cast<std::size_t>(c)] = p; }
  } pwm_port;
  struct Gpio final : fw::Gpio {
    Hardware* h;
    void write(fw::OutputPin pin, bool on) override { h->outputs[static_cast<std::size_t>(pin)] = on; }
    bool read(fw::InputPin pin) override { return pin == fw::InputPin::arm_button ? h->arm_button : h->kill_switch; }
  } gpio;
  struct Horn final : fw::Horn {
    std::uint16_t* hz;
    void tone(std::uint16_t f) override { *hz = f; }
  } horn;
  struct Leds final : fw::LedStrip {
    std::vector<fw::Rgb>* leds;
    void show(std::span<const fw::Rgb> p) override { leds->assign(p.begin(), p.end()); }
  } led_strip;
  struct Sensors final : fw::Sensors {
    fw::SensorReadings read() override {
      fw::SensorReadings r;
      r.tof_valid = true;
      r.tof_mm = 850;
      r.pressure_valid = true;
      r.pressure_pa = 101'325;
      return r;
    }
  } sensors;

  QueuePort balance_link{io_to_balance, &balance_to_io, nullptr};
  QueuePort io_link{balance_to_io, &io_to_balance, nullptr};
  QueuePort balance_console{balance_console_in, &balance_console_out, nullptr, kBalanceConsoleRoom};
  QueuePort io_console{io_console_in, &io_console_out};
  QueuePort crsf{crsf_in, &telemetry_out};
  QueuePort elrs{elrs_in, nullptr};

  Hardware(World* w, bool* cut)
      : world(w),
        link_cut(cut),
        balance_link(io_to_balance, &balance_to_io, cut),
        io_link(balance_to_io, &io_to_balance, cut) {
    imu_port.h = this;
    can_port.h = this;
    balance_watchdog.fed = &balance_fed_us;
    balance_watchdog.now = &now;
    io_watchdog.fed = &io_fed_us;
    io_watchdog.now = &now;
    display.view = &lcd;
    pwm_port.pwm = &pwm;
    gpio.h = this;
    horn.hz = &horn_hz;
    led_strip.leds = &leds;
  }
};

World::World(const WorldConfig& config) : config_(config), plant_(config.plant), hw_(std::make_unique<Hardware>(this, &link_cut_)) {
  channels_us_.fill(1500);
  channels_us_[4] = 2000;  // CH5 ARM switch on: arming still needs the 3 s button hold while upright
  channels_us_[5] = 1000;  // CH6 ESTOP off
  channels_us_[6] = 988;   // CH7 speed limit at its minimum (10 %)
  boot_balance(fw::ResetReason::power_on);
  io_.emplace(fw::IoBoard::Hardware{hw_->crsf, hw_->elrs, hw_->io_link, hw_->io_console, hw_->pwm_port, hw_->gpio,
                                    hw_->horn, hw_->led_strip, hw_->sensors, hw_->io_watchdog},
              config_.io);
}

World::~World() = default;

void World::boot_balance(fw::ResetReason reason) {
  balance_.reset();
  balance_.emplace(fw::BalanceBoard::Hardware{hw_->imu_port, hw_->can_port, hw_->balance_link, hw_->balance_console,
                                              hw_->balance_watchdog, hw_->display, hw_->retained},
                   config_.balance, reason);
  hw_->balance_fed_us = now_;
  balance_hung_ = false;
}

void World::send_from_balance(const CanFrame& f) {
  CanFrame out = f;
  out.timestamp_ns = now_ * 1000;
  plant_.on_can(f, static_cast<double>(now_) / 1e6);
  can_out_.push_back(out);
}

void World::send_can(const CanFrame& frame) {
  CanFrame f = frame;
  f.timestamp_ns = now_ * 1000;
  hw_->balance_rx.push_back(f);
  plant_.on_can(f, static_cast<double>(now_) / 1e6);  // a VESC command from outside reaches the VESCs too
}

std::vector<CanFrame> World::take_can_output() {
  std::vector<CanFrame> out;
  out.swap(can_out_);
  return out;
}

void World::send_radio() {
  crsf::RcChannels rc;
  for (std::size_t i = 0; i < 16; ++i) rc.ticks[i] = crsf::us_to_ticks(channels_us_[i]);
  std::array<std::uint8_t, crsf::kMaxFrameSize> buf{};
  const auto n = crsf::encode(rc, buf);
  if (!n) return;
  if (crsf_on_ && now_ >= next_crsf_) {
    hw_->crsf_in.insert(hw_->crsf_in.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(*n));
    next_crsf_ = now_ + 10'000;  // 100 Hz
  }
  if (elrs_on_ && now_ >= next_elrs_) {
    hw_->elrs_in.insert(hw_->elrs_in.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(*n));
    next_elrs_ = now_ + 10'000;
  }
}

void World::step() {
  now_ += kStepUs;
  hw_->now = now_;
  const double t = static_cast<double>(now_) / 1e6;
  plant_.step(static_cast<double>(kStepUs) / 1e6, t);
  if (imu_on_) hw_->imu.push_back(plant_.imu_sample(now_));
  if (hw_->imu.size() > 16) hw_->imu.pop_front();  // a stalled reader loses old samples, like a FIFO overrun
  for (const auto& f : plant_.status_frames(t)) {
    CanFrame out = f;
    out.timestamp_ns = now_ * 1000;
    hw_->balance_rx.push_back(out);
    can_out_.push_back(out);
  }
  send_radio();
  if (hw_->telemetry_out.size() > 4096) hw_->telemetry_out.clear();

  io_->step(now_);
  if (!balance_hung_) balance_->step(now_);
  // The console's reboot: the board restarts as the glue's esp_restart() does (a software reset: OFF, limits kept).
  if (!balance_hung_ && balance_->reboot_requested()) {
    ++balance_resets_;
    boot_balance(fw::ResetReason::software);
  }
  // The 50 ms task watchdog: a board that stopped feeding it is reset (and comes back OFF, reason watchdog).
  if (now_ - hw_->balance_fed_us > 50'000) {
    ++balance_resets_;
    boot_balance(fw::ResetReason::watchdog);
  }
  // The bench stand lets go once the robot balances on its own.
  if (plant_.on_stand() && balance_->state() == saulcan::RobotState::balance) plant_.release_stand();
}

void World::console_input(const std::string& board, const std::string& text) {
  Bytes& in = board == "io" ? hw_->io_console_in : hw_->balance_console_in;
  in.insert(in.end(), text.begin(), text.end());
}

std::string World::take_console_output(const std::string& board) {
  Bytes& out = board == "io" ? hw_->io_console_out : hw_->balance_console_out;
  std::string s(out.begin(), out.end());
  out.clear();
  return s;
}

std::uint16_t World::io_pwm(fw::PwmChannel channel) const { return hw_->pwm[static_cast<std::size_t>(channel)]; }
bool World::io_pin(fw::OutputPin pin) const { return hw_->outputs[static_cast<std::size_t>(pin)]; }

std::uint16_t World::io_drive_duty() const {
  using fw::OutputPin;
  using fw::PwmChannel;
  const bool left = io_pin(OutputPin::left_r_en) || io_pin(OutputPin::left_l_en);
  const bool right = io_pin(OutputPin::right_r_en) || io_pin(OutputPin::right_l_en);
  const std::uint16_t l = left ? std::max(io_pwm(PwmChannel::left_rpwm), io_pwm(PwmChannel::left_lpwm)) : 0;
  const std::uint16_t r = right ? std::max(io_pwm(PwmChannel::right_rpwm), io_pwm(PwmChannel::right_lpwm)) : 0;
  return std::max(l, r);
}

std::string World::status_line() const {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "t=%.3f s state=%s pitch=%.2f deg speed=%.3f m/s battery=%.2f V faults=0x%02X stand=%s io_armed=%d "
                "rc=%s resets=%u",
                static_cast<double>(now_) / 1e6, saulcan::to_string(balance_->state()), plant_.pitch_deg(),
                plant_.speed_mps(), plant_.battery_v(), balance_->faults(), plant_.on_stand() ? "on" : "off",
                io_->armed() ? 1 : 0, rc::to_string(io_->active_source()), balance_resets_);
  return buf;
}

std::string World::command(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> w;
  for (std::string t; in >> t;) w.push_back(t);
  auto ok = [](const std::string& what = "") { return what.empty() ? std::string("ok\n") : what + "\nok\n"; };
  auto error = [](const std::string& what) { return "error: " + what + "\n"; };
  if (w.empty()) return error("empty command (try help)");
  const std::string& c = w[0];
  auto arg = [&](std::size_t i) { return i < w.size() ? w[i] : std::string(); };
  auto number = [&](std::size_t i, double& v) {
    try {
      std::size_t used = 0;
      v = std::stod(arg(i), &used);
      return used == arg(i).size();
    } catch (...) {
      return false;
    }
  };
  double v = 0;
  if (c == "help") {
    return ok(
        "status                       one line: time, state, pitch, speed, battery, faults, stand, radio\n"
        "push DPS                     a 20 ms shove that adds DPS deg/s to the pitch rate (+ = nose up)\n"
        "tilt DEG                     a hand moves the body to DEG degrees in 250 ms and lets go (off the stand)\n"
        "upright                      hands put it back on the bench stand in 250 ms (slightly off balance)\n"
        "imu off|on                   pull the IMU (no samples at all) / plug it back\n"
        "radio CH US                  RC channel 1..16 in microseconds (CH5 arm, CH6 estop, CH7 speed cap)\n"
        "rc loss|ok                   both receivers silent / back\n"
        "crsf loss|ok, elrs loss|ok   one receiver\n"
        "button down|up               the arming button (hold 3 s while upright to arm)\n"
        "kill on|off                  the hardware kill switch\n"
        "vesc left|right|both dead|alive\n"
        "link cut|ok                  the inter-board UART\n"
        "hang balance                 the BALANCE loop stops (the watchdog resets it after 50 ms)");
  }
  if (c == "status") return ok(status_line());
  if (c == "push" && number(1, v)) {
    plant_.push(v);
    return ok();
  }
  if (c == "tilt" && number(1, v)) {
    plant_.tilt(v);
    return ok();
  }
  if (c == "imu" && (arg(1) == "off" || arg(1) == "on")) {
    imu_on_ = arg(1) == "on";
    return ok();
  }
  if (c == "upright") {
    plant_.upright();
    return ok();
  }
  if (c == "radio" && number(2, v)) {
    std::string ch = arg(1);
    if (ch.rfind("ch", 0) == 0) ch = ch.substr(2);
    int n = 0;
    try {
      n = std::stoi(ch);
    } catch (...) {
      n = 0;
    }
    if (n < 1 || n > 16 || v < 880 || v > 2160) return error("radio CH US: channel 1..16, 880..2160 us");
    channels_us_[static_cast<std::size_t>(n - 1)] = static_cast<std::uint16_t>(v);
    return ok();
  }
  if ((c == "rc" || c == "crsf" || c == "elrs") && (arg(1) == "loss" || arg(1) == "ok")) {
    const bool on = arg(1) == "ok";
    if (c != "elrs") crsf_on_ = on;
    if (c != "crsf") elrs_on_ = on;
    return ok();
  }
  if (c == "button" && (arg(1) == "down" || arg(1) == "up")) {
    hw_->arm_button = arg(1) == "down";
    return ok();
  }
  if (c == "kill" && (arg(1) == "on" || arg(1) == "off")) {
    hw_->kill_switch = arg(1) == "on";
    return ok();
  }
  if (c == "vesc" && (arg(2) == "dead" || arg(2) == "alive") && (arg(1) == "left" || arg(1) == "right" || arg(1) == "both")) {
    const bool alive = arg(2) == "alive";
    if (arg(1) != "right") plant_.left().alive = alive;
    if (arg(1) != "left") plant_.right().alive = alive;
    return ok();
  }
  if (c == "link" && (arg(1) == "cut" || arg(1) == "ok")) {
    link_cut_ = arg(1) == "cut";
    return ok();
  }
  if (c == "hang" && arg(1) == "balance") {
    balance_hung_ = true;
    return ok();
  }
  return error("unknown or malformed command '" + line + "' (try help)");
}

}  // namespace saul::sim
