// CandumpReader (large reads, lines scanned in place, batches) reads what the log read line by line with
// parse_candump_line gives (test::CandumpLineModel): the same frames,
// interfaces and corrupt-line reports, whatever the block size; an over-long line (200 MB here, written through a
// pipe on the fly) is reported at its line and skipped without being held, and the lines after it still read;
// split_candump_blocks cuts at line starts only.
#include <catch2/catch.hpp>
#include <fmt/format.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/pcap.hpp"
#include "host/capture/candump_model.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

const std::string kLog =
    "# comment line\n"
    "(1700000000.000000) can0 300#E8030CFE\n"
    "\n"
    "(1700000000.100000) vcan1 400#0102030405060708\r\n"
    "(1700000000.2) can0 30G#00\n"
    "not a frame, a comment to canplayer\n"
    "(1700000000.300000) can0 12345678#R\n"
    "(1700000000.400000) can0 20000080#0000000000000000\n"
    "(1700000000.500000)\n"
    "(1700000000.600000) can0 123#11";  // last line without newline

struct Seen {
  std::vector<CanFrame> frames;
  std::vector<std::string> interfaces;
  std::vector<std::string> errors;  // in order among the frames: "before N: FILE:LINE:COL: message"
};

/// The records of a reader's batches, in order.
template <class Batches>
Seen with_batches(Batches& source) {
  Seen s;
  FrameBatch batch;
  while (source.next_batch(batch)) {
    std::size_t c = 0;
    for (std::size_t i = 0; i <= batch.frames.size(); ++i) {
      for (; c < batch.corrupt.size() && batch.corrupt[c].before == i; ++c)
        s.errors.push_back(std::to_string(s.frames.size()) + ": " + format_capture_error("f", batch.corrupt[c].error));
      if (i < batch.frames.size()) {
        s.frames.push_back(batch.frames[i]);
        s.interfaces.emplace_back(batch.interfaces[i]);
      }
    }
  }
  return s;
}

Seen with_reader(const std::string& text) {
  std::istringstream in(text);
  test::CandumpLineModel reader(in);
  return with_batches(reader);
}

/// A pipe whose write end is fed by a thread (so nothing of it is ever a file).
struct Pipe {
  int fds[2]{-1, -1};
  std::thread writer;
  explicit Pipe(std::function<void(int)> feed) {
    REQUIRE(::pipe(fds) == 0);
    writer = std::thread([this, feed] {
      feed(fds[1]);
      ::close(fds[1]);
    });
  }
  ~Pipe() {
    if (writer.joinable()) writer.join();
    ::close(fds[0]);
  }
};

void write_all(int fd, const char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w <= 0) return;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
}

}  // namespace

TEST_CASE("candump scanner: the frames, interfaces and reports of the line-by-line model, at any block size") {
  const Seen expected = with_reader(kLog);
  REQUIRE(expected.frames.size() == 5);
  REQUIRE(expected.errors.size() == 2);
  CHECK(expected.errors[0] == "2: f:5:23: id is not hexadecimal (line skipped)");
  for (std::size_t block : {1, 2, 7, 64, 4096}) {
    INFO("block " << block);
    Pipe pipe([](int fd) { write_all(fd, kLog.data(), kLog.size()); });
    CandumpReader scanner(pipe.fds[0], block);
    const Seen got = with_batches(scanner);
    CHECK(got.frames == expected.frames);
    CHECK(got.interfaces == expected.interfaces);
    CHECK(got.errors == expected.errors);
    CHECK(scanner.lines() == 10);
    CHECK(scanner.bytes_read() == kLog.size());
  }
}

TEST_CASE("candump scanner: a 200 MB line is reported at its line and skipped, the rest still reads") {
  // Line 1 a frame, line 2 a frame with 200 MB of data digits, line 3 a 200 MB comment, then two frames.
  constexpr std::size_t kHuge = 200u << 20;
  Pipe pipe([](int fd) {
    const std::string head = "(1700000000.000000) can0 300#E8030CFE\n(1700000000.100000) can0 300#";
    write_all(fd, head.data(), head.size());
    const std::string chunk(1 << 20, 'A');
    for (std::size_t n = 0; n < kHuge; n += chunk.size()) write_all(fd, chunk.data(), chunk.size());
    write_all(fd, "\n# ", 3);
    for (std::size_t n = 0; n < kHuge; n += chunk.size()) write_all(fd, chunk.data(), chunk.size());
    const std::string tail = "\n(1700000000.200000) can0 400#01\n(1700000000.300000) can1 401#02\n";
    write_all(fd, tail.data(), tail.size());
  });
  CandumpReader scanner(pipe.fds[0]);
  const Seen got = with_batches(scanner);
  REQUIRE(got.frames.size() == 3);
  CHECK(got.frames[0].id == 0x300);
  CHECK(got.frames[1].id == 0x400);
  CHECK(*got.frames[2].timestamp_ns == 1'700'000'000'300'000'000ULL);
  CHECK(got.interfaces[2] == "can1");
  REQUIRE(got.errors.size() == 1);
  CHECK(got.errors[0] == "1: f:2:1: line longer than 65536 bytes (line skipped)");
  CHECK(scanner.lines() == 5);
}

TEST_CASE("candump scanner: ranges from split_candump_blocks start at line starts and cover the file") {
  std::string log;
  for (int i = 0; i < 500; ++i) log += "(1700000000." + std::to_string(100000 + i) + ") can0 300#E8030CFE\n";
  log += "(1700000001.000000) can0 300#" + std::string(5000, '0') + "\n";  // a line across several blocks
  for (int i = 0; i < 10; ++i) log += "(1700000002.000000) can0 301#00\n";
  char name[] = "/tmp/saul_scan_XXXXXX";
  const int fd = mkstemp(name);
  REQUIRE(fd >= 0);
  REQUIRE(::write(fd, log.data(), log.size()) == static_cast<ssize_t>(log.size()));
  for (std::uint64_t block : {1u, 100u, 1000u, 1u << 20}) {
    INFO("block " << block);
    const auto starts = split_candump_blocks(fd, log.size(), block);
    REQUIRE(starts.front() == 0);
    REQUIRE(starts.back() == log.size());
    std::size_t frames = 0;
    std::string errors;
    for (std::size_t k = 0; k + 1 < starts.size(); ++k) {
      REQUIRE(starts[k] < starts[k + 1]);
      if (k > 0) CHECK(log[starts[k] - 1] == '\n');
      CandumpReader scanner(fd, starts[k], starts[k + 1], 64);
      const Seen s = with_batches(scanner);
      frames += s.frames.size();
      for (const auto& e : s.errors) errors += e;
    }
    CHECK(frames == 510);
    CHECK(errors.find("more than 8 data bytes") != std::string::npos);
  }
  ::close(fd);
  std::remove(name);
}

namespace {

void le32(std::string& s, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s += static_cast<char>((v >> (8 * i)) & 0xFF);
}

/// A pcap record by hand: header (little-endian) and a 16-byte SocketCAN packet (id big-endian).
std::string pcap_record(std::uint32_t sec, std::uint32_t usec, std::uint32_t id_flags, std::uint8_t len,
                        std::size_t incl = 16) {
  std::string r;
  le32(r, sec);
  le32(r, usec);
  le32(r, static_cast<std::uint32_t>(incl));
  le32(r, static_cast<std::uint32_t>(incl));
  std::string p(incl, '\0');
  for (int i = 0; i < 4 && i < static_cast<int>(incl); ++i) p[static_cast<std::size_t>(i)] = static_cast<char>(id_flags >> (24 - 8 * i));
  if (incl > 4) p[4] = static_cast<char>(len);
  for (std::size_t i = 8; i < incl && i < 16; ++i) p[i] = static_cast<char>(0x10 + i);
  return r + p;
}

}  // namespace

TEST_CASE("pcap reader: a regular file read with pread gives the frames and byte-offset reports of the stream, at any block size") {
  std::string pcap;
  le32(pcap, 0xA1B2C3D4);
  pcap += std::string("\x02\x00\x04\x00", 4);
  le32(pcap, 0);
  le32(pcap, 0);
  le32(pcap, 0xFFFF);
  le32(pcap, 227);
  for (std::uint32_t i = 0; i < 3000; ++i) {
    switch (i % 500) {
      case 17: pcap += pcap_record(1700000000 + i, 1'000'000, 0x300, 4); break;             // fraction too big
      case 18: pcap += pcap_record(1700000000 + i, 5, 0x300, 4, 80); break;                 // longer than CAN FD
      case 19: pcap += pcap_record(1700000000 + i, 5, 0x300, 9); break;                     // length above 8
      case 20: pcap += pcap_record(1700000000 + i, 5, 0x900, 2); break;                     // 11-bit id above 7FF
      case 21: pcap += pcap_record(1700000000 + i, 5, 0x80000344, 6, 12); break;           // too few data bytes
      case 22: pcap += pcap_record(1700000000 + i, 5, 0x40000123, 3); break;               // remote
      default: pcap += pcap_record(1700000000 + i, i * 7 % 1'000'000, i % 3 ? 0x400 : 0x80000944, static_cast<std::uint8_t>(i % 9));
    }
  }
  pcap += pcap_record(1700009999, 1, 0x300, 4).substr(0, 20);  // ends inside a record

  std::istringstream in(pcap);
  const auto reader = make_capture_reader(in, CaptureFormat::pcap);
  const Seen expected = with_batches(*reader);
  REQUIRE(expected.frames.size() > 2900);
  REQUIRE(expected.errors.size() == 31);

  char name[] = "/tmp/saul_pcap_XXXXXX";
  const int fd = mkstemp(name);
  REQUIRE(fd >= 0);
  REQUIRE(::write(fd, pcap.data(), pcap.size()) == static_cast<ssize_t>(pcap.size()));
  for (std::size_t block : {1, 33, 4096, 1 << 20}) {
    INFO("block " << block);
    PcapReader scanner(fd, pcap.size(), 0, pcap.size(), {}, block);
    Seen got;
    FrameBatch batch;
    while (scanner.next_batch(batch)) {
      std::size_t c = 0;
      for (std::size_t i = 0; i <= batch.frames.size(); ++i) {
        for (; c < batch.corrupt.size() && batch.corrupt[c].before == i; ++c)
          got.errors.push_back(std::to_string(got.frames.size()) + ": " + format_capture_error("f", batch.corrupt[c].error));
        if (i == batch.frames.size()) break;
        got.frames.push_back(batch.frames[i]);
        got.interfaces.emplace_back(batch.interfaces[i]);
      }
    }
    CHECK(got.frames == expected.frames);
    CHECK(got.interfaces == expected.interfaces);
    CHECK(got.errors == expected.errors);
  }
  ::close(fd);
  std::remove(name);
}

TEST_CASE("candump scanner: a line taker's lines and the batches give the line-by-line model's frames and reports in order") {
  // The taker (stats' line memo) takes every other line it can read with parse_candump_usual; the rest go into
  // batches. Frames and reports put together in the order they come must be the reader's, at any block size and
  // through a pipe, and the lines given to the taker are followed by kCandumpLineSlack readable bytes (ASan checks
  // the reads below).
  std::string log;
  std::uint64_t rng = 12345;
  auto next = [&] { return rng = rng * 6364136223846793005ULL + 1442695040888963407ULL, rng >> 33; };
  const std::vector<std::string> lines{
      "(1700000000.000000) can0 300#E8030CFE",   "(1700000000.100000) vcan1 400#0102030405060708\r",
      "(1700000000.2) can0 30G#00",              "(1700000000.300000) can0 12345678#R",
      "(1700000000.400000) can0 20000080#0000000000000000", "(1700000000.500000)",
      "# comment",                               "",
      "(1700000001.123456) can0 00000944#0011223344556677", "(1700000001.123457) robot_bus_long_name 123#",
      "(170000000.123457) can0 123#11"};
  for (int i = 0; i < 3000; ++i) {
    log += lines[next() % lines.size()] + "\n";
    // A line of the longest length read (corrupt): with small reads it ends near the buffer's end, where only the
    // slack is left after it.
    if (i == 1000) log += "(" + std::string(kMaxCandumpLine - 1, '7') + "\n";
  }
  log += "(1700000002.000000) can0 123#11";  // last line without newline
  const Seen expected = with_reader(log);
  REQUIRE(expected.errors.size() > 100);

  struct Taker final : CandumpLineTaker {
    Seen* seen = nullptr;
    bool odd = false;
    std::size_t taken = 0;
    std::size_t take_run(const char* begin, const char* end, std::size_t& used) override {
      volatile char last = end[kCandumpLineSlack - 1];  // in the buffer: ASan would say
      (void)last;
      const char* p = begin;
      std::size_t n = 0;
      while (const void* nl = std::memchr(p, '\n', static_cast<std::size_t>(end - p))) {
        const std::string_view line(p, static_cast<std::size_t>(static_cast<const char*>(nl) - p));
        CanFrame f;
        std::string_view interface;
        if (!parse_candump_usual(line, f, interface) || (odd = !odd)) break;
        std::uint64_t ns = 0;
        if (candump_fixed_time(line, ns)) CHECK(ns == f.timestamp_ns);
        seen->frames.push_back(f);
        seen->interfaces.emplace_back(interface);
        ++n;
        p += line.size() + 1;
      }
      used = static_cast<std::size_t>(p - begin);
      taken += n;
      return n;
    }
  };
  for (std::size_t block : {1, 7, 100, 4096, 1 << 20}) {
    INFO("block " << block);
    Pipe pipe([&](int fd) { write_all(fd, log.data(), log.size()); });
    CandumpReader scanner(pipe.fds[0], block);
    Seen got;
    Taker taker;
    taker.seen = &got;
    FrameBatch batch;
    while (scanner.next_batch(batch, &taker)) {
      // a batch ends at its first entry: a frame or a report, never both, never more than one
      CHECK(batch.frames.size() + batch.corrupt.size() == 1);
      for (const auto& c : batch.corrupt)
        got.errors.push_back(std::to_string(got.frames.size()) + ": " + format_capture_error("f", c.error));
      for (std::size_t i = 0; i < batch.frames.size(); ++i) {
        got.frames.push_back(batch.frames[i]);
        got.interfaces.emplace_back(batch.interfaces[i]);
      }
    }
    CHECK(taker.taken > 500);
    CHECK(got.frames == expected.frames);
    CHECK(got.interfaces == expected.interfaces);
    CHECK(got.errors == expected.errors);
    CHECK(scanner.bytes_read() == log.size());
  }
}

// The word-at-a-time readers of stats' line tables, against the byte-at-a-time definition.
// stats reads each line's time with the seconds remembered by their text: lines that share the seconds' text, that
// change one byte of it (a digit, the '(' or the '.'), or whose fraction is not digits must read as the line alone.
TEST_CASE("candump times read in file order with the seconds remembered equal each line read alone") {
  std::mt19937_64 rng(1234);
  CandumpFixedTimes times;
  std::string line = "(1763800000.000100) can0 300#00";
  for (int i = 0; i < 200000; ++i) {
    switch (rng() % 8) {
      case 0: line[rng() % 20] = "0123456789.() x\x80"[rng() % 16]; break;  // any byte of the time
      case 1: line[12 + rng() % 6] = static_cast<char>('0' + rng() % 10); break;  // another fraction
      case 2: line = fmt::format("({:010}.{:06}) can0 300#00", rng() % 10'000'000'000ULL, rng() % 1'000'000); break;
      case 3: line = line.substr(0, 20 + rng() % 8); break;  // shorter, down to too short for a time
      default: line = fmt::format("({}.{:06}) can0 300#00", line.substr(1, 10), rng() % 1'000'000); break;
    }
    INFO(line);
    std::uint64_t alone = 0, remembered = 0;
    const bool ok = candump_fixed_time(line, alone);
    REQUIRE(times.read(line, remembered) == ok);
    if (ok) REQUIRE(remembered == alone);
  }
}

// The fraction "dddddd) " of a candump time is checked and read in one SSE2 register (candump_fixed_fraction): every
// byte of it drawn from digits and the bytes around their range and the ") " must read as the digits one by one do.
TEST_CASE("a candump time's fraction read in a register equals its digits read one by one") {
  std::mt19937_64 rng(77);
  const std::vector<char> near = {'0', '1', '2', '3', '4', '5', '6', '7', '8', '9', '/', ':', ')', '(', ' ', '!',
                                  '\x7f', '\x80', '\xff', '\0', 'a'};  // digits, their neighbours, ") ", others
  int accepted = 0;
  for (int i = 0; i < 200000; ++i) {
    std::string line = "(1763800000.123456) can0 300#00";
    const int changes = static_cast<int>(rng() % 3);
    for (int c = 0; c < changes; ++c) line[12 + rng() % 8] = near[rng() % near.size()];
    bool want = line[18] == ')' && line[19] == ' ';
    std::uint64_t us = 0;
    for (std::size_t k = 12; k < 18; ++k) {
      const auto ch = static_cast<unsigned char>(line[k]);
      if (ch < '0' || ch > '9') want = false;
      us = us * 10 + (ch - '0');
    }
    INFO(line);
    std::uint64_t ns = 0;
    REQUIRE(candump_fixed_fraction(line.data(), ns) == want);
    std::uint64_t time_ns = 0;
    REQUIRE(candump_fixed_time(line, time_ns) == want);
    if (want) {
      REQUIRE(ns == us * 1000);
      REQUIRE(time_ns == 1'763'800'000'000'000'000ULL + us * 1000);
      ++accepted;
    }
  }
  CHECK(accepted > 50000);
}

TEST_CASE("candump text a word at a time: hex digits and byte search agree with reading byte by byte") {
  auto scalar_hex = [](unsigned char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
  };
  auto word_of = [](const char (&text)[8]) {
    std::uint64_t w;
    std::memcpy(&w, text, 8);
    return w;
  };
  // hand-written: "0123abCD" is the bytes 01 23 AB CD, the first the lowest
  std::uint32_t bytes = 0;
  REQUIRE(detail::hex_word(word_of({'0', '1', '2', '3', 'a', 'b', 'C', 'D'}), bytes));
  CHECK(bytes == 0xCDAB2301U);
  std::uint64_t data = 0;
  REQUIRE(detail::hex_bytes("00FF10e5a0b1c2d3", 16, data));
  CHECK(data == 0xD3C2B1A0E510FF00ULL);
  REQUIRE(detail::hex_bytes("7Fzzzzzzzzzzzzzz", 2, data));  // digits past the count are not looked at
  CHECK(data == 0x7F);
  // every byte value at every place of a word of digits
  for (unsigned place = 0; place < 8; ++place)
    for (unsigned b = 0; b < 256; ++b) {
      char text[8] = {'9', 'f', 'A', '0', '5', 'c', 'E', '1'};
      text[place] = static_cast<char>(b);
      INFO("byte " << b << " at " << place);
      const bool ok = detail::hex_word(word_of(text), bytes);
      REQUIRE(ok == (scalar_hex(static_cast<unsigned char>(b)) >= 0));
      if (ok)
        for (unsigned k = 0; k < 4; ++k)
          REQUIRE(((bytes >> (8 * k)) & 0xFF) ==
                  static_cast<unsigned>(scalar_hex(static_cast<unsigned char>(text[2 * k])) << 4 |
                                        scalar_hex(static_cast<unsigned char>(text[2 * k + 1]))));
    }
  // the first place of each byte value in words of other bytes
  std::uint64_t words[5];
  for (unsigned b = 0; b < 256; ++b)
    for (unsigned at = 0; at <= 40; ++at) {
      unsigned char text[40];
      std::memset(text, b == 'x' ? 'y' : 'x', sizeof text);
      if (at < 40) text[at] = static_cast<unsigned char>(b);
      if (at + 3 < 40) text[at + 3] = static_cast<unsigned char>(b);  // a later one does not count
      std::memcpy(words, text, sizeof words);
      REQUIRE(detail::first_byte(words, static_cast<char>(b)) == at);
    }
  // two bytes at once, in 40 bytes of text followed by bytes that do not count (48 are read)
  std::mt19937_64 rng(40);
  for (int round = 0; round < 20000; ++round) {
    char text[48];
    for (char& c : text) c = "(0123456789.# \nABcan_x"[rng() % 23];
    const char a = static_cast<char>(rng() % 3 == 0 ? rng() % 256 : '\n');
    const char b = static_cast<char>(rng() % 3 == 0 ? rng() % 256 : '#');
    if (rng() % 4 == 0) text[rng() % 48] = a;  // sometimes only after the 40 bytes
    std::uint64_t w[5];
    std::memcpy(w, text, sizeof w);
    const auto two = detail::first_two(text, a, b);
    REQUIRE(two.a == detail::first_byte(w, a));
    REQUIRE(two.b == detail::first_byte(w, b));
  }
}
