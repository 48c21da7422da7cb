// Private helpers of the capture formats that carry calendar dates (ASC date lines, BLF's SYSTEMTIME, TRC's
// $STARTTIME): days since 1970-01-01 of a proleptic Gregorian date and back (the usual era-based algorithm). UTC,
// no leap seconds. Not installed, not part of the API.
#pragma once

#include <cstdint>

namespace saul::host::detail {

inline constexpr std::uint64_t kNsPerSecond = 1'000'000'000ULL;
inline constexpr std::uint64_t kNsPerDay = 86'400ULL * kNsPerSecond;

constexpr std::int64_t days_from_civil(std::int64_t y, unsigned m, unsigned d) noexcept {
  y -= m <= 2 ? 1 : 0;
  const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
  const auto yoe = static_cast<unsigned>(y - era * 400);
  const unsigned mp = m > 2 ? m - 3 : m + 9;
  const unsigned doy = (153 * mp + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}

struct Civil {
  std::int64_t year;
  unsigned month;  // 1..12
  unsigned day;    // 1..31
};

constexpr Civil civil_from_days(std::int64_t z) noexcept {
  z += 719468;
  const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const auto doe = static_cast<unsigned>(z - era * 146097);
  const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const unsigned mp = (5 * doy + 2) / 153;
  const unsigned d = doy - (153 * mp + 2) / 5 + 1;
  const unsigned m = mp < 10 ? mp + 3 : mp - 9;
  return {static_cast<std::int64_t>(yoe) + era * 400 + (m <= 2 ? 1 : 0), m, d};
}

/// 0 = Sunday for a count of days since 1970-01-01 (a Thursday), days >= 0.
constexpr unsigned weekday_from_days(std::int64_t days) noexcept { return static_cast<unsigned>((days + 4) % 7); }

static_assert(days_from_civil(1970, 1, 1) == 0);
static_assert(days_from_civil(2023, 11, 14) == 19675);

}  // namespace saul::host::detail
