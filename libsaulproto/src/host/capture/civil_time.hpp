// Private helpers of the capture formats that carry calendar dates (ASC, BLF, TRC): days since 1970-01-01 of a date
// and back, on std::chrono's proleptic Gregorian calendar. UTC, no leap seconds.
#pragma once

#include <chrono>
#include <cstdint>

namespace saul::host::detail {

inline constexpr std::uint64_t kNsPerSecond = 1'000'000'000ULL;
inline constexpr std::uint64_t kNsPerDay = 86'400ULL * kNsPerSecond;

/// Days since 1970-01-01 of y-m-d (d >= 1; a day past the month's end runs on into the next month).
constexpr std::int64_t days_from_civil(std::int64_t y, unsigned m, unsigned d) noexcept {
  const std::chrono::sys_days first{std::chrono::year{static_cast<int>(y)} / std::chrono::month{m} / 1};
  return (first + std::chrono::days{d - 1}).time_since_epoch().count();
}

struct Civil {
  std::int64_t year;
  unsigned month;  // 1..12
  unsigned day;    // 1..31
};

constexpr Civil civil_from_days(std::int64_t days) noexcept {
  const std::chrono::year_month_day date{std::chrono::sys_days{std::chrono::days{days}}};
  return {static_cast<int>(date.year()), static_cast<unsigned>(date.month()), static_cast<unsigned>(date.day())};
}

/// 0 = Sunday.
constexpr unsigned weekday_from_days(std::int64_t days) noexcept {
  return std::chrono::weekday{std::chrono::sys_days{std::chrono::days{days}}}.c_encoding();
}

static_assert(days_from_civil(1970, 1, 1) == 0);
static_assert(days_from_civil(2023, 11, 14) == 19675);
static_assert(days_from_civil(2023, 2, 31) == days_from_civil(2023, 3, 3));
static_assert(civil_from_days(19675).day == 14 && weekday_from_days(19675) == 2);  // a Tuesday

}  // namespace saul::host::detail
