// The 0x301 stager: a tuning set is applied whole or not at all, within 100 ms of its first frame.
#include <catch2/catch.hpp>

#include <limits>

#include "saulproto/core/pid_stager.hpp"

using namespace saul::saulcan;
using Kind = StagerOutcome::Kind;

TEST_CASE("a complete set within the window is applied atomically, in any order") {
  PidStager s;
  CHECK(s.accept({Gain::kd, 9, 0.05F}, 1'000).kind == Kind::none);
  CHECK(s.accept({Gain::kp, 9, 1.5F}, 2'000).kind == Kind::none);
  CHECK(s.staging());
  auto out = s.accept({Gain::ki, 9, 0.25F}, 3'000);
  CHECK(out.kind == Kind::applied);
  CHECK(out.sequence == 9);
  CHECK(out.gains == PidGains{1.5F, 0.25F, 0.05F});
  CHECK_FALSE(s.staging());
}

TEST_CASE("the window is 100 ms from the first frame: at 100 ms applied, at 100.001 ms discarded") {
  PidStager a;
  a.accept({Gain::kp, 1, 1}, 0);
  a.accept({Gain::ki, 1, 1}, 50'000);
  CHECK(a.accept({Gain::kd, 1, 1}, 100'000).kind == Kind::applied);

  PidStager b;
  b.accept({Gain::kp, 1, 1}, 0);
  b.accept({Gain::ki, 1, 1}, 50'000);
  auto late = b.accept({Gain::kd, 1, 1}, 100'001);
  CHECK(late.kind == Kind::discarded);
  CHECK(late.result == AckResult::incomplete);
  CHECK(late.sequence == 1);
  CHECK(b.staging());  // the late frame started a new set of its own
}

TEST_CASE("an incomplete set is discarded by poll() once the window has passed") {
  PidStager s;
  s.accept({Gain::kp, 4, 1}, 10'000);
  CHECK(s.poll(110'000).kind == Kind::none);
  auto out = s.poll(110'001);
  CHECK(out.kind == Kind::discarded);
  CHECK(out.result == AckResult::incomplete);
  CHECK(out.sequence == 4);
  CHECK(s.poll(500'000).kind == Kind::none);  // reported once
}

TEST_CASE("interleaved sets: a new sequence number discards the staged one and starts its own") {
  PidStager s;
  s.accept({Gain::kp, 1, 1.0F}, 0);
  s.accept({Gain::ki, 1, 2.0F}, 1'000);
  auto ended = s.accept({Gain::kp, 2, 10.0F}, 2'000);
  CHECK(ended.kind == Kind::discarded);
  CHECK(ended.sequence == 1);
  CHECK(s.accept({Gain::ki, 2, 20.0F}, 3'000).kind == Kind::none);
  auto out = s.accept({Gain::kd, 2, 30.0F}, 4'000);
  CHECK(out.kind == Kind::applied);
  CHECK(out.gains == PidGains{10.0F, 20.0F, 30.0F});  // nothing of set 1 leaked in
}

TEST_CASE("a repeated index replaces the earlier value") {
  PidStager s;
  s.accept({Gain::kp, 3, 1.0F}, 0);
  s.accept({Gain::kp, 3, 2.0F}, 1);
  s.accept({Gain::ki, 3, 0.0F}, 2);
  auto out = s.accept({Gain::kd, 3, 0.0F}, 3);
  REQUIRE(out.kind == Kind::applied);
  CHECK(out.gains.kp == 2.0F);
}

TEST_CASE("non-finite and negative gains discard the whole set as out of range") {
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity(), -0.5F};
  for (float b : bad) {
    PidStager s;
    s.accept({Gain::kp, 5, 1.0F}, 0);
    s.accept({Gain::ki, 5, b}, 1);
    auto out = s.accept({Gain::kd, 5, 1.0F}, 2);
    CHECK(out.kind == Kind::discarded);
    CHECK(out.result == AckResult::out_of_range);
    CHECK(out.sequence == 5);
    CHECK_FALSE(s.staging());
  }
}

TEST_CASE("zero gains are valid") {
  PidStager s;
  s.accept({Gain::kp, 0, 0.0F}, 0);
  s.accept({Gain::ki, 0, 0.0F}, 0);
  CHECK(s.accept({Gain::kd, 0, 0.0F}, 0).kind == Kind::applied);
}
