// The table-driven stuff-bit count (can_bits.cpp) against the bit-by-bit rule written out here, on random frames of
// both id formats and every length (data and remote), and on runs of equal bits where stuffing piles up. The Python
// model's vectors stay in test_bus_stats.cpp (can_frame_bits exact).
#include <catch2/catch.hpp>

#include <random>
#include <vector>

#include "saulproto/host/report/bus_stats.hpp"
#include "../capture/test_captures.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

/// The frame's bits SOF..data, one bit at a time.
std::vector<int> frame_bits_model(const CanFrame& f) {
  std::vector<int> bits;
  auto put = [&](std::uint32_t v, int width) {
    for (int i = width - 1; i >= 0; --i) bits.push_back(static_cast<int>((v >> i) & 1U));
  };
  put(0, 1);
  if (f.extended) {
    put(f.id >> 18, 11);
    put(1, 1);
    put(1, 1);
    put(f.id & 0x3FFFF, 18);
    put(f.remote, 1);
    put(0, 2);
  } else {
    put(f.id, 11);
    put(f.remote, 1);
    put(0, 2);
  }
  put(f.dlc, 4);
  for (std::uint8_t b : f.payload()) put(b, 8);
  return bits;
}

/// The CAN CRC-15 (polynomial 0x4599) of the frame's bits SOF..data, one bit at a time.
unsigned crc15_model(const CanFrame& f) {
  unsigned crc = 0;
  for (int b : frame_bits_model(f)) {
    const bool next = (b != 0) != (((crc >> 14) & 1U) != 0);
    crc = (crc << 1) & 0x7FFF;
    if (next) crc ^= 0x4599;
  }
  return crc;
}

/// The frame's bits SOF..data, then its CRC-15, then the stuffing rule, one bit at a time.
unsigned stuff_bits_model(const CanFrame& f) {
  std::vector<int> bits = frame_bits_model(f);
  const unsigned crc = crc15_model(f);
  for (int i = 14; i >= 0; --i) bits.push_back(static_cast<int>((crc >> i) & 1U));
  unsigned stuff = 0, run = 0;
  int last = -1;
  for (int b : bits) {
    if (b == last) {
      ++run;
    } else {
      last = b;
      run = 1;
    }
    if (run == 5) {
      ++stuff;
      last = 1 - b;
      run = 1;
    }
  }
  return stuff;
}

}  // namespace

TEST_CASE("can bits: the bit-by-bit model's CRC-15 gives the Python model's values") {
  // The frames of test_bus_stats.cpp "CAN frame lengths on the wire", whose exact stuff bits follow from these CRCs.
  using capture_test::make;
  CHECK(crc15_model(make(0x300, false, {0xE8, 0x03, 0x0C, 0xFE}, 0)) == 0x18D8);
  CHECK(crc15_model(make(0x000, false, {}, 0)) == 0);
  CHECK(crc15_model(make(0x938, true, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA}, 0)) == 0x63C6);
  CHECK(crc15_model(make(0x1FFFFFFF, true, {0, 0, 0, 0, 0, 0, 0, 0}, 0)) == 0x7DA3);
}

TEST_CASE("can bits: table-driven stuff bits equal the bit-by-bit rule on random and run-heavy frames") {
  std::mt19937_64 rng(15);
  for (int i = 0; i < 20000; ++i) {
    CanFrame f;
    f.extended = rng() % 2 == 0;
    f.id = static_cast<std::uint32_t>(rng() % (f.extended ? 0x20000000 : 0x800));
    f.remote = rng() % 8 == 0;
    f.dlc = static_cast<std::uint8_t>(rng() % 9);
    const int style = static_cast<int>(rng() % 3);  // random bytes, all 0x00/0xFF, or few set bits
    for (auto& b : f.data) {
      const std::uint64_t r = rng();
      b = static_cast<std::uint8_t>(style == 0 ? r : style == 1 ? (r % 2 ? 0xFFU : 0x00U) : 1U << (r % 8));
    }
    if (style == 1) f.id = rng() % 2 ? 0 : (f.extended ? 0x1FFFFFFF : 0x7FF);
    INFO("id " << f.id << " ext " << f.extended << " remote " << f.remote << " dlc " << int{f.dlc});
    const unsigned model = stuff_bits_model(f);
    REQUIRE(can_stuff_bits(f) == model);
    // the way stats' line tables count: the header's share first, then the data
    const CanStuffStart start = can_stuff_start(f.id, f.extended, f.remote, f.dlc);
    REQUIRE(can_stuff_bits(start, f.data.data()) == model);
  }
}
