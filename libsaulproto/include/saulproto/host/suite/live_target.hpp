// A bench-test Target on live links: a CAN link, optional USB consoles of the boards, and optionally the control
// console of a running `saulctl sim` (which makes `sim ...` steps possible). Time is the host's steady clock.
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <string>

#include "saulproto/host/suite/suite.hpp"
#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saul::host::suite {

class LiveTarget final : public Target {
 public:
  /// consoles: board name ("balance", "io") -> open port. sim_control: the simulator's control port, or null.
  LiveTarget(CanLink& link, std::map<std::string, std::unique_ptr<SerialPort>> consoles,
             std::unique_ptr<SerialPort> sim_control);

  std::uint64_t now_us() override;
  void send(const CanFrame& frame) override;
  std::optional<CanFrame> receive_until(std::uint64_t deadline_us) override;
  std::optional<std::string> console(const std::string& board, const std::string& line, const std::string& until,
                                     std::uint64_t timeout_us) override;
  bool console_type(const std::string& board, const std::string& bytes) override;
  std::optional<std::string> console_take(const std::string& board) override;
  bool sim(const std::string& command, std::string& error) override;
  [[nodiscard]] bool is_simulator() const override { return sim_control_ != nullptr; }
  [[nodiscard]] std::string describe() const override;

 private:
  std::string exchange(SerialPort& port, const std::string& line, const std::string& until, std::uint64_t timeout_us);

  CanLink& link_;
  std::map<std::string, std::unique_ptr<SerialPort>> consoles_;
  std::unique_ptr<SerialPort> sim_control_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace saul::host::suite
