// The robot's arming and latches as one table: (state, event) -> the next state, whether a button hold in progress
// is cancelled, and why an arming is refused. BALANCE owns the robot state and applies every event through
// arming::rule(); the IO board's hold follows the same "cancels a hold" column for the events it hears itself (kill
// switch, CH6, CH5, RC loss, its console, BALANCE's STATE entering a latch). docs/protocol.md section 4 prints
// this table; tests/firmware/test_arming.cpp checks the table against the rules written out by hand, and the
// explorer's oracles (tests/firmware/explorer.cpp) check the boards' behaviour against the same rules from outside.
//
// Why a table: the rules used to be spread over flags (a "disarmed since latch" flag, a "button released" flag set
// in four places), and two cases fell between them: a stop that did not change the state (an estop in ESTOP, a
// disarm in OFF) did not cancel a hold in progress, so the same press armed the robot 1.5 s later; and an arming
// could leave a latch without passing through OFF. Here every stop and every disarm cancels a hold, whatever state
// it finds, and only OFF can be armed.
//
// Cost: a table lookup; no state of its own.
#pragma once

#include <cstdint>

#include "saulproto/core/saul_can.hpp"

namespace saul::fw::arming {

using saulcan::RobotState;

/// What happened, by kind; the source does not matter to the table (each source is listed with its kind).
enum class Event : std::uint8_t {
  estop,   ///< RC_CMD kill flag, IO FAULT estop bit, 0x302 mode 3, BALANCE console estop, an estop input still active
  tilt,    ///< |pitch| beyond the tilt limit (BALANCE checks it while armed)
  fault,   ///< IO link loss, RC loss, motor fault, loop hang, IMU missing or silent, IO board silent since power-on
  disarm,  ///< BALANCE console disarm, 0x302 mode 0, CH5 at disarm (RC_CMD disarm_switch), the IO armed flag
           ///< falling while armed
  arm,     ///< the IO board's completed 3 s hold (RC_CMD armed flag 0 -> 1), BALANCE console arm
};
inline constexpr int kEvents = 5;
inline constexpr int kStates = 6;

struct Rule {
  RobotState next;            ///< the state after the event; the same state when it stays
  bool cancels_hold;          ///< the next arming by button needs a press that starts after this event
  bool kept_by_estop_input;   ///< refused (the state stays) while an estop input is active or in the loop
                              ///< iteration an ESTOP arrived in
  const char* refusal;        ///< arm: why it is refused in this state; nullptr: the arming checks decide
};

namespace detail {
constexpr RobotState kOff = RobotState::off;
constexpr RobotState kBal = RobotState::balance;
constexpr RobotState kMan = RobotState::manual;
constexpr RobotState kEst = RobotState::estop;
constexpr RobotState kTilt = RobotState::tilt_cutoff;
constexpr RobotState kFault = RobotState::fault;
constexpr const char* kArmed = "already armed";
constexpr const char* kLatched = "latched: disarm first (console disarm, 0x302 mode 0 or CH5 at disarm), then arm";
}  // namespace detail

// clang-format off
/// kTable[state][event]. Rows: OFF, BALANCE, MANUAL, ESTOP, TILT_CUTOFF, FAULT (RobotState's values).
/// Columns: estop, tilt, fault, disarm, arm.
inline constexpr Rule kTable[kStates][kEvents] = {
  // OFF: a tilt while disarmed only blocks arming (upright check); every stop and disarm cancels a hold.
  {{detail::kEst, true, false, nullptr}, {detail::kOff, false, false, nullptr}, {detail::kFault, true, false, nullptr},
   {detail::kOff, true, false, nullptr}, {detail::kBal, false, false, nullptr}},
  // BALANCE
  {{detail::kEst, true, false, nullptr}, {detail::kTilt, true, false, nullptr}, {detail::kFault, true, false, nullptr},
   {detail::kOff, true, false, nullptr}, {detail::kBal, false, false, detail::kArmed}},
  // MANUAL
  {{detail::kEst, true, false, nullptr}, {detail::kTilt, true, false, nullptr}, {detail::kFault, true, false, nullptr},
   {detail::kOff, true, false, nullptr}, {detail::kMan, false, false, detail::kArmed}},
  // ESTOP: stays against a tilt or a fault (their bits are added); a disarm goes to OFF unless an estop input holds.
  {{detail::kEst, true, false, nullptr}, {detail::kEst, true, false, nullptr}, {detail::kEst, true, false, nullptr},
   {detail::kOff, true, true, nullptr}, {detail::kEst, false, false, detail::kLatched}},
  // TILT_CUTOFF: the first latch stays; only ESTOP replaces it.
  {{detail::kEst, true, false, nullptr}, {detail::kTilt, true, false, nullptr}, {detail::kTilt, true, false, nullptr},
   {detail::kOff, true, false, nullptr}, {detail::kTilt, false, false, detail::kLatched}},
  // FAULT
  {{detail::kEst, true, false, nullptr}, {detail::kFault, true, false, nullptr}, {detail::kFault, true, false, nullptr},
   {detail::kOff, true, false, nullptr}, {detail::kFault, false, false, detail::kLatched}},
};
// clang-format on

/// The rule for an event in a state. A state value outside the table (never produced) is treated as FAULT.
constexpr const Rule& rule(RobotState from, Event event) noexcept {
  const auto s = static_cast<unsigned>(from);
  return kTable[s < kStates ? s : static_cast<unsigned>(RobotState::fault)][static_cast<unsigned>(event)];
}

constexpr bool is_armed(RobotState s) noexcept { return s == RobotState::balance || s == RobotState::manual; }
constexpr bool is_latched(RobotState s) noexcept {
  return s == RobotState::estop || s == RobotState::tilt_cutoff || s == RobotState::fault;
}

constexpr const char* event_name(Event e) noexcept {
  switch (e) {
    case Event::estop: return "estop";
    case Event::tilt: return "tilt";
    case Event::fault: return "fault";
    case Event::disarm: return "disarm";
    case Event::arm: return "arm";
  }
  return "?";
}

}  // namespace saul::fw::arming
