// The arming table (firmware/logic/include/saulfw/arming.hpp) against the rules as docs/protocol.md section 4 and
// issue 33 state them, written out here cell by cell in words of their own (not read from the table): an estop
// always latches ESTOP; only OFF can be armed; a disarm always leads to OFF (in ESTOP, not while an estop input
// holds); the first latch stays, except that ESTOP replaces it; a tilt latches only an armed robot; every stop and
// every disarm cancels a hold, whatever state it finds; an arming never does.
#include <catch2/catch.hpp>

#include <string>

#include "saulfw/arming.hpp"

using saul::fw::arming::Event;
using saul::saulcan::RobotState;
namespace arming = saul::fw::arming;

namespace {

constexpr RobotState kStates[] = {RobotState::off,         RobotState::balance, RobotState::manual,
                                  RobotState::estop,       RobotState::tilt_cutoff, RobotState::fault};
constexpr Event kEvents[] = {Event::estop, Event::tilt, Event::fault, Event::disarm, Event::arm};

bool armed(RobotState s) { return s == RobotState::balance || s == RobotState::manual; }
bool latched(RobotState s) { return s == RobotState::estop || s == RobotState::tilt_cutoff || s == RobotState::fault; }

/// The next state as the documents say it, from first principles.
RobotState expected_next(RobotState from, Event e) {
  switch (e) {
    case Event::estop: return RobotState::estop;
    case Event::tilt: return armed(from) ? RobotState::tilt_cutoff : from;
    case Event::fault: return latched(from) ? from : RobotState::fault;
    case Event::disarm: return RobotState::off;
    case Event::arm: return from == RobotState::off ? RobotState::balance : from;
  }
  return from;
}

std::string cell(RobotState s, Event e) {
  return std::string(saul::saulcan::to_string(s)) + " x " + arming::event_name(e);
}

}  // namespace

TEST_CASE("arming table: every cell is what the documents say") {
  for (const RobotState s : kStates) {
    for (const Event e : kEvents) {
      INFO(cell(s, e));
      const arming::Rule& r = arming::rule(s, e);
      CHECK(r.next == expected_next(s, e));
      // Every stop and every disarm cancels a hold; a tilt while disarmed is no stop (it only blocks arming); an
      // arming never cancels one.
      const bool stop_or_disarm = e == Event::estop || e == Event::fault || e == Event::disarm ||
                                  (e == Event::tilt && s != RobotState::off);
      CHECK(r.cancels_hold == stop_or_disarm);
      // Only ESTOP's disarm waits for the estop inputs to be gone.
      CHECK(r.kept_by_estop_input == (s == RobotState::estop && e == Event::disarm));
      // Only arming has refusals, and it is refused everywhere but in OFF.
      CHECK((r.refusal != nullptr) == (e == Event::arm && s != RobotState::off));
    }
  }
}

TEST_CASE("arming table: a latch is left only to OFF, and only OFF is armed") {
  for (const RobotState s : kStates) {
    for (const Event e : kEvents) {
      INFO(cell(s, e));
      const RobotState next = arming::rule(s, e).next;
      if (latched(s)) CHECK((latched(next) || next == RobotState::off));
      if (!armed(s) && armed(next)) CHECK((s == RobotState::off && e == Event::arm));
    }
  }
  // Refusals name the way out.
  CHECK(std::string(arming::rule(RobotState::estop, Event::arm).refusal).find("disarm first") != std::string::npos);
  CHECK(std::string(arming::rule(RobotState::balance, Event::arm).refusal) == "already armed");
}

TEST_CASE("arming table: a state value outside the table reads as FAULT, never as armable") {
  const auto bogus = static_cast<RobotState>(9);
  CHECK(arming::rule(bogus, Event::arm).refusal != nullptr);
  CHECK(arming::rule(bogus, Event::estop).next == RobotState::estop);
}
