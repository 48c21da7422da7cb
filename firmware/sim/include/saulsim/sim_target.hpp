// The simulated robot as a bench-test target, in-process and on simulated time: a suite runs as fast as the
// machine can step the simulation, and gives the same result every time.
#pragma once

#include <deque>

#include "saulproto/host/bench/bench_test.hpp"
#include "saulsim/world.hpp"

namespace saul::sim {

class SimTarget final : public host::benchtest::Target {
 public:
  explicit SimTarget(World& world) : world_(world) {}

  std::uint64_t now_us() override { return world_.now_us(); }
  void send(const CanFrame& frame) override { world_.send_can(frame); }
  std::optional<CanFrame> receive_until(std::uint64_t deadline_us) override;
  std::optional<std::string> console(const std::string& board, const std::string& line, const std::string& until,
                                     std::uint64_t timeout_us) override;
  bool sim(const std::string& command, std::string& error) override;
  [[nodiscard]] bool is_simulator() const override { return true; }
  [[nodiscard]] std::string describe() const override { return "the simulated robot (in-process, simulated time)"; }

 private:
  void step();
  World& world_;
  std::deque<CanFrame> pending_;
};

}  // namespace saul::sim
