// Check values from the RevEng CRC catalogue ("123456789"), and Pride frames summed by hand.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <string_view>

#include "saulproto/core/crc.hpp"

using namespace saul;

namespace {
std::span<const std::uint8_t> ascii(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}
}  // namespace

TEST_CASE("CRC-8/MAXIM matches the catalogue check value 0xA1") {
  CHECK(crc::crc8_maxim(ascii("123456789")) == 0xA1);
  CHECK(crc::crc8_maxim({}) == 0x00);
}

TEST_CASE("CRC-8/MAXIM byte-wise update equals the whole-buffer form") {
  std::uint8_t c = 0;
  for (char ch : std::string_view("123456789")) c = crc::crc8_maxim_update(c, static_cast<std::uint8_t>(ch));
  CHECK(c == 0xA1);
}

TEST_CASE("CRC-8/MAXIM has residue zero: data followed by its CRC checks to 0") {
  const std::array<std::uint8_t, 10> d{'1', '2', '3', '4', '5', '6', '7', '8', '9', 0xA1};
  CHECK(crc::crc8_maxim(d) == 0x00);
}

TEST_CASE("CRC-8/DVB-S2 matches the catalogue check value 0xBC") {
  CHECK(crc::crc8_dvb_s2(ascii("123456789")) == 0xBC);
  std::uint8_t c = 0;
  for (char ch : std::string_view("123456789")) c = crc::crc8_dvb_s2_update(c, static_cast<std::uint8_t>(ch));
  CHECK(c == 0xBC);
}

TEST_CASE("CRC-8/DVB-S2 over a CRSF heartbeat frame (type + payload) gives its published CRC") {
  // C8 04 0B 00 C8 ED: CRC covers 0B 00 C8.
  const std::array<std::uint8_t, 3> covered{0x0B, 0x00, 0xC8};
  CHECK(crc::crc8_dvb_s2(covered) == 0xED);
}

TEST_CASE("Pride checksum is the complement of the byte sum") {
  // By hand: FE + 54 + 07 + 32 + 00 = 0x18B -> low byte 0x8B -> ~ = 0x74.
  const std::array<std::uint8_t, 5> vcu{0xFE, 0x54, 0x07, 0x32, 0x00};
  CHECK(crc::pride_checksum(vcu) == 0x74);
  // By hand: 4A + 01 + 02 + 64 + 00 = 0xB1 -> ~ = 0x4E.
  const std::array<std::uint8_t, 5> ctrl{0x4A, 0x01, 0x02, 0x64, 0x00};
  CHECK(crc::pride_checksum(ctrl) == 0x4E);
  // Summing as signed chars: -2 + 84 + 7 + 50 + 0 = 139 = 0x8B, the same low byte.
  CHECK(crc::pride_checksum({}) == 0xFF);
  // "123456789": 0x31 + ... + 0x39 = 0x1DD -> 0xDD -> ~ = 0x22.
  CHECK(crc::pride_checksum(ascii("123456789")) == 0x22);
}
