// USB console: every command, every rejection with its reason and argument index, the limits at their
// boundaries, and the report=... lines read back exactly.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <string_view>

#include "saulproto/core/console.hpp"

using namespace saul;
using namespace saul::console;

namespace {

Command ok(std::string_view line) {
  const ParseResult r = parse(line);
  INFO("line \"" << std::string(line) << "\": " << to_string(r.error.reason) << " " << r.error.message);
  REQUIRE(r.ok());
  return r.command;
}

ParseError rejected(std::string_view line) {
  const ParseResult r = parse(line);
  INFO("line \"" << std::string(line) << "\"");
  REQUIRE_FALSE(r.ok());
  REQUIRE(r.error.message != nullptr);
  CHECK(std::strlen(r.error.message) > 0);
  return r.error;
}

std::uint16_t tilt(std::string_view arg) {
  const Command c = ok("tilt_limit " + std::string(arg));
  REQUIRE(std::holds_alternative<TiltLimitCmd>(c));
  return std::get<TiltLimitCmd>(c).tilt_limit_x100;
}

std::string text_of(Result<std::size_t> n, const std::array<char, kMaxReply>& buf) {
  REQUIRE(n.ok());
  CHECK(buf[*n] == '\0');
  return std::string(buf.data(), *n);
}

std::string real(float v) {
  std::array<char, 64> buf{};
  TextWriter w(buf);
  w.real(v);
  auto n = w.finish();
  REQUIRE(n.ok());
  return std::string(buf.data(), *n);
}

}  // namespace

TEST_CASE("console: every command without arguments parses to its own type") {
  CHECK(std::holds_alternative<HelpCmd>(ok("help")));
  CHECK(std::holds_alternative<StatusCmd>(ok("status")));
  CHECK(std::holds_alternative<ArmCmd>(ok("arm")));
  CHECK(std::holds_alternative<DisarmCmd>(ok("disarm")));
  CHECK(std::holds_alternative<EstopCmd>(ok("estop")));
  CHECK(std::holds_alternative<CanStatsCmd>(ok("can_stats")));
  CHECK(std::holds_alternative<UartStatsCmd>(ok("uart_stats")));
  CHECK(std::holds_alternative<RebootCmd>(ok("reboot")));
  for (const auto& spec : kCommands) {
    INFO(spec.name);
    CHECK(spec_of(spec.verb).name == spec.name);
    if (spec.arguments == 0) {
      const Command c = ok(spec.name);
      CHECK(verb_of(c) == spec.verb);
      CHECK(std::string_view(name_of(c)) == spec.name);
    }
  }
}

TEST_CASE("console: whitespace, line endings and case") {
  CHECK(std::holds_alternative<StatusCmd>(ok("  status\r\n")));
  CHECK(std::holds_alternative<StatusCmd>(ok("\tSTATUS\t")));
  CHECK(std::holds_alternative<EstopCmd>(ok("EStop\n")));
  CHECK(std::get<PidCmd>(ok("pid   1\t2  3\r")) == PidCmd{1.0F, 2.0F, 3.0F});
}

TEST_CASE("console: pid takes three finite, non-negative decimals") {
  CHECK(std::get<PidCmd>(ok("pid 1.5 0.02 0.3")) == PidCmd{1.5F, 0.02F, 0.3F});
  CHECK(std::get<PidCmd>(ok("pid 0 0 0")) == PidCmd{0.0F, 0.0F, 0.0F});
  CHECK(std::get<PidCmd>(ok("pid 1e-3 .5 5.")) == PidCmd{0.001F, 0.5F, 5.0F});
  CHECK(std::get<PidCmd>(ok("pid +2 2E2 12.5e-1")) == PidCmd{2.0F, 200.0F, 1.25F});
  CHECK(std::get<PidCmd>(ok("pid 0000.0100 123456.78 3.4e38")) == PidCmd{0.01F, 123456.78F, 3.4e38F});
  const PidCmd zero = std::get<PidCmd>(ok("pid -0 -0.0 0"));
  CHECK_FALSE(std::signbit(zero.kp));  // "-0" is stored as +0
  CHECK_FALSE(std::signbit(zero.ki));
}

TEST_CASE("console: pid rejections name the argument") {
  auto e = rejected("pid");
  CHECK(e.reason == Reason::missing_argument);
  CHECK(e.argument == 1);
  REQUIRE(e.command != nullptr);
  CHECK(e.command->verb == Verb::pid);
  e = rejected("pid 1 2");
  CHECK(e.reason == Reason::missing_argument);
  CHECK(e.argument == 3);
  e = rejected("pid 1 2 3 4");
  CHECK(e.reason == Reason::extra_argument);
  CHECK(e.argument == 4);
  e = rejected("pid 1 abc 3");
  CHECK(e.reason == Reason::not_a_number);
  CHECK(e.argument == 2);
  e = rejected("pid 1 2 -0.5");
  CHECK(e.reason == Reason::negative);
  CHECK(e.argument == 3);
  e = rejected("pid nan 1 1");
  CHECK(e.reason == Reason::not_finite);
  CHECK(e.argument == 1);
  CHECK(rejected("pid 1 INF 1").reason == Reason::not_finite);
  CHECK(rejected("pid 1 1 -infinity").reason == Reason::not_finite);
  e = rejected("pid 1e39 1 1");
  CHECK(e.reason == Reason::out_of_range);
  CHECK(e.argument == 1);
  for (const char* bad : {"1.2.3", "1e", "1e+", "e5", ".", "-", "+-1", "--1", "0x10", "1,5", "1f", "1_000"}) {
    INFO(bad);
    e = rejected(std::string("pid 1 1 ") + bad);
    CHECK(e.reason == Reason::not_a_number);
    CHECK(e.argument == 3);
  }
}

TEST_CASE("console: tilt_limit 5..25 degrees, exact at the boundaries, never clamped") {
  CHECK(tilt("5") == 500);
  CHECK(tilt("5.00") == 500);
  CHECK(tilt("25") == 2500);
  CHECK(tilt("25.000") == 2500);
  CHECK(tilt("12.5") == 1250);
  CHECK(tilt("2.5e1") == 2500);
  CHECK(tilt("12.344") == 1234);  // rounded half up to 0.01 degree
  CHECK(tilt("12.345") == 1235);
  CHECK(tilt("24.996") == 2500);
  CHECK(tilt("5.001") == 500);
  for (const char* out : {"4.99", "4.999999", "25.01", "25.001", "25.0000000000000000000000001", "30", "0", "-10",
                          "-25", "1e3", "99999999999999999999999"}) {
    INFO(out);
    const auto e = rejected(std::string("tilt_limit ") + out);
    CHECK(e.reason == Reason::out_of_range);
    CHECK(e.argument == 1);
    CHECK(std::string_view(e.message) == "tilt limit must be 5 to 25 degrees");
  }
  CHECK(rejected("tilt_limit").reason == Reason::missing_argument);
  CHECK(rejected("tilt_limit 10 20").reason == Reason::extra_argument);
  CHECK(rejected("tilt_limit 10 20").argument == 2);
  CHECK(rejected("tilt_limit ten").reason == Reason::not_a_number);
  CHECK(rejected("tilt_limit nan").reason == Reason::not_finite);
}

TEST_CASE("console: speed_limit 10..100 in steps of 10") {
  for (unsigned pct = 10; pct <= 100; pct += 10)
    CHECK(std::get<SpeedLimitCmd>(ok("speed_limit " + std::to_string(pct))).percent == pct);
  CHECK(std::get<SpeedLimitCmd>(ok("speed_limit 50.0")).percent == 50);
  CHECK(std::get<SpeedLimitCmd>(ok("speed_limit 1e2")).percent == 100);
  for (const char* out : {"0", "5", "9.99", "110", "100.5", "-10", "1000000000000000000000"}) {
    INFO(out);
    const auto e = rejected(std::string("speed_limit ") + out);
    CHECK(e.reason == Reason::out_of_range);
    CHECK(e.argument == 1);
    CHECK(std::string_view(e.message) == "speed limit must be 10 to 100 percent");
  }
  for (const char* off_step : {"15", "55.5", "99", "10.1"}) {
    INFO(off_step);
    const auto e = rejected(std::string("speed_limit ") + off_step);
    CHECK(e.reason == Reason::out_of_range);
    CHECK(std::string_view(e.message) == "speed limit must be a multiple of 10");
  }
  CHECK(rejected("speed_limit").reason == Reason::missing_argument);
  CHECK(rejected("speed_limit 10 %").reason == Reason::extra_argument);
  CHECK(rejected("speed_limit 10%").reason == Reason::not_a_number);
}

TEST_CASE("console: unknown commands, blank lines, extra arguments to plain commands") {
  auto e = rejected("fly");
  CHECK(e.reason == Reason::unknown_command);
  CHECK(e.argument == 0);
  CHECK(e.command == nullptr);
  CHECK(rejected("statuss").reason == Reason::unknown_command);
  CHECK(rejected("tilt-limit 10").reason == Reason::unknown_command);
  e = rejected("");
  CHECK(e.reason == Reason::syntax);
  CHECK(std::string_view(e.message) == "empty line");
  CHECK(rejected(" \t\r\n").reason == Reason::syntax);
  for (const auto& spec : kCommands) {
    if (spec.arguments != 0) continue;
    INFO(spec.name);
    e = rejected(std::string(spec.name) + " now");
    CHECK(e.reason == Reason::extra_argument);
    CHECK(e.argument == 1);
  }
}

TEST_CASE("console: error lines") {
  std::array<char, kMaxReply> buf{};
  auto n = format_error(parse("tilt_limit 30").error, buf);
  CHECK(text_of(n, buf) ==
        "error: tilt limit must be 5 to 25 degrees (argument 1; usage: tilt_limit <deg>) [out_of_range]\n");
  n = format_error(parse("frobnicate").error, buf);
  CHECK(text_of(n, buf) == "error: unknown command (try help) [unknown_command]\n");
  n = format_error(parse("pid 1 2").error, buf);
  CHECK(text_of(n, buf) == "error: missing argument (argument 3; usage: pid <Kp> <Ki> <Kd>) [missing_argument]\n");
  n = format_ok(buf);
  CHECK(text_of(n, buf) == "ok\n");
}

TEST_CASE("console: help lists every command with its usage") {
  std::array<char, kMaxReply> buf{};
  const std::string help = text_of(format_help(buf), buf);
  for (const auto& spec : kCommands) CHECK(help.find(spec.usage) != std::string::npos);
  CHECK(help.find("pid <Kp> <Ki> <Kd>   set PID gains") != std::string::npos);
  CHECK(std::count(help.begin(), help.end(), '\n') == static_cast<long>(kCommands.size()));
}

TEST_CASE("console: TextWriter numbers and overflow") {
  std::array<char, 64> buf{};
  TextWriter w(buf);
  w.unsigned_number(0).ch(' ').unsigned_number(4294967295U).ch(' ').signed_number(-2147483647 - 1).ch(' ');
  w.fixed(-123, 2).ch(' ').fixed(5, 3).ch(' ').fixed(2500, 2).ch(' ').fixed(7, 0);
  auto n = w.finish();
  REQUIRE(n.ok());
  CHECK(std::string(buf.data(), *n) == "0 4294967295 -2147483648 -1.23 0.005 25.00 7");

  std::array<char, 4> small{};
  TextWriter s(small);
  s.text("hello");
  CHECK(s.finish().reason() == Reason::buffer_too_small);
  CHECK(std::string(small.data()) == "hel");  // truncated, still NUL-terminated
  CHECK(TextWriter(std::span<char>{}).finish().reason() == Reason::buffer_too_small);
}

TEST_CASE("console: floats are written in their shortest exact form") {
  CHECK(real(0.0F) == "0");
  CHECK(real(-0.0F) == "0");
  CHECK(real(1.0F) == "1");
  CHECK(real(1.5F) == "1.5");
  CHECK(real(0.1F) == "0.1");
  CHECK(real(0.02F) == "0.02");
  CHECK(real(-2.25F) == "-2.25");
  CHECK(real(100.0F) == "100");
  CHECK(real(123456.78F) == "123456.78");
  CHECK(real(1e-5F) == "0.00001");
  CHECK(real(1.5e-7F) == "1.5e-7");
  CHECK(real(1e9F) == "1e9");
  CHECK(real(3.4028235e38F) == "3.4028235e38");
  CHECK(real(std::numeric_limits<float>::denorm_min()) == "1e-45");
  CHECK(real(std::numeric_limits<float>::quiet_NaN()) == "nan");
  CHECK(real(std::numeric_limits<float>::infinity()) == "inf");
  CHECK(real(-std::numeric_limits<float>::infinity()) == "-inf");
}

TEST_CASE("console: every float written reads back exactly (random bit patterns, fixed seed)") {
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::uint32_t> bits;
  int checked = 0;
  while (checked < 20000) {
    const float v = std::bit_cast<float>(bits(rng));
    if (!std::isfinite(v)) continue;
    ++checked;
    const std::string s = real(v);
    const auto back = parse_float(s);
    INFO(s);
    REQUIRE(back.ok());
    CHECK((*back == v));
    CHECK(s.size() <= 16);  // "-0.0000" and 9 digits
  }
}

TEST_CASE("console: status report=... line round-trips") {
  StatusReport r;
  r.board = Board::io;
  r.state = saulcan::RobotState::tilt_cutoff;
  r.pitch_x100 = -1234;
  r.pid_out = -1000;
  r.kp = 1.5F;
  r.ki = 0.02F;
  r.kd = 1.5e-7F;
  r.tilt_limit_x100 = 2000;
  r.speed_limit_pct = 30;
  r.faults = saulcan::fault::kRcLoss | saulcan::fault::kTiltCutoff;
  r.battery_mv = 36512;
  r.uptime_ms = 4294967295U;
  std::array<char, kMaxReply> buf{};
  const std::string line = text_of(format_kv(r, buf), buf);
  CHECK(line ==
        "report=status board=io state=TILT_CUTOFF pitch_x100=-1234 pid_out=-1000 kp=1.5 ki=0.02 kd=1.5e-7 "
        "tilt_limit_x100=2000 speed_limit_pct=30 faults=9 battery_mv=36512 uptime_ms=4294967295\n");
  const auto back = parse_status(line);
  REQUIRE(back.ok());
  CHECK(*back == r);

  // Extremes and every state.
  for (std::uint8_t s = 0; s <= 5; ++s) {
    StatusReport x;
    x.state = static_cast<saulcan::RobotState>(s);
    x.pitch_x100 = static_cast<std::int16_t>(s % 2 ? -32768 : 32767);
    x.kp = 3.4028235e38F;
    x.ki = std::numeric_limits<float>::denorm_min();
    x.faults = 0xFF;
    std::array<char, kMaxKvLine> kv{};
    auto n = format_kv(x, kv);
    REQUIRE(n.ok());
    const auto y = parse_status(std::string_view(kv.data(), *n));
    REQUIRE(y.ok());
    CHECK(*y == x);
  }
}

TEST_CASE("console: can_stats and uart_stats lines round-trip") {
  const CanStats c{4294967295U, 1200, 3, 1, 2, 5, 7, 255, 128};
  std::array<char, kMaxReply> buf{};
  const std::string line = text_of(format_kv(c, buf), buf);
  CHECK(line ==
        "report=can_stats tx=4294967295 rx=1200 errors=3 busoff=1 tx_failed=2 rx_missed=5 arb_lost=7 tec=255 rec=128\n");
  const auto back = parse_can_stats(line);
  REQUIRE(back.ok());
  CHECK(*back == c);

  interboard::Counters counters;
  counters.frames = 100;
  counters.crc_errors = 2;
  counters.length_errors = 3;
  counters.unknown_types = 4;
  counters.bytes_skipped = 50;
  const UartStats u = UartStats::from(counters);
  const std::string uline = text_of(format_kv(u, buf), buf);
  CHECK(uline == "report=uart_stats frames=100 crc_errors=2 length_errors=3 unknown_types=4 bytes_skipped=50\n");
  const auto uback = parse_uart_stats(uline);
  REQUIRE(uback.ok());
  CHECK(*uback == u);
  CHECK(parse_uart_stats("report=uart_stats frames=0 crc_errors=0 length_errors=0 unknown_types=0 bytes_skipped=0")
            ->frames == 0);
}

TEST_CASE("console: report=... parse errors and tolerance") {
  const std::string good = "report=uart_stats frames=1 crc_errors=2 length_errors=3 unknown_types=4 bytes_skipped=5";
  CHECK(parse_uart_stats(good + "\r\n").ok());
  CHECK(parse_uart_stats("  " + good + "   ").ok());
  // Unknown keys are skipped (a newer firmware may add some).
  const auto extra = parse_uart_stats(good + " tx_frames=9");
  REQUIRE(extra.ok());
  CHECK(extra->bytes_skipped == 5);
  // Keys in another order are fine.
  CHECK(parse_uart_stats("report=uart_stats bytes_skipped=5 frames=1 crc_errors=2 length_errors=3 unknown_types=4")
            .ok());

  CHECK(parse_uart_stats("").reason() == Reason::syntax);
  CHECK(parse_uart_stats("frames=1").reason() == Reason::syntax);
  CHECK(parse_uart_stats("report=can_stats tx=1").reason() == Reason::unknown_type);
  CHECK(parse_can_stats(good).reason() == Reason::unknown_type);
  CHECK(parse_uart_stats("report=uart_stats frames=1").reason() == Reason::missing_argument);
  CHECK(parse_uart_stats(good + " frames=1").reason() == Reason::syntax);  // a key twice
  CHECK(parse_uart_stats(good + " junk").reason() == Reason::syntax);
  CHECK(parse_uart_stats(good + " =3").reason() == Reason::syntax);
  CHECK(parse_uart_stats("report=uart_stats frames=x crc_errors=2 length_errors=3 unknown_types=4 bytes_skipped=5")
            .reason() == Reason::not_a_number);
  CHECK(parse_uart_stats("report=uart_stats frames=-1 crc_errors=2 length_errors=3 unknown_types=4 bytes_skipped=5")
            .reason() == Reason::not_a_number);
  CHECK(parse_uart_stats("report=uart_stats frames= crc_errors=2 length_errors=3 unknown_types=4 bytes_skipped=5")
            .reason() == Reason::not_a_number);
  CHECK(parse_uart_stats(
            "report=uart_stats frames=4294967296 crc_errors=2 length_errors=3 unknown_types=4 bytes_skipped=5")
            .reason() == Reason::out_of_range);

  std::array<char, kMaxKvLine> kv{};
  auto n = format_kv(StatusReport{}, kv);
  REQUIRE(n.ok());
  std::string status(kv.data(), *n);
  auto with = [&](std::string_view key, std::string_view value) {
    std::string s = status;
    const auto at = s.find(std::string(" ") + std::string(key) + "=");
    REQUIRE(at != std::string::npos);
    const auto end = s.find(' ', at + 1);
    s.replace(at, end - at, std::string(" ") + std::string(key) + "=" + std::string(value));
    return s;
  };
  CHECK(parse_status(with("faults", "256")).reason() == Reason::out_of_range);
  CHECK(parse_status(with("pitch_x100", "-32769")).reason() == Reason::out_of_range);
  CHECK(parse_status(with("pitch_x100", "-32768"))->pitch_x100 == -32768);
  CHECK(parse_status(with("state", "FLYING")).reason() == Reason::out_of_range);
  CHECK(parse_status(with("board", "orin")).reason() == Reason::out_of_range);
  CHECK(parse_status(with("kp", "1.2.3")).reason() == Reason::not_a_number);
  CHECK(std::isnan(parse_status(with("kp", "nan"))->kp));
}

TEST_CASE("console: human lines") {
  StatusReport r;
  r.state = saulcan::RobotState::balance;
  r.pitch_x100 = -123;
  r.pid_out = 45;
  r.kp = 1.5F;
  r.ki = 0.0F;
  r.kd = 0.25F;
  r.faults = saulcan::fault::kRcLoss | saulcan::fault::kEstop;
  r.battery_mv = 36512;
  r.uptime_ms = 12005;
  std::array<char, kMaxReply> buf{};
  CHECK(text_of(format_human(r, buf), buf) ==
        "board balance, state BALANCE\n"
        "pitch -1.23 deg, pid_out 45 permille\n"
        "pid kp 1.5, ki 0, kd 0.25\n"
        "tilt limit 25.00 deg, speed limit 10 %\n"
        "battery 36.512 V, faults rc_loss estop\n"
        "uptime 12.005 s\n");
  CHECK(text_of(format_human(CanStats{1, 2, 3, 4, 5, 6, 7, 8, 9}, buf), buf) ==
        "CAN: tx 1, rx 2, errors 3, busoff 4, tx_failed 5, rx_missed 6, arb_lost 7, tec 8, rec 9\n");
  CHECK(text_of(format_human(UartStats{1, 2, 3, 4, 5}, buf), buf) ==
        "UART: frames 1, crc_errors 2, length_errors 3, unknown_types 4, bytes_skipped 5\n");
}

TEST_CASE("console: the largest replies fit the documented buffer sizes") {
  StatusReport r;
  r.state = saulcan::RobotState::tilt_cutoff;
  r.pitch_x100 = -32768;
  r.pid_out = -32768;
  r.kp = r.ki = r.kd = -3.40282e-38F;
  r.tilt_limit_x100 = 65535;
  r.speed_limit_pct = 255;
  r.faults = 0xFF;
  r.battery_mv = 65535;
  r.uptime_ms = 4294967295U;
  std::array<char, kMaxKvLine> kv{};
  CHECK(format_kv(r, kv).ok());
  std::array<char, kMaxReply> buf{};
  CHECK(format_human(r, buf).ok());
  CHECK(format_help(buf).ok());
  const CanStats c{4294967295U, 4294967295U, 4294967295U, 4294967295U, 4294967295U, 4294967295U, 4294967295U,
                   65535, 65535};
  CHECK(format_kv(c, kv).ok());
}
