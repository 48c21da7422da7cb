// Replay scheduling on a fake clock: absolute deadlines (no drift), speed, loops, long gaps, single step;
// lateness statistics; filters, id remapping and the motion rule.
#include <catch2/catch.hpp>

#include <cstdio>
#include <initializer_list>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/replay/replay.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

constexpr std::uint64_t kMs = 1'000'000ULL;
constexpr std::uint64_t kStart = 5'000 * kMs;  // the fake clock's time when a replay starts

CanFrame frame(std::uint32_t id, bool extended, std::initializer_list<std::uint8_t> bytes) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  return f;
}

/// Time moves only when the replay waits (to the deadline, or later by `oversleep`) or sends (by send_cost).
struct FakeClock final : ReplayClock {
  std::uint64_t now = kStart;
  std::uint64_t oversleep = 0;
  std::vector<std::uint64_t> deadlines;
  std::uint64_t now_ns() override { return now; }
  bool sleep_until(std::uint64_t deadline) override {
    deadlines.push_back(deadline);
    if (deadline > now) now = deadline + oversleep;
    return true;
  }
};

/// A candump log held in memory, opened afresh for every pass.
struct Log {
  explicit Log(std::string t) : text(std::move(t)) {}
  std::string text;
  std::vector<std::unique_ptr<std::istringstream>> streams;
  std::function<std::unique_ptr<CaptureReader>()> opener() {
    return [this] {
      streams.push_back(std::make_unique<std::istringstream>(text));
      return std::unique_ptr<CaptureReader>(std::make_unique<CandumpReader>(*streams.back()));
    };
  }
};

std::vector<std::uint64_t> relative(const std::vector<std::uint64_t>& v) {
  std::vector<std::uint64_t> out;
  for (auto x : v) out.push_back(x - kStart);
  return out;
}

}  // namespace

TEST_CASE("deadlines are absolute: a slow link makes frames late, never the schedule") {
  Log log{"(100.000000) can0 400#01\n(100.010000) can0 400#02\n(100.030000) can0 400#03\n"
          "(100.030000) can0 400#04\n(100.100000) can0 400#05\n"};
  FakeClock clock;
  std::vector<std::uint64_t> sent_at;
  ReplayHooks hooks;
  hooks.send = [&](const CanFrame&) {
    sent_at.push_back(clock.now - kStart);
    clock.now += 15 * kMs;  // every send takes 15 ms
  };
  const ReplayReport r = replay(log.opener(), ReplayOptions{}, clock, hooks);
  CHECK(r.sent == 5);
  CHECK(relative(clock.deadlines) == std::vector<std::uint64_t>{0, 10 * kMs, 30 * kMs, 30 * kMs, 100 * kMs});
  // sends start at 0, 15 (5 late), 30, 45 (15 late), 100
  CHECK(sent_at == std::vector<std::uint64_t>{0, 15 * kMs, 30 * kMs, 45 * kMs, 100 * kMs});
  CHECK(r.lateness.count() == 5);
  CHECK(r.lateness.max_ns() == 15 * kMs);
  CHECK(r.lateness.over_1ms() == 2);
  CHECK(r.lateness.percentile_ns(50) <= 1'000);      // three frames on time: the 0..1 us bin
  CHECK(r.lateness.percentile_ns(99) == 15 * kMs);   // capped at the exact maximum
  CHECK(r.elapsed_ns == 115 * kMs);                  // first deadline to the end of the last send
}

TEST_CASE("a small oversleep on every frame does not accumulate") {
  std::string text;  // 1000 frames 10 ms apart
  for (int i = 0; i < 1000; ++i) {
    char line[64];
    std::snprintf(line, sizeof line, "(%d.%06d) can0 300#00\n", 1000 + i / 100, (i % 100) * 10000);
    text += line;
  }
  Log log{text};
  FakeClock clock;
  clock.oversleep = 40'000;  // the OS wakes us 40 us late every time
  ReplayHooks hooks;
  hooks.send = [](const CanFrame&) {};
  ReplayOptions options;
  options.allow_motion = true;
  const ReplayReport r = replay(log.opener(), options, clock, hooks);
  REQUIRE(clock.deadlines.size() == 1000);
  CHECK(clock.deadlines.back() - kStart == 9'990 * kMs);  // frame 999 is due at 9.99 s, as logged
  CHECK(r.lateness.max_ns() == 40'000);
  CHECK(r.lateness.percentile_ns(99) == 40'000);
  CHECK(r.lateness.over_1ms() == 0);
}

TEST_CASE("speed, loops, long gaps and timestamps that go backwards") {
  FakeClock clock;
  ReplayHooks hooks;
  hooks.send = [](const CanFrame&) {};
  SECTION("twice as fast") {
    Log log{"(1.000000) can0 400#\n(1.010000) can0 400#\n(1.030000) can0 400#\n"};
    ReplayOptions o;
    o.speed = 2;
    replay(log.opener(), o, clock, hooks);
    CHECK(relative(clock.deadlines) == std::vector<std::uint64_t>{0, 5 * kMs, 15 * kMs});
  }
  SECTION("three passes continue one mean interval after the last frame") {
    Log log{"(1.000000) can0 400#\n(1.010000) can0 400#\n(1.020000) can0 400#\n"};
    ReplayOptions o;
    o.loops = 3;
    const auto r = replay(log.opener(), o, clock, hooks);
    CHECK(r.passes == 3);
    CHECK(r.sent == 9);
    CHECK(relative(clock.deadlines) ==
          std::vector<std::uint64_t>{0, 10 * kMs, 20 * kMs, 30 * kMs, 40 * kMs, 50 * kMs, 60 * kMs, 70 * kMs, 80 * kMs});
  }
  SECTION("an hour of silence shortened to --max-gap, a step back in time sent at once") {
    Log log{"(1.000000) can0 400#\n(3601.000000) can0 400#\n(3600.500000) can0 400#\n(3600.600000) can0 400#\n"};
    ReplayOptions o;
    o.max_gap_ns = 1'000 * kMs;
    replay(log.opener(), o, clock, hooks);
    CHECK(relative(clock.deadlines) == std::vector<std::uint64_t>{0, 1'000 * kMs, 1'000 * kMs, 1'100 * kMs});
  }
  SECTION("as fast as possible: nothing waits, no lateness") {
    Log log{"(1.000000) can0 400#\n(2.000000) can0 400#\n"};
    ReplayOptions o;
    o.speed = 0;
    const auto r = replay(log.opener(), o, clock, hooks);
    CHECK(r.sent == 2);
    CHECK(clock.deadlines.empty());
    CHECK(r.lateness.count() == 0);
  }
}

TEST_CASE("single step: one frame per answer, no timing, q stops") {
  Log log{"(1.000000) can0 400#01\n(1.500000) can0 400#02\n(2.000000) can0 400#03\n"};
  FakeClock clock;
  int asked = 0;
  std::vector<std::uint8_t> sent;
  ReplayHooks hooks;
  hooks.send = [&](const CanFrame& f) { sent.push_back(f.data[0]); };
  hooks.step = [&](const CanFrame&) {
    clock.now += 7 * kMs;  // the user takes a while
    return ++asked < 3;    // "q" at the third frame
  };
  const auto r = replay(log.opener(), ReplayOptions{}, clock, hooks);
  CHECK(asked == 3);
  CHECK(sent == std::vector<std::uint8_t>{1, 2});
  CHECK(r.stopped);
  CHECK(clock.deadlines.empty());
  CHECK(r.lateness.count() == 0);
}

TEST_CASE("frames that can move motors") {
  CHECK(can_move_motors(frame(0x300, false, {0, 0, 0, 0})));
  CHECK(can_move_motors(frame(0x302, false, {1})));   // balance
  CHECK(can_move_motors(frame(0x302, false, {2})));   // manual
  CHECK_FALSE(can_move_motors(frame(0x302, false, {0})));  // off
  CHECK_FALSE(can_move_motors(frame(0x302, false, {3})));  // estop stops them
  CHECK_FALSE(can_move_motors(frame(0x301, false, {0, 1, 0, 0, 0, 0, 0xC0, 0x3F})));
  CHECK_FALSE(can_move_motors(frame(0x400, false, {0, 0, 0, 0, 0, 0, 1})));
  for (std::uint32_t command : {0U, 1U, 2U, 3U, 4U, 10U, 11U, 12U, 13U})
    CHECK(can_move_motors(frame(command << 8 | 68, true, {0, 0, 0, 0})));
  for (std::uint32_t command : {5U, 9U, 14U, 16U, 27U})
    CHECK_FALSE(can_move_motors(frame(command << 8 | 68, true, {0, 0, 0, 0})));
  CanFrame rtr = frame(0x300, false, {});
  rtr.remote = true;
  CHECK_FALSE(can_move_motors(rtr));
}

TEST_CASE("filters apply to the logged id, then the map, then the motion rule") {
  ReplayOptions o;
  o.exclude.push_back(parse_id_filter("401"));
  o.mappings.push_back(parse_id_mapping("300=310"));
  o.mappings.push_back(parse_id_mapping("400=0x00000500"));
  CanFrame out;
  CHECK(plan_frame(frame(0x300, false, {1, 0, 0, 0}), o, out) == ReplayVerdict::send);  // 0x310 moves nothing
  CHECK(out.id == 0x310);
  CHECK(plan_frame(frame(0x400, false, {1}), o, out) == ReplayVerdict::send);
  CHECK(out.id == 0x500);
  CHECK(out.extended);
  CHECK(plan_frame(frame(0x401, false, {1}), o, out) == ReplayVerdict::filtered);
  CHECK(plan_frame(frame(0x302, false, {1}), o, out) == ReplayVerdict::motion_dropped);
  CHECK(plan_frame(frame(0x344, true, {0, 0, 0, 1}), o, out) == ReplayVerdict::motion_dropped);
  o.allow_motion = true;
  CHECK(plan_frame(frame(0x302, false, {1}), o, out) == ReplayVerdict::send);
  o.include.push_back(parse_id_filter("0x400:0x7F0"));  // 0x400..0x40F only
  CHECK(plan_frame(frame(0x302, false, {1}), o, out) == ReplayVerdict::filtered);
  CHECK(plan_frame(frame(0x402, false, {1, 0, 0}), o, out) == ReplayVerdict::send);
  CanFrame err = frame(0x040, false, {0, 0, 0, 0, 0, 0, 0, 0});
  err.error = true;
  CHECK(plan_frame(err, o, out) == ReplayVerdict::error_frame);

  CHECK_THROWS_AS(parse_id_mapping("300"), std::invalid_argument);
  CHECK_THROWS_AS(parse_id_mapping("300=xyz"), std::invalid_argument);
  CHECK_THROWS_AS(parse_id_filter("123456789"), std::invalid_argument);
  const auto m = parse_id_mapping("00000344=345");
  CHECK(m.from_extended);
  CHECK_FALSE(m.to_extended);
}

TEST_CASE("a replay counts what it did not send, and the preview counts motion frames") {
  Log log{"(1.000000) can0 300#00000000\n(1.010000) can0 400#01\n(1.020000) can0 20000040#0000000000000000\n"
          "(1.030000) can0 00000344#00000001\nbroken line\n(1.040000) can0 401#02\n"};
  ReplayOptions o;
  o.exclude.push_back(parse_id_filter("401"));
  auto reader = log.opener()();
  const auto p = preview_replay(reader, o);
  CHECK(p.to_send == 3);
  CHECK(p.motion == 2);

  FakeClock clock;
  std::vector<std::uint32_t> ids;
  ReplayHooks hooks;
  hooks.send = [&](const CanFrame& f) { ids.push_back(f.id); };
  const auto r = replay(log.opener(), o, clock, hooks);
  CHECK(ids == std::vector<std::uint32_t>{0x400});
  CHECK(r.frames == 5);
  CHECK(r.motion_dropped == 2);
  CHECK(r.filtered == 1);
  CHECK(r.error_frames == 1);
  CHECK(r.corrupt == 0);  // "broken line" has no '(': a comment, as canplayer reads it
  CHECK(relative(clock.deadlines) == std::vector<std::uint64_t>{0});  // the first frame sent anchors the schedule
}

TEST_CASE("lateness bins") {
  LatenessStats s;
  CHECK(s.percentile_ns(50) == 0);
  for (int i = 0; i < 98; ++i) s.add(25'300);  // 25.3 us
  s.add(2'345'678);                           // 2.3 ms
  s.add(-500);                                // early counts as on time
  CHECK(s.count() == 100);
  CHECK(s.percentile_ns(50) == 26'000);  // upper edge of the 25..26 us bin
  CHECK(s.percentile_ns(99) == 26'000);
  CHECK(s.percentile_ns(100) == 2'345'678);
  CHECK(s.max_ns() == 2'345'678);
  CHECK(s.over_1ms() == 1);
}
