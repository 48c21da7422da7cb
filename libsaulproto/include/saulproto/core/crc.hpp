// Checksums of the robot's links.
//
//  - CRC-8/MAXIM (a.k.a. MAXIM-DOW, Dallas 1-Wire): the inter-board UART. Reflected poly 0x31 (0x8C), init 0,
//    no final xor. Catalogue check over "123456789" = 0xA1.
//  - CRC-8/DVB-S2: CRSF. Poly 0xD5, MSB first, init 0, no final xor. Check = 0xBC.
//  - Pride ES sum complement: bitwise NOT of the 8-bit sum of the bytes (signed or unsigned addition give the
//    same low 8 bits, so "sum as signed chars" in the manual changes nothing).
//
// Both CRCs are table-driven (256-byte tables in flash): O(n), one lookup per byte, no state besides the
// running value. The *_update functions let a streaming decoder fold bytes in as they arrive.
#pragma once

#include <cstdint>
#include <span>

namespace saul::crc {

std::uint8_t crc8_maxim_update(std::uint8_t crc, std::uint8_t byte) noexcept;
std::uint8_t crc8_maxim(std::span<const std::uint8_t> data, std::uint8_t init = 0) noexcept;

std::uint8_t crc8_dvb_s2_update(std::uint8_t crc, std::uint8_t byte) noexcept;
std::uint8_t crc8_dvb_s2(std::span<const std::uint8_t> data, std::uint8_t init = 0) noexcept;

/// Pride ES checksum: ~(sum of bytes) truncated to 8 bits. A valid frame therefore sums to 0xFF.
std::uint8_t pride_checksum(std::span<const std::uint8_t> data) noexcept;

}  // namespace saul::crc
