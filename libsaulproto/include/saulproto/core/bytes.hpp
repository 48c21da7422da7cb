// Fixed-width integers to and from byte buffers in an explicit byte order.
//
// The SAUL CAN frames and the inter-board UART are little-endian; VESC and CRSF are big-endian
// (docs/protocol.md §1). Every codec says which it uses by calling one of these; none relies on the
// host's own byte order. All functions are O(1) and never touch memory outside [p, p + width).
#pragma once

#include <bit>
#include <cstdint>

namespace saul::bytes {

constexpr std::uint16_t get_u16le(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
constexpr std::int16_t get_i16le(const std::uint8_t* p) noexcept {
  return static_cast<std::int16_t>(get_u16le(p));
}
constexpr std::uint32_t get_u32le(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
constexpr std::uint16_t get_u16be(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}
constexpr std::int16_t get_i16be(const std::uint8_t* p) noexcept {
  return static_cast<std::int16_t>(get_u16be(p));
}
constexpr std::uint32_t get_u24be(const std::uint8_t* p) noexcept {
  return (static_cast<std::uint32_t>(p[0]) << 16) | (static_cast<std::uint32_t>(p[1]) << 8) | p[2];
}
constexpr std::uint32_t get_u32be(const std::uint8_t* p) noexcept {
  return (static_cast<std::uint32_t>(p[0]) << 24) | (static_cast<std::uint32_t>(p[1]) << 16) |
         (static_cast<std::uint32_t>(p[2]) << 8) | static_cast<std::uint32_t>(p[3]);
}
constexpr std::int32_t get_i32be(const std::uint8_t* p) noexcept {
  return static_cast<std::int32_t>(get_u32be(p));
}
constexpr float get_f32le(const std::uint8_t* p) noexcept { return std::bit_cast<float>(get_u32le(p)); }

constexpr void put_u16le(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
constexpr void put_i16le(std::uint8_t* p, std::int16_t v) noexcept { put_u16le(p, static_cast<std::uint16_t>(v)); }
constexpr void put_u32le(std::uint8_t* p, std::uint32_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
  p[2] = static_cast<std::uint8_t>(v >> 16);
  p[3] = static_cast<std::uint8_t>(v >> 24);
}
constexpr void put_f32le(std::uint8_t* p, float v) noexcept { put_u32le(p, std::bit_cast<std::uint32_t>(v)); }
constexpr void put_u16be(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v);
}
constexpr void put_i16be(std::uint8_t* p, std::int16_t v) noexcept { put_u16be(p, static_cast<std::uint16_t>(v)); }
constexpr void put_u24be(std::uint8_t* p, std::uint32_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v >> 16);
  p[1] = static_cast<std::uint8_t>(v >> 8);
  p[2] = static_cast<std::uint8_t>(v);
}
constexpr void put_u32be(std::uint8_t* p, std::uint32_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v >> 24);
  p[1] = static_cast<std::uint8_t>(v >> 16);
  p[2] = static_cast<std::uint8_t>(v >> 8);
  p[3] = static_cast<std::uint8_t>(v);
}
constexpr void put_i32be(std::uint8_t* p, std::int32_t v) noexcept { put_u32be(p, static_cast<std::uint32_t>(v)); }

}  // namespace saul::bytes
