// Hexadecimal digits, shared by every text codec (slcan, candump, serial logs, sigrok exports).
#pragma once

namespace saul::hex {

inline constexpr char kUpperDigits[] = "0123456789ABCDEF";

/// The value of one hex digit (either case), or -1 when c is not one. O(1).
constexpr int value(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace saul::hex
