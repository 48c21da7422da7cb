// The simulated robot as a bench-test target, in-process and on simulated time: a suite runs as fast as the
// machine can step the simulation, and gives the same result every time.
//
// Besides the world's own control commands, `sim` steps here can check what only the simulator can see (the IO
// board's motor pins have no CAN frame): `sim check FIELD OP VALUE` (OP one of = != < <= > >=) fails the step when
// the condition does not hold now, and `sim peak reset` restarts the peaks; `sim type BOARD LINE` types a console
// line without waiting for its reply (the explorer's suites: their timing is the input's). Fields:
//   io_duty       the largest BTS7960 duty on the IO board's pins now (permille, 0 while the enables are low)
//   io_duty_peak  the largest io_duty since the suite started or `sim peak reset`
//   io_armed      the IO board's armed flag (0 / 1)
#pragma once

#include <deque>

#include "saulproto/host/suite/suite.hpp"
#include "saulsim/world.hpp"

namespace saul::sim {

class SimTarget final : public host::suite::Target {
 public:
  explicit SimTarget(World& world) : world_(world) {}

  std::uint64_t now_us() override { return world_.now_us(); }
  void send(const CanFrame& frame) override { world_.send_can(frame); }
  std::optional<CanFrame> receive_until(std::uint64_t deadline_us) override;
  std::optional<std::string> console(const std::string& board, const std::string& line, const std::string& until,
                                     std::uint64_t timeout_us) override;
  bool console_type(const std::string& board, const std::string& bytes) override {
    world_.console_input(board, bytes);
    return true;
  }
  std::optional<std::string> console_take(const std::string& board) override { return world_.take_console_output(board); }
  bool sim(const std::string& command, std::string& error) override;
  [[nodiscard]] bool is_simulator() const override { return true; }
  [[nodiscard]] std::string describe() const override { return "the simulated robot (in-process, simulated time)"; }

 private:
  void step();
  bool check(const std::string& condition, std::string& error) const;
  World& world_;
  std::deque<CanFrame> pending_;
  std::uint16_t io_duty_peak_ = 0;
};

}  // namespace saul::sim
