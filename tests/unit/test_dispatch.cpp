// decode_bus_name() against decode_bus_frame(): the same outcome for every frame, the name in place of the message.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <cstring>
#include <random>

#include "saulproto/core/dispatch.hpp"

using namespace saul;

TEST_CASE("decode_bus_name gives decode_bus_frame's reason, or the decoded message's name, for any frame") {
  std::mt19937_64 rng(515);
  // every SAUL id and neighbours; VESC commands (known, unknown, past 0xFF) for a few nodes; ids too large
  constexpr std::array<std::uint32_t, 12> kStandard{0x300, 0x301, 0x302, 0x303, 0x304, 0x3FF,
                                                    0x400, 0x401, 0x402, 0x403, 0x7FF, 0x800};
  constexpr std::array<std::uint32_t, 18> kVescCommands{0,  1,  2,  3,  4,  5,  9,  10,   14,
                                                    15, 16, 17, 18, 27, 58, 59, 0xFF, 0x100};
  // bytes near the codecs' limits (enums, signs, NaN and infinity patterns) more often than others
  constexpr std::array<std::uint8_t, 10> kEdges{0x00, 0x01, 0x02, 0x03, 0x04, 0x7F, 0x80, 0xC0, 0xFE, 0xFF};
  std::size_t decoded = 0;
  for (int i = 0; i < 200000; ++i) {
    CanFrame f;
    f.extended = rng() % 2 != 0;
    if (f.extended) {
      f.id = rng() % 16 == 0 ? static_cast<std::uint32_t>(rng() % 0x40000000)
                             : kVescCommands[rng() % kVescCommands.size()] << 8 | static_cast<std::uint32_t>(rng() % 256);
    } else {
      f.id = kStandard[rng() % kStandard.size()];
    }
    f.dlc = static_cast<std::uint8_t>(rng() % 4 == 0 ? rng() % 16 : 8 - rng() % 3 * (rng() % 3));
    f.remote = rng() % 32 == 0;
    f.error = rng() % 64 == 0;
    for (auto& byte : f.data)
      byte = rng() % 2 ? kEdges[rng() % kEdges.size()] : static_cast<std::uint8_t>(rng());
    INFO("id " << std::hex << f.id << " extended " << f.extended << " dlc " << std::dec << int{f.dlc});
    const auto full = decode_bus_frame(f);
    const auto name = decode_bus_name(f);
    REQUIRE(static_cast<bool>(name) == static_cast<bool>(full));
    if (full) {
      ++decoded;
      REQUIRE(std::strcmp(name.value().name, name_of(full.value())) == 0);
    } else {
      REQUIRE(name.reason() == full.reason());
    }
  }
  CHECK(decoded > 10000);  // the frames reach the codecs' decoders, not only their first checks
}
