// The simulated robot: both boards' real firmware logic (firmware/logic), wired to the plant model through fake
// hardware, on simulated time in 1 ms steps. Everything that happens is a function of the commands given and
// the seed: two runs with the same inputs are identical.
//
// The outside world reaches it the way it reaches the real robot:
//  - the CAN bus (send_can / take_can_output): what a CANable on the robot's bus would see;
//  - each board's USB console (console_input / take_console_output);
//  - the virtual radio, the arming button and the kill switch, and fault injection, through command().
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "saulfw/balance.hpp"
#include "saulfw/io.hpp"
#include "saulsim/plant.hpp"

namespace saul::sim {

/// A byte queue between two ends (a UART, a USB console).
using Bytes = std::deque<std::uint8_t>;

struct WorldConfig {
  PlantConfig plant;
  fw::BalanceConfig balance;
  fw::IoConfig io;
  WorldConfig();
};

class World {
 public:
  explicit World(const WorldConfig& config = WorldConfig());
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  static constexpr fw::TimeUs kStepUs = 1000;

  /// Advances one step (1 ms): plant, IMU sample, radio, both boards, the bus.
  void step();
  /// Steps until now_us() >= t.
  void run_until(fw::TimeUs t) {
    while (now_ < t) step();
  }
  [[nodiscard]] fw::TimeUs now_us() const { return now_; }

  // ---- the CAN bus, as an adapter on it sees it ----
  void send_can(const CanFrame& frame);
  /// Frames put on the bus by BALANCE and the VESCs since the last call (timestamps: simulated ns).
  std::vector<CanFrame> take_can_output();

  // ---- USB consoles ("balance", "io") ----
  void console_input(const std::string& board, const std::string& text);
  std::string take_console_output(const std::string& board);

  /// A control command (the simulator's own console): radio, button, kill switch, fault injection, status.
  /// Returns the reply; it ends with "ok" or starts with "error:". `help` lists the commands.
  std::string command(const std::string& line);

  // ---- observers ----
  [[nodiscard]] const Plant& plant() const { return plant_; }
  [[nodiscard]] const fw::BalanceBoard& balance() const { return *balance_; }
  [[nodiscard]] const fw::IoBoard& io() const { return *io_; }
  [[nodiscard]] std::uint32_t balance_resets() const { return balance_resets_; }
  [[nodiscard]] std::string status_line() const;
  /// The IO board's outputs as its pins carry them now: a PWM duty (permille) and a digital output.
  [[nodiscard]] std::uint16_t io_pwm(fw::PwmChannel channel) const;
  [[nodiscard]] bool io_pin(fw::OutputPin pin) const;
  /// The largest BTS7960 duty on the pins now (permille): 0 unless that side's enables are high.
  [[nodiscard]] std::uint16_t io_drive_duty() const;

 private:
  struct Hardware;
  friend struct Hardware;
  void send_from_balance(const CanFrame& frame);
  void boot_balance(fw::ResetReason reason);
  void send_radio();

  WorldConfig config_;
  Plant plant_;
  fw::TimeUs now_ = 0;
  std::unique_ptr<Hardware> hw_;
  std::optional<fw::BalanceBoard> balance_;
  std::optional<fw::IoBoard> io_;
  std::vector<CanFrame> can_out_;
  std::uint32_t balance_resets_ = 0;
  // fault injection and the radio
  bool balance_hung_ = false;
  bool link_cut_ = false;
  bool imu_on_ = true;
  bool crsf_on_ = true;
  bool elrs_on_ = true;
  std::array<std::uint16_t, 16> channels_us_{};
  fw::TimeUs next_crsf_ = 0;
  fw::TimeUs next_elrs_ = 0;
};

}  // namespace saul::sim
