// CAN id filters (can_link.hpp, can_filter.cpp): parse_can_id against std::stoul over random spellings, and passes()
// against the rule written out here, over random filters and frames. Seeded: a failure replays.
#include <catch2/catch.hpp>
#include <cctype>
#include <random>
#include <stdexcept>
#include <string>

#include "saulproto/host/link/can_link.hpp"

using namespace saul;
using namespace saul::host;

TEST_CASE("parse_can_id reads 1 to 8 hex digits of either case, 0x allowed, as std::stoul does") {
  std::mt19937 rng(20261129);
  const std::string digits = "0123456789abcdefABCDEF";
  for (int n = 0; n < 20000; ++n) {
    const int len = 1 + static_cast<int>(rng() % 8);
    std::string hex;
    for (int i = 0; i < len; ++i) hex += digits[rng() % digits.size()];
    const std::string text = (rng() % 4 == 0 ? "0x" : "") + hex;
    const unsigned long want = std::stoul(hex, nullptr, 16);
    bool extended = false;
    if (want > 0x1FFFFFFFUL) {
      CHECK_THROWS_AS(parse_can_id(text, text, extended), std::invalid_argument);
      continue;
    }
    const std::uint32_t got = parse_can_id(text, text, extended);
    INFO(text);
    CHECK(got == want);
    CHECK(extended == (len > 3 || want > 0x7FFUL));  // the width it is written in, or a value only 29 bits hold
  }
}

TEST_CASE("parse_can_id refuses what is not an id, quoting the option's whole value") {
  bool extended = false;
  for (const char* bad : {"", "0x", "123456789", "12G", "-1", " 12", "3 0", "0x1FFFFFFFF"})
    CHECK_THROWS_AS(parse_can_id(bad, "WHOLE", extended), std::invalid_argument);
  try {
    parse_can_id("12G", "--id 12G", extended);
    FAIL("no throw");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()) == "bad CAN id '12G' in '--id 12G': ids are hex");
  }
  CHECK(parse_can_id("1FFFFFFF", "", extended) == 0x1FFFFFFFU);
  CHECK(extended);
  CHECK(parse_can_id("7FF", "", extended) == 0x7FFU);
  CHECK_FALSE(extended);
  CHECK(parse_can_id("0800", "", extended) == 0x800U);  // four digits: 29-bit, even with a small value
  CHECK(extended);
}

TEST_CASE("parse_id_filter: ID alone matches every bit of its format, ID:MASK the mask's") {
  const CanFilter a = parse_id_filter("400");
  CHECK((a.id == 0x400U && a.mask == 0x7FFU && !a.extended));
  const CanFilter b = parse_id_filter("0x400:0x7F0");
  CHECK((b.id == 0x400U && b.mask == 0x7F0U && !b.extended));
  const CanFilter c = parse_id_filter("00000344");
  CHECK((c.id == 0x344U && c.mask == 0x1FFFFFFFU && c.extended));
  CHECK_THROWS_AS(parse_id_filter("400:"), std::invalid_argument);
  CHECK_THROWS_AS(parse_id_filter(":7F0"), std::invalid_argument);
}

TEST_CASE("passes: no filter or an error frame passes; else some filter of the frame's format matches its id bits") {
  std::mt19937 rng(7);
  for (int n = 0; n < 20000; ++n) {
    std::vector<CanFilter> filters(rng() % 4);
    for (auto& f : filters) {
      f.extended = rng() % 2 == 0;
      const std::uint32_t limit = f.extended ? 0x1FFFFFFFU : 0x7FFU;
      f.id = static_cast<std::uint32_t>(rng()) & limit;
      f.mask = rng() % 3 == 0 ? limit : static_cast<std::uint32_t>(rng()) & limit;
    }
    CanFrame frame;
    frame.extended = rng() % 2 == 0;
    frame.id = static_cast<std::uint32_t>(rng()) & (frame.extended ? 0x1FFFFFFFU : 0x7FFU);
    if (rng() % 8 == 0 && !filters.empty()) {  // often enough a frame a filter is about
      frame.id = filters[0].id;
      frame.extended = filters[0].extended;
    }
    frame.error = rng() % 16 == 0;
    bool want = filters.empty() || frame.error;
    for (const auto& f : filters)
      for (std::uint32_t bit = 1; bit != 0 && !want; bit <<= 1) {
        if (f.extended != frame.extended) break;
        if ((f.mask & bit) && (f.id & bit) != (frame.id & bit)) break;
        if (bit == 0x80000000U) want = true;
      }
    CHECK(passes(filters, frame) == want);
  }
}
