// Test-only mutants of the safety checks. Each one removes a single check from the board logic, so that the
// firmware tests' explorer (tests/firmware/explorer.hpp) can show it notices the check's absence.
//
// Only the firmware tests compile the logic with SAUL_MUTANTS defined (a copy of their own, tests/CMakeLists.txt).
// Everywhere else, the boards and the simulator included, SAUL_MUTANT(name) is the constant false, so the checks
// compile to exactly the shipped code.
#pragma once

#include <cstdint>

namespace saul::fw::mutant {

enum class Id : std::uint8_t {
  none = 0,
  new_press,          ///< rule 1: re-arming after a disarm or latch without a new press of the button
  arm_switch,         ///< rule 2: BALANCE ignores CH5 at disarm (RC_CMD disarm_switch)
  io_cap,             ///< rule 3: the IO board's BTS7960 duty follows CH7 only, not the speed cap
  tilt_cutoff,        ///< no TILT_CUTOFF
  rc_loss_stop,       ///< BALANCE does not stop on RC loss
  link_loss_stop,     ///< BALANCE does not stop on inter-board link loss
  kill_switch,        ///< the IO board does not read the kill switch
  estop_latch,        ///< ESTOP clears itself once no estop input is active
  speed_cap,          ///< BALANCE's wheel speed is not limited by the speed cap
  throttle_centred,   ///< arming with the throttle stick off centre
  raise_while_armed,  ///< the speed cap may be raised while armed
  hold_cancel,        ///< rule 1: a stop or disarm that leaves the state as it was does not cancel a button hold
  arm_from_latch,     ///< arming (console arm, a button hold) leaves ESTOP, TILT_CUTOFF or FAULT without a disarm
  excite_latch,       ///< the excitation survives leaving BALANCE (a latch, a disarm)
  excite_cap,         ///< a test signal starts and runs outside trace::kExciteMinCapPct..kExciteMaxCapPct of the cap
};
inline constexpr int kCount = 16;  ///< none included

constexpr const char* name(Id id) noexcept {
  switch (id) {
    case Id::none: return "none";
    case Id::new_press: return "new_press";
    case Id::arm_switch: return "arm_switch";
    case Id::io_cap: return "io_cap";
    case Id::tilt_cutoff: return "tilt_cutoff";
    case Id::rc_loss_stop: return "rc_loss_stop";
    case Id::link_loss_stop: return "link_loss_stop";
    case Id::kill_switch: return "kill_switch";
    case Id::estop_latch: return "estop_latch";
    case Id::speed_cap: return "speed_cap";
    case Id::throttle_centred: return "throttle_centred";
    case Id::raise_while_armed: return "raise_while_armed";
    case Id::hold_cancel: return "hold_cancel";
    case Id::arm_from_latch: return "arm_from_latch";
    case Id::excite_latch: return "excite_latch";
    case Id::excite_cap: return "excite_cap";
  }
  return "?";
}

#ifdef SAUL_MUTANTS
/// The mutant in force (tests only; none = the real logic).
inline Id active = Id::none;
#define SAUL_MUTANT(id) (::saul::fw::mutant::active == ::saul::fw::mutant::Id::id)
#else
#define SAUL_MUTANT(id) false
#endif

}  // namespace saul::fw::mutant
