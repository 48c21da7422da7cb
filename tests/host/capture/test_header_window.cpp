// The window the pcap and pcapng cutters walk a file with (HeaderWindow, private to the capture folder): on long
// random walks it must give the file's bytes at every position asked, lend exactly the bytes of the range asked,
// and, walking forward, read no byte of the file twice (counted by the kernel: /proc/self/io's rchar).
#include <catch2/catch.hpp>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "../../../libsaulproto/src/host/capture/capture_io.hpp"
#include "host/read_count.hpp"
#include "host/temp_file.hpp"

using saul::host::detail::HeaderWindow;


TEST_CASE("header window: random forward walks see the file's bytes, lend whole ranges and read each byte once") {
  std::mt19937_64 rng(15);
  std::string file(300'000, '\0');
  for (char& c : file) c = static_cast<char>(rng());
  TempFile temp(file);
  const int fd = ::open(temp.path.c_str(), O_RDONLY);
  REQUIRE(fd >= 0);
  for (int round = 0; round < 200; ++round) {
    const std::size_t window = 16 + rng() % 20'000;
    INFO("round " << round << ", window " << window);
    HeaderWindow w(fd, file.size(), window);
    std::vector<std::uint8_t> scratch;  // the reader's buffer, swapped with the window's at each lend
    std::uint64_t pos = rng() % 1000, lent_to = pos;
    const std::uint64_t before = bytes_read_so_far();
    for (;;) {
      const std::size_t n = 1 + rng() % (rng() % 8 == 0 ? 3 * window : 64);  // now and then more than a window
      const std::uint8_t* p = w.at(pos, n);
      if (pos + n > file.size()) {
        CHECK(p == nullptr);
        break;
      }
      REQUIRE(p != nullptr);
      REQUIRE(std::string(reinterpret_cast<const char*>(p), n) == file.substr(pos, n));
      if (rng() % 5 == 0) {  // the walk found a block's end where it stands, or behind: lend [lent_to, to)
        const std::uint64_t to = lent_to + rng() % (pos - lent_to + 1);
        std::size_t offset = 0;
        if (w.lend(lent_to, to, scratch, offset)) {
          REQUIRE(offset >= HeaderWindow::kFront);
          REQUIRE(offset + (to - lent_to) <= scratch.size());
          REQUIRE(std::string(reinterpret_cast<const char*>(scratch.data() + offset), to - lent_to) ==
                  file.substr(lent_to, to - lent_to));
          lent_to = to;
        }
      }
      pos += rng() % (rng() % 16 == 0 ? 2 * window : 200);
    }
    // Forward only: every read starts where the last one ended, or further on.
    const std::uint64_t read = bytes_read_so_far() - before;  // (read_count_cost() reads too: not in one expression)
    CHECK(read <= file.size() + read_count_cost());  // measured now: /proc/self/io grows a digit now and then
  }
  ::close(fd);
}

TEST_CASE("header window: a walk that is never lent keeps a bounded window and still reads each byte once") {
  std::mt19937_64 rng(16);
  std::string file(1'000'000, '\0');
  for (char& c : file) c = static_cast<char>(rng());
  TempFile temp(file);
  const int fd = ::open(temp.path.c_str(), O_RDONLY);
  REQUIRE(fd >= 0);
  HeaderWindow w(fd, file.size(), 4096);
  const std::uint64_t before = bytes_read_so_far();
  for (std::uint64_t pos = 0; pos + 48 <= file.size(); pos += 48) {
    const std::uint8_t* p = w.at(pos, 48);
    REQUIRE(p != nullptr);
    REQUIRE(std::memcmp(p, file.data() + pos, 48) == 0);
  }
  const std::uint64_t read = bytes_read_so_far() - before;
  CHECK(read <= file.size() + read_count_cost());  // measured now: /proc/self/io grows a digit now and then
  // A range that was let go of cannot be lent; one still in the window can.
  std::vector<std::uint8_t> into;
  std::size_t offset = 0;
  CHECK_FALSE(w.lend(0, 48, into, offset));
  ::close(fd);
}

TEST_CASE("header window: a walk going back starts afresh and gives the right bytes") {
  std::string file(50'000, '\0');
  for (std::size_t i = 0; i < file.size(); ++i) file[i] = static_cast<char>(i * 7 + i / 251);
  TempFile temp(file);
  const int fd = ::open(temp.path.c_str(), O_RDONLY);
  REQUIRE(fd >= 0);
  HeaderWindow w(fd, file.size(), 1000);
  for (const std::uint64_t pos : {40'000, 100, 39'990, 0, 49'990, 20'000}) {
    const std::uint8_t* p = w.at(pos, 10);
    REQUIRE(p != nullptr);
    CHECK(std::memcmp(p, file.data() + pos, 10) == 0);
  }
  CHECK(w.at(49'995, 10) == nullptr);  // past the end
  ::close(fd);
}
