// What this process has read from files, as the kernel counts it (/proc/self/io's rchar): for tests that check a
// reader reads each byte of a file once.
#pragma once

#include <catch2/catch.hpp>

#include <cstdint>
#include <fstream>
#include <string>

/// Bytes this process has read with read() and pread() so far. Reading /proc/self/io counts too: subtract
/// read_count_cost() per call, and do not call both in one expression (their order would be unspecified).
inline std::uint64_t bytes_read_so_far() {
  std::ifstream io("/proc/self/io");
  std::string key;
  std::uint64_t value = 0;
  while (io >> key >> value)
    if (key == "rchar:") return value;
  FAIL("no rchar in /proc/self/io");
  return 0;
}

/// What one bytes_read_so_far() adds to the count: ask it after the reads measured (the file's numbers only grow, and
/// a digit more makes the next call read a byte more).
inline std::uint64_t read_count_cost() {
  const std::uint64_t a = bytes_read_so_far();
  const std::uint64_t b = bytes_read_so_far();
  return b - a;
}
