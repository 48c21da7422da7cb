#include "saulproto/core/crc.hpp"

#include <array>

namespace saul::crc {
namespace {

// Tables are computed at compile time from the bitwise definitions, so the only thing to trust is the
// polynomial; tests check both against the catalogue values.
constexpr std::array<std::uint8_t, 256> make_reflected_table(std::uint8_t reflected_poly) {
  std::array<std::uint8_t, 256> table{};
  for (unsigned i = 0; i < 256; ++i) {
    auto c = static_cast<std::uint8_t>(i);
    for (int bit = 0; bit < 8; ++bit) {
      c = (c & 1U) ? static_cast<std::uint8_t>((c >> 1) ^ reflected_poly) : static_cast<std::uint8_t>(c >> 1);
    }
    table[i] = c;
  }
  return table;
}

constexpr std::array<std::uint8_t, 256> make_msb_first_table(std::uint8_t poly) {
  std::array<std::uint8_t, 256> table{};
  for (unsigned i = 0; i < 256; ++i) {
    auto c = static_cast<std::uint8_t>(i);
    for (int bit = 0; bit < 8; ++bit) {
      c = (c & 0x80U) ? static_cast<std::uint8_t>((c << 1) ^ poly) : static_cast<std::uint8_t>(c << 1);
    }
    table[i] = c;
  }
  return table;
}

constexpr auto kMaximTable = make_reflected_table(0x8C);  // 0x31 reflected
constexpr auto kDvbS2Table = make_msb_first_table(0xD5);

}  // namespace

std::uint8_t crc8_maxim_update(std::uint8_t crc, std::uint8_t byte) noexcept {
  return kMaximTable[static_cast<std::uint8_t>(crc ^ byte)];
}

std::uint8_t crc8_maxim(std::span<const std::uint8_t> data, std::uint8_t init) noexcept {
  std::uint8_t crc = init;
  for (std::uint8_t b : data) crc = kMaximTable[static_cast<std::uint8_t>(crc ^ b)];
  return crc;
}

std::uint8_t crc8_dvb_s2_update(std::uint8_t crc, std::uint8_t byte) noexcept {
  return kDvbS2Table[static_cast<std::uint8_t>(crc ^ byte)];
}

std::uint8_t crc8_dvb_s2(std::span<const std::uint8_t> data, std::uint8_t init) noexcept {
  std::uint8_t crc = init;
  for (std::uint8_t b : data) crc = kDvbS2Table[static_cast<std::uint8_t>(crc ^ b)];
  return crc;
}

std::uint8_t pride_checksum(std::span<const std::uint8_t> data) noexcept {
  std::uint8_t sum = 0;
  for (std::uint8_t b : data) sum = static_cast<std::uint8_t>(sum + b);
  return static_cast<std::uint8_t>(~sum);
}

}  // namespace saul::crc
