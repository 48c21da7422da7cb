// core/quantity.hpp: the one reader of numbers with units, as parse_size, link rates, saulctl's --samplerate and
// --bitrate use it. Expected values written out by hand.
#include <catch2/catch.hpp>
#include <cstdint>
#include <optional>

#include "saulproto/core/quantity.hpp"

using saul::quantity::parse;
using saul::quantity::parse_duration_us;

TEST_CASE("parse_quantity: a positive number, a k/M/G prefix of the given kilo, then one of the units") {
  const auto bytes = [](const char* t) { return parse(t, {"iB", "B"}, 1024.0); };
  const auto hz = [](const char* t) { return parse(t, {"Hz", "hz"}, 1e3); };
  CHECK(bytes("4096") == std::optional<std::uint64_t>(4096));
  CHECK(bytes("64k") == std::optional<std::uint64_t>(65536));
  CHECK(bytes("64K") == std::optional<std::uint64_t>(65536));
  CHECK(bytes("64kB") == std::optional<std::uint64_t>(65536));
  CHECK(bytes("2MiB") == std::optional<std::uint64_t>(2097152));
  CHECK(bytes("1.5G") == std::optional<std::uint64_t>(1610612736));
  CHECK(bytes("10B") == std::optional<std::uint64_t>(10));
  CHECK(hz("1MHz") == std::optional<std::uint64_t>(1000000));
  CHECK(hz("10M") == std::optional<std::uint64_t>(10000000));
  CHECK(hz("2.5khz") == std::optional<std::uint64_t>(2500));
  CHECK(hz("500000") == std::optional<std::uint64_t>(500000));
  CHECK(hz("0.4") == std::optional<std::uint64_t>(0));  // positive, rounded: the caller judges 0
  for (const char* bad : {"", "k", "M", "0", "-1", "1X", "1m", "1 M", "1MB", "1e30G", "nan", "Hz"})
    CHECK_FALSE(hz(bad).has_value());
  for (const char* bad : {"", "0k", "-5M", "1T", "1Hz", "1kk", "1e30"}) CHECK_FALSE(bytes(bad).has_value());
}

TEST_CASE("parse_duration_us: a number and us, ms, s (or none), m or min") {
  CHECK(parse_duration_us("500ms") == std::optional<std::uint64_t>(500'000));
  CHECK(parse_duration_us("2s") == std::optional<std::uint64_t>(2'000'000));
  CHECK(parse_duration_us("1.5") == std::optional<std::uint64_t>(1'500'000));
  CHECK(parse_duration_us("250us") == std::optional<std::uint64_t>(250));
  CHECK(parse_duration_us("1m") == std::optional<std::uint64_t>(60'000'000));
  CHECK(parse_duration_us("2min") == std::optional<std::uint64_t>(120'000'000));
  CHECK(parse_duration_us("0s") == std::optional<std::uint64_t>(0));
  for (const char* bad : {"", "s", "-1s", "1h", "1 s", "5sec", "nan", "1e300m"}) CHECK_FALSE(parse_duration_us(bad).has_value());
}
