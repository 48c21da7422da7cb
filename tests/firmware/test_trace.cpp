// BALANCE's loop trace, flight recorder and excitation (docs/protocol.md section 10): records read back by hand
// from the console bytes (fields at their documented offsets, CRC-8/MAXIM bit by bit, never the codec's decoder),
// the counters, the ring frozen at a latch, and the test signal's safety: only in BALANCE and at a speed cap of at
// least trace::kExciteMinCapPct, gone in the iteration that leaves either, refused or stopped by a speed request.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "fakes.hpp"

using namespace fwtest;
using saulcan::RobotState;

namespace {

/// One record as read by hand from its frame (offsets of docs/protocol.md section 10).
struct Read {
  std::size_t at = 0;  // offset in the console bytes
  std::uint32_t time_us = 0, seq = 0;
  std::int16_t pitch_x100 = 0, setpoint_x100 = 0, output = 0, excite_x100 = 0;
  std::uint8_t state = 0, excite = 0;
};

std::uint32_t u32(const Bytes& b, std::size_t i) {
  return b[i] | (b[i + 1] << 8) | (b[i + 2] << 16) | (static_cast<std::uint32_t>(b[i + 3]) << 24);
}
std::int16_t i16(const Bytes& b, std::size_t i) { return static_cast<std::int16_t>(b[i] | (b[i + 1] << 8)); }

/// Every record in the console bytes; text is every byte outside them. A 0xAA that starts no whole valid record
/// fails the test (BALANCE never writes part of one, and its text never holds 0xAA).
std::vector<Read> records(const Bytes& tx, std::string* text = nullptr) {
  std::vector<Read> out;
  for (std::size_t i = 0; i < tx.size();) {
    if (tx[i] != 0xAA) {
      if (text != nullptr) text->push_back(static_cast<char>(tx[i]));
      ++i;
      continue;
    }
    REQUIRE(tx.size() - i >= 39);
    REQUIRE(tx[i + 1] == 35);
    REQUIRE(tx[i + 2] == 0x20);
    REQUIRE(crc8_maxim(Bytes(tx.begin() + static_cast<std::ptrdiff_t>(i) + 2,
                             tx.begin() + static_cast<std::ptrdiff_t>(i) + 38)) == tx[i + 38]);
    const std::size_t p = i + 3;
    out.push_back({i, u32(tx, p), u32(tx, p + 4), i16(tx, p + 8), i16(tx, p + 12), i16(tx, p + 20), i16(tx, p + 33),
                   tx[p + 30], tx[p + 32]});
    i += 39;
  }
  return out;
}

/// A rig armed in BALANCE, upright, its speed cap first raised (disarmed, one 10 % step per line) to cap_pct: a test
/// signal needs trace::kExciteMinCapPct.
void arm(BalanceRig& rig, int cap_pct = trace::kExciteMinCapPct) {
  rig.run_ms(30);
  for (int pct = 20; pct <= cap_pct; pct += 10) REQUIRE(rig.reply_to("speed_limit " + std::to_string(pct)) == "ok\n");
  rig.arm_via_io();
  REQUIRE(rig.board->state() == RobotState::balance);
}

}  // namespace

TEST_CASE("trace on: one record per loop, seq +1, the loop's time, text and records apart on the one port") {
  BalanceRig rig;
  rig.run_ms(30);
  std::string reply;
  rig.reply_to("trace on");
  CHECK(records(rig.console.tx, &reply).size() == 1);
  CHECK(reply == "ok\n");  // the reply comes before the iteration's record
  rig.console.tx.clear();
  rig.run_ms(100);
  std::string text;
  auto r = records(rig.console.tx, &text);
  CHECK(text.empty());
  REQUIRE(r.size() == 100);
  for (std::size_t i = 1; i < r.size(); ++i) {
    CHECK(r[i].seq == r[i - 1].seq + 1);
    CHECK(r[i].time_us == r[i - 1].time_us + 1000);
  }
  CHECK(r.back().time_us == static_cast<std::uint32_t>(rig.now));
  CHECK(r.back().state == 0);  // OFF
  CHECK(rig.board->trace_sent() == 101);  // the one in the reply's own iteration too

  // Every 10th loop: seq steps by 10.
  rig.reply_to("trace on 10");
  rig.console.tx.clear();
  rig.run_ms(100);
  r = records(rig.console.tx);
  REQUIRE(r.size() == 10);
  for (std::size_t i = 1; i < r.size(); ++i) CHECK(r[i].seq == r[i - 1].seq + 10);
  CHECK(r[0].seq % 10 == 0);

  const std::string off = rig.reply_to("trace off");
  rig.console.tx.clear();
  rig.run_ms(50);
  CHECK(rig.console.tx.empty());
  CHECK(off.find("ok\n") != std::string::npos);
}

TEST_CASE("trace: a full console buffer drops whole records and counts them, never a cut record, never waits") {
  BalanceRig rig;
  rig.run_ms(30);
  rig.reply_to("trace on");
  rig.console.tx.clear();
  rig.console.tx_limit = 39 * 10 + 20;  // room for 10 records and a bit: the 11th does not fit whole
  rig.run_ms(50);
  const auto r = records(rig.console.tx);  // fails on any cut record
  CHECK(r.size() == 10);
  CHECK(rig.board->trace_dropped() == 40);
  rig.console.tx_limit = static_cast<std::size_t>(-1);
  rig.console.tx.clear();
  rig.run_ms(5);
  const auto after = records(rig.console.tx);
  REQUIRE(after.size() == 5);
  CHECK(after[0].seq == r.back().seq + 41);  // the gap shows the 40 lost
  rig.reply_to("trace off");
  const std::string status = rig.reply_to("status");
  CHECK(status.find("report=trace divider=0 sent=") != std::string::npos);
  CHECK(status.find(" dropped=40 ") != std::string::npos);
}

TEST_CASE("flight recorder: the last 5 s before a tilt cutoff, frozen at the latch, sent by trace dump, re-armed") {
  BalanceRig rig;
  arm(rig);
  rig.run_ms(6000);
  rig.pitch = 40.0F;
  rig.rate = 0.0F;
  for (int i = 0; i < 3000 && rig.board->state() == RobotState::balance; ++i) rig.tick();  // the filter follows
  REQUIRE(rig.board->state() == RobotState::tilt_cutoff);
  const auto& ring = rig.board->recorder();
  CHECK(ring.frozen());
  CHECK(ring.size() == 5000);
  rig.run_ms(1000);  // a second after the fall: the ring still holds the seconds before it
  rig.console.tx.clear();
  rig.type("trace dump");
  for (int i = 0; i < 200 && rig.console.text().find("trace dump end") == std::string::npos; ++i) rig.tick();
  std::string text;
  const auto r = records(rig.console.tx, &text);
  REQUIRE(r.size() == 5000);
  CHECK(text.find("trace dump: 5000 records, frozen at ") == 0);
  CHECK(text.find(" ms by TILT_CUTOFF\n") != std::string::npos);
  CHECK(text.find("trace dump end: 5000 records\nok\n") != std::string::npos);
  for (std::size_t i = 1; i < r.size(); ++i) CHECK(r[i].seq == r[i - 1].seq + 1);
  CHECK(r.back().state == static_cast<std::uint8_t>(RobotState::tilt_cutoff));  // the latch's own iteration
  CHECK(r[r.size() - 2].state == static_cast<std::uint8_t>(RobotState::balance));
  CHECK(r.back().pitch_x100 > 2500);
  CHECK(r.front().time_us == r.back().time_us - 4'999'000);

  CHECK(rig.reply_to("trace arm") == "ok\n");
  CHECK_FALSE(rig.board->recorder().frozen());
  rig.run_ms(10);
  CHECK(rig.board->recorder().size() == 11);
}

TEST_CASE("flight recorder: a latch while disarmed does not freeze it, ESTOP while armed does") {
  BalanceRig rig;
  rig.run_ms(30);
  rig.reply_to("estop");
  rig.run_ms(10);
  CHECK(rig.board->state() == RobotState::estop);
  CHECK_FALSE(rig.board->recorder().frozen());
  rig.reply_to("disarm");
  arm(rig);
  rig.run_ms(100);
  rig.reply_to("estop");
  CHECK(rig.board->recorder().frozen());
  CHECK(std::string(rig.board->recorder().why()) == "ESTOP");
}

TEST_CASE("excite: refused outside BALANCE with the reason, bad arguments refused with the rule") {
  BalanceRig rig;
  rig.run_ms(30);
  CHECK(rig.reply_to("excite step 1 2") == "error: excite runs only in BALANCE (arm first) [not_allowed]\n");
  CHECK(rig.reply_to("excite step 2.5 2") ==
        "error: amplitude must be -2 to 2 degrees, not 0 (argument 2) [out_of_range]\n");
  CHECK(rig.reply_to("excite step 1 21").find("duration must be above 0 and at most 20 seconds") !=
        std::string::npos);
  CHECK(rig.reply_to("excite chirp 1 0.5 20").find("[missing_argument]") != std::string::npos);
  CHECK(rig.reply_to("excite chirp 1 0.5 200 5").find("frequency must be 0.05 to 100 Hz") != std::string::npos);
  CHECK(rig.reply_to("excite wobble 1 2").find("[unknown_command]") != std::string::npos);
  CHECK(rig.reply_to("trace on 0").find("[out_of_range]") != std::string::npos);
  CHECK(rig.reply_to("trace on 2.5").find("[out_of_range]") != std::string::npos);
  CHECK(rig.reply_to("TRACE off") == "ok\n");
  CHECK(rig.reply_to("help").find("excite chirp A F0 F1 D") != std::string::npos);
  CHECK(rig.board->excitation() == trace::Excite::none);
}

TEST_CASE("excite step: on the setpoint in BALANCE, in the trace, it ends by itself, ESTOP ends it in that iteration") {
  BalanceRig rig;
  arm(rig);
  rig.run_ms(100);
  const std::int16_t base = rig.board->last_trace().setpoint_x100;
  CHECK(rig.reply_to("excite step 1.5 0.5") == "ok\n");
  CHECK(rig.board->excitation() == trace::Excite::step);
  CHECK(rig.board->last_trace().excite == 1);
  CHECK(rig.board->last_trace().excite_x100 == 150);
  CHECK(rig.board->last_trace().setpoint_x100 == base + 150);
  rig.run_ms(600);
  CHECK(rig.board->excitation() == trace::Excite::none);  // 0.5 s are over
  CHECK(rig.board->last_trace().excite_x100 == 0);

  rig.reply_to("excite prbs 1 10");
  rig.run_ms(100);
  CHECK(std::fabs(std::fabs(rig.board->excitation_deg()) - 1.0F) < 1e-6F);
  rig.type("estop");
  rig.tick();
  CHECK(rig.board->state() == RobotState::estop);
  CHECK(rig.board->excitation() == trace::Excite::none);
  CHECK(rig.board->last_trace().excite == 0);
  CHECK(rig.board->last_trace().excite_x100 == 0);
}

TEST_CASE("excite: a latch, a disarm and a re-arm in one iteration leave no test signal behind") {
  BalanceRig rig;
  arm(rig);
  rig.reply_to("excite step 1 10");
  REQUIRE(rig.board->excitation() == trace::Excite::step);
  // One iteration: the console disarms and arms again. The signal must not survive into the new run.
  rig.type("disarm");
  rig.type("arm");
  rig.tick();
  CHECK(rig.board->state() == RobotState::balance);
  CHECK(rig.board->excitation() == trace::Excite::none);
}

TEST_CASE("excite: a radio stick or an Orin request beyond the dead band stops it at once, or refuses it") {
  BalanceRig rig;
  arm(rig);
  rig.reply_to("excite chirp 1 0.5 5 10");
  rig.run_ms(20);
  REQUIRE(rig.board->excitation() == trace::Excite::chirp);
  rig.rc.throttle = 20;  // inside the dead band (30 permille)
  rig.run_ms(20);
  CHECK(rig.board->excitation() == trace::Excite::chirp);
  rig.rc.throttle = 0;
  rig.rc.steer = 31;
  rig.run_ms(20);
  CHECK(rig.board->excitation() == trace::Excite::none);
  CHECK(rig.reply_to("excite step 1 2") ==
        "error: a speed or steering request is active (sticks centred, Orin at 0) [not_allowed]\n");
  rig.rc.steer = 0;
  rig.run_ms(20);
  rig.orin_on = true;
  rig.velocity = {0, 0};
  rig.run_ms(60);
  CHECK(rig.reply_to("excite step 1 2") == "ok\n");
  rig.velocity = {100, 0};  // 100 mm/s
  rig.run_ms(60);
  CHECK(rig.board->excitation() == trace::Excite::none);
}

TEST_CASE("excite chirp: the offset follows the closed form A sin(2 pi (f0 t + (f1 - f0) t^2 / 2T))") {
  BalanceRig rig;
  arm(rig);
  const TimeUs start = rig.now + 1000;  // the command is handled in the next iteration
  rig.reply_to("excite chirp 2 1 9 4");
  for (int i = 0; i < 3000; ++i) {
    rig.tick();
    const double t = static_cast<double>(rig.now - start) * 1e-6;
    const double expected = 2.0 * std::sin(2.0 * M_PI * (1.0 * t + (9.0 - 1.0) * t * t / (2.0 * 4.0)));
    REQUIRE(std::fabs(rig.board->excitation_deg() - expected) < 2e-3);
  }
}

TEST_CASE("excite: refused below the minimum speed cap with the fix named, and a cap lowered while it runs ends it") {
  // The cap the simulator showed too low (docs/tuning.md): speed_limit 10 and 40 %, each refused with its fix.
  for (const int low : {10, 40}) {
    BalanceRig rig;
    arm(rig, low);
    CHECK(rig.reply_to("excite step 1 2") == "error: excite needs the speed cap >= 50 % (speed_limit is " +
                                                 std::to_string(low) +
                                                 " %: disarm, raise it to 50 one 10 % step at a time, arm again) "
                                                 "[not_allowed]\n");
    CHECK(rig.board->excitation() == trace::Excite::none);
    CHECK(rig.board->last_trace().excite == 0);
  }
  BalanceRig rig;
  arm(rig);  // 50 %: exactly the minimum runs
  CHECK(rig.reply_to("excite chirp 1 0.5 5 10") == "ok\n");
  rig.run_ms(20);
  REQUIRE(rig.board->excitation() == trace::Excite::chirp);
  // Lowering the cap is allowed while armed: the iteration that reads it ends the signal.
  rig.type("speed_limit 40");
  rig.tick();
  CHECK(rig.board->speed_limit_pct() == 40);
  CHECK(rig.board->excitation() == trace::Excite::none);
  CHECK(rig.board->last_trace().excite == 0);
  CHECK(rig.board->state() == RobotState::balance);  // the robot keeps balancing; only the signal ends

  // The Orin's 0x303 max speed lowers the cap too: 1000 mm/s (50 % of 2000) runs, 999 ends it and is named.
  BalanceRig orin;
  arm(orin);
  orin.can.rx.push_back(saulcan::encode(saulcan::ConfigCmd{2500, 1000}));
  orin.run_ms(5);
  CHECK(orin.reply_to("excite prbs 1 10") == "ok\n");
  orin.run_ms(20);
  REQUIRE(orin.board->excitation() == trace::Excite::prbs);
  orin.can.rx.push_back(saulcan::encode(saulcan::ConfigCmd{2500, 999}));
  orin.tick();
  CHECK(orin.board->speed_cap_mmps() == 999);
  CHECK(orin.board->excitation() == trace::Excite::none);
  CHECK(orin.reply_to("excite step 1 2") ==
        "error: excite needs the speed cap >= 50 % (the Orin's 0x303 max speed holds it at 999 mm/s) [not_allowed]\n");
}

TEST_CASE("excite: refused above the maximum speed cap with the fix named; 90 % runs, and so does 100 % held to "
          "1800 mm/s by the Orin") {
  // The full cap is where the simulated robot fell coming back from a test signal (trace::kExciteMaxCapPct).
  BalanceRig rig;
  arm(rig, 100);
  CHECK(rig.reply_to("excite step 1 2") ==
        "error: excite needs the speed cap <= 90 % (speed_limit is 100 %: disarm, lower it to 90, arm again) "
        "[not_allowed]\n");
  CHECK(rig.board->excitation() == trace::Excite::none);
  CHECK(rig.board->last_trace().excite == 0);
  BalanceRig ninety;
  arm(ninety, 90);  // exactly the maximum runs
  CHECK(ninety.reply_to("excite step 1 2") == "ok\n");
  ninety.run_ms(5);
  CHECK(ninety.board->excitation() == trace::Excite::step);
  // The rule is on the cap in force: the Orin's 0x303 holding a 100 % speed_limit at 1800 mm/s (90 %) allows it.
  BalanceRig orin;
  arm(orin, 100);
  orin.can.rx.push_back(saulcan::encode(saulcan::ConfigCmd{2500, 1800}));
  orin.run_ms(5);
  CHECK(orin.reply_to("excite prbs 1 10") == "ok\n");
  orin.run_ms(5);
  CHECK(orin.board->excitation() == trace::Excite::prbs);
}
