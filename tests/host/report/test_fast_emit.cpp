// The decode driver (fast_decode.hpp): the same bytes, corrupt reports and counts on one thread and on two
// (threshold forced low), and the same as reading the file with a CaptureReader frame by frame through one
// FrameEmitter (the lines themselves: test_render.cpp).
#include <catch2/catch.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numeric>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/signals.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture_blocks.hpp"
#include "saulproto/host/capture/compressed.hpp"
#include "saulproto/host/capture/pcap.hpp"
#include "saulproto/host/capture/pcapng.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/bus_stats.hpp"
#include "saulproto/host/report/fast_decode.hpp"
#include "saulproto/host/report/fast_emit.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/frame_text.hpp"
#include "../../../libsaulproto/src/host/capture/capture_io.hpp"
#include "host/capture/candump_model.hpp"
#include "host/read_count.hpp"
#include "host/temp_file.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

/// A file's block starts as a cutter gives them one at a time (pcapng: and where its header blocks end).
struct PcapngBlocks {
  std::vector<std::uint64_t> starts;
  std::uint64_t prefix_end = 0;
};
PcapngBlocks cut_starts(detail::BlockCutter& cut) {
  PcapngBlocks out;
  std::uint64_t start = 0;
  while (cut.next(start)) out.starts.push_back(start);
  out.prefix_end = cut.prefix_end();
  return out;
}

/// Frames of every described CAN message (right length, random bytes, so values, names and unnamed values all
/// occur), plus unknown ids, wrong lengths, remote and error frames; each drawn twice or more now and then, so
/// the emitter's cache answers too.
std::vector<CanFrame> random_frames(std::mt19937_64& rng, std::size_t n) {
  std::vector<const saul::signals::MessageDesc*> can;
  for (auto p : {saul::signals::Protocol::saul_can, saul::signals::Protocol::vesc_can})
    for (const auto& m : saul::signals::messages(p)) can.push_back(&m);
  std::vector<CanFrame> out;
  std::uint64_t ns = 1'763'800'000'000'000'000ULL;
  while (out.size() < n) {
    CanFrame f;
    const unsigned kind = static_cast<unsigned>(rng() % 20);
    if (kind < 14) {
      const auto& d = *can[rng() % can.size()];
      if (d.protocol == saul::signals::Protocol::saul_can) {
        f.id = d.id;
      } else {
        f.extended = true;
        f.id = (d.id << 8) | static_cast<std::uint32_t>(rng() % 4 == 0 ? rng() % 256 : 68);
      }
      f.dlc = d.length;
    } else if (kind < 16) {
      f.extended = rng() % 2 == 0;
      f.id = static_cast<std::uint32_t>(rng() % (f.extended ? 0x20000000 : 0x800));
      f.dlc = static_cast<std::uint8_t>(rng() % 9);
    } else if (kind < 17) {
      f.id = 0x300 + static_cast<std::uint32_t>(rng() % 4);
      f.dlc = static_cast<std::uint8_t>(rng() % 9);  // mostly the wrong length
    } else if (kind < 18) {
      f.id = static_cast<std::uint32_t>(rng() % 0x800);
      f.remote = true;
      f.dlc = static_cast<std::uint8_t>(rng() % 9);
    } else if (kind < 19) {
      f.error = true;
      f.id = static_cast<std::uint32_t>(rng() % 0x400);
      f.dlc = 8;
    } else {
      const auto& d = *can[rng() % can.size()];  // small values: names and multiplexers hit often
      f.id = d.protocol == saul::signals::Protocol::saul_can ? d.id : (d.id << 8 | 56);
      f.extended = d.protocol == saul::signals::Protocol::vesc_can;
      f.dlc = d.length;
      for (std::size_t i = 0; i < f.dlc; ++i) f.data[i] = static_cast<std::uint8_t>(rng() % 4);
      ns += rng() % 3'000'000;
      f.timestamp_ns = ns;
      out.push_back(f);
      continue;
    }
    if (!f.remote)
      for (std::size_t i = 0; i < f.dlc; ++i) f.data[i] = static_cast<std::uint8_t>(rng());
    // mostly forward, now and then back in time (delta and rel are negative then)
    if (rng() % 50 == 0) {
      ns -= rng() % 5'000'000'000ULL;
    } else {
      ns += rng() % 3'000'000;
    }
    f.timestamp_ns = ns;
    out.push_back(f);
    if (rng() % 4 == 0) {
      f.timestamp_ns = ns += 1000;
      out.push_back(f);
    }
  }
  return out;
}

}  // namespace

namespace {

/// A candump log with comments, blank lines, CRLF, corrupt lines and one over-long line, from random frames.
std::string random_log(std::mt19937_64& rng, std::size_t frames) {
  std::string log = "# a comment\n";
  const auto fs = random_frames(rng, frames);
  for (std::size_t i = 0; i < fs.size(); ++i) {
    if (fs[i].error && fs[i].id == 0) continue;
    log += format_candump_line(fs[i], i % 5 == 0 ? "vcan1" : "can0");
    log += i % 97 == 0 ? "\r\n" : "\n";
    if (i % 301 == 0) log += "(1763800000.000000) can0 30G#00\n";
    if (i % 509 == 0) log += "\n";
    if (i == fs.size() / 2) log += "(1763800000.000000) can0 300#" + std::string(kMaxCandumpLine + 10, 'A') + "\n";
  }
  log += "(1763800000.000000) can0 123#11";  // no newline at the end
  return log;
}

struct Decoded {
  std::string out;
  std::vector<std::string> corrupt;
  FrameDecodeResult result;
  std::uint64_t progress_bytes = 0;  ///< the last progress report's
};

/// What a decode_*() call wrote, reported and counted.
template <class Decode>
Decoded run_with(Decode&& decode) {
  Decoded d;
  FrameDecodeSinks sinks;
  sinks.write = [&](std::string_view s) { d.out.append(s); };
  sinks.corrupt = [&](const CaptureError& e) { d.corrupt.push_back(format_capture_error("f", e)); };
  sinks.progress = [&](std::uint64_t, std::uint64_t bytes) { d.progress_bytes = bytes; };
  d.result = decode(sinks);
  return d;
}

/// decode_capture of the file at `path`, opened as saulctl decode opens it (any format, compressed or not).
FrameDecodeResult decode_file(const std::string& path, const FrameDecodeOptions& o, const FrameDecodeSinks& sinks) {
  auto opened = open_capture(path);
  REQUIRE(opened.frames);
  return decode_capture(path, opened.frames, opened.compressed, o, sinks);
}

Decoded run(const std::string& path, const FrameDecodeOptions& o) {
  return run_with([&](const FrameDecodeSinks& sinks) { return decode_file(path, o, sinks); });
}

/// The reference: a reader record by record, its frames that pass `ids` (all when null) through one FrameEmitter
/// (whose lines test_render.cpp holds to lines written by hand).
struct Expected {
  std::string out;
  std::vector<std::string> corrupt;
};
Expected expected_from(CaptureReader& reader, DecodeFormat format, TimeMode mode,
                       const std::set<std::uint32_t>* ids = nullptr) {
  Expected e;
  FrameEmitter emitter(format, mode);
  fmt::memory_buffer out;
  DecodeCounts counts;
  for (FrameBatch batch; reader.next_batch(batch);)
    batch.walk(
        [&](std::size_t i) {
          if (ids != nullptr && !ids->count(batch.frames[i].id)) return;
          emitter.add(batch.frames[i], batch.interfaces[i], out, counts);
        },
        [&](const CaptureError& error) { e.corrupt.push_back(format_capture_error("f", error)); });
  e.out.assign(out.data(), out.size());
  return e;
}

}  // namespace

TEST_CASE("fast decode on two threads: what a decoding thread or the writer throws ends the decode with it") {
  // The blocks-in-order engine (host/threads/in_order.hpp) under both failures: a block's work throws (here the --id
  // filter, which runs on the decoding threads), or handing a block on throws (the writer). Either way the
  // exception comes out of decode_capture, the threads are stopped and joined, and nothing hangs.
  std::mt19937_64 rng(31);
  TempFile file(random_log(rng, 20000));
  FrameDecodeOptions o;
  o.read.threads = 2;
  o.read.parallel_from = 0;
  o.read.block = 4096;
  FrameDecodeSinks sinks;
  std::size_t writes = 0;
  sinks.write = [&](std::string_view) { ++writes; };
  sinks.corrupt = [](const CaptureError&) {};
  std::atomic<int> seen{0};
  o.keep = [&](const saul::CanFrame&) {
    if (++seen == 12345) throw std::runtime_error("filter failed");
    return true;
  };
  REQUIRE_THROWS_WITH(decode_file(file.path, o, sinks), "filter failed");
  CHECK(writes < 20000 * 45 / 4096);  // stopped early: not every block was written

  o.keep = {};
  writes = 0;
  sinks.write = [&](std::string_view) {
    if (++writes == 7) throw std::runtime_error("disk full");
  };
  REQUIRE_THROWS_WITH(decode_file(file.path, o, sinks), "disk full");
  CHECK(writes == 7);  // nothing written after the failure
}

TEST_CASE("fast decode: two threads give the bytes, reports and counts of one thread and of the line-by-line model") {
  std::mt19937_64 rng(7);
  const std::string log = random_log(rng, 20000);
  TempFile file(log);
  const std::set<std::uint32_t> some = {0x300, 0x400, (9u << 8) | 68};
  for (auto format : {DecodeFormat::text, DecodeFormat::csv, DecodeFormat::jsonl}) {
    for (auto mode : {TimeMode::absolute, TimeMode::relative, TimeMode::delta}) {
      for (const std::set<std::uint32_t>* ids : {static_cast<const std::set<std::uint32_t>*>(nullptr), &some}) {
        INFO("format " << static_cast<int>(format) << " time " << static_cast<int>(mode) << " filter " << (ids != nullptr));
        FrameDecodeOptions o;
        o.format = format;
        o.time = mode;
        if (ids != nullptr) o.keep = [ids](const saul::CanFrame& f) { return ids->count(f.id) != 0; };
        o.read.threads = 1;
        const Decoded one = run(file.path, o);
        o.read.threads = 2;
        o.read.parallel_from = 0;
        o.read.block = 4096;  // many blocks, some inside the over-long line
        const Decoded two = run(file.path, o);
        CHECK(one.out == two.out);
        CHECK(one.corrupt == two.corrupt);
        CHECK(one.progress_bytes == log.size());
        CHECK(two.progress_bytes == log.size());
        CHECK(one.result.records == two.result.records);
        CHECK(one.result.corrupt == two.result.corrupt);
        CHECK(one.result.counts.frames == two.result.counts.frames);
        CHECK(one.result.counts.decoded == two.result.counts.decoded);
        CHECK(one.result.counts.rejected == two.result.counts.rejected);

        // The reference: the log line by line (test::CandumpLineModel), one FrameEmitter.
        std::istringstream in(log);
        test::CandumpLineModel reader(in);
        const auto [expected, corrupt] = expected_from(reader, format, mode, ids);
        CHECK(one.out == expected);
        // The model holds the over-long line and parses it ("more than 8 data bytes"); the scanner reports
        // it by its length. Every other report is the same.
        REQUIRE(corrupt.size() == one.corrupt.size());
        std::size_t differ = 0;
        for (std::size_t i = 0; i < corrupt.size(); ++i)
          if (corrupt[i] != one.corrupt[i]) {
            ++differ;
            CHECK(one.corrupt[i].find("line longer than 65536 bytes (line skipped)") != std::string::npos);
          }
        CHECK(differ == 1);
      }
    }
  }
}

namespace {

void put_u32(std::string& s, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s += static_cast<char>((v >> (8 * i)) & 0xFF);
}

/// A little-endian pcap file header, written out by hand: microseconds, version 2.4, snaplen 65535,
/// LINKTYPE_CAN_SOCKETCAN.
std::string raw_pcap_header() {
  std::string h;
  put_u32(h, 0xA1B2C3D4), put_u32(h, 0x00040002), put_u32(h, 0), put_u32(h, 0), put_u32(h, 65535), put_u32(h, 227);
  return h;
}

/// A little-endian pcapng section header (version 1.0, no section length, no options) and interface 0
/// (LINKTYPE_CAN_SOCKETCAN, no options), written out by hand.
std::string raw_pcapng_head() {
  std::string h;
  put_u32(h, 0x0A0D0D0A), put_u32(h, 28), put_u32(h, 0x1A2B3C4D), put_u32(h, 1), put_u32(h, 0xFFFFFFFF),
      put_u32(h, 0xFFFFFFFF), put_u32(h, 28);
  put_u32(h, 1), put_u32(h, 20), put_u32(h, 227), put_u32(h, 0), put_u32(h, 20);
  return h;
}

/// A little-endian pcap record header and `payload_bytes` zero bytes, written out by hand.
std::string raw_pcap_record(std::uint32_t sec, std::uint32_t usec, std::uint32_t payload_bytes) {
  std::string r;
  put_u32(r, sec);
  put_u32(r, usec);
  put_u32(r, payload_bytes);
  put_u32(r, payload_bytes);
  r.append(payload_bytes, '\0');
  return r;
}

Decoded run_pcap(const std::string& path, const FrameDecodeOptions& o) { return run(path, o); }

}  // namespace

namespace {

/// A capture's statistics as stats counted them before blocks: its reader's records one at a time.
struct CountedByReader {
  std::string text;
  std::string json;
  std::vector<std::string> corrupt;  // format_capture_error("f", ...)
};
CountedByReader count_by_reader(CaptureReader& reader) {
  BusStats one;
  CountedByReader r;
  for (FrameBatch batch; reader.next_batch(batch);)
    batch.walk([&](std::size_t i) { one.add(batch.frames[i], batch.interfaces[i]); },
               [&](const CaptureError& e) {
                 one.add_corrupt();
                 r.corrupt.push_back(format_capture_error("f", e));
               });
  r.text = one.text("f");
  r.json = one.json("f").dump();
  return r;
}

/// stats of the file at `path` as saulctl stats counts it (add_capture), its corrupt records' reports, records
/// and progress.
struct CountedByPath : CountedByReader {
  std::uint64_t records = 0, progress = 0, counted = 0;
};
CountedByPath count_by_path(const std::string& path, const ReadOptions& read) {
  auto opened = open_capture(path);
  REQUIRE(opened.frames);
  BusStats stats;
  CountedByPath r;
  add_capture(
      stats, path, opened.frames, opened.compressed, read,
      [&](const CaptureError& e) { r.corrupt.push_back(format_capture_error("f", e)); },
      [&](std::uint64_t n, std::uint64_t bytes) {
        r.records = n;
        r.progress = bytes;
      });
  r.text = stats.text("f");
  r.json = stats.json("f").dump();
  r.counted = stats.frames() + stats.corrupt();
  return r;
}

/// stats of the file at `path` counted in blocks of `block_bytes` on two threads against stats of `reader` (the same
/// file) frame by frame: the same report, the same corrupt records in the same order, and progress up to the file's
/// size.
void check_stats_in_blocks(const std::string& path, CaptureReader& reader, std::uint64_t block_bytes,
                           std::uint64_t size) {
  const CountedByReader one = count_by_reader(reader);
  const auto blocks = CaptureBlocks::open(path, block_bytes);
  REQUIRE(blocks);
  CHECK(blocks->count() > 10);
  ReadOptions read;
  read.parallel_from = 0;
  read.block = block_bytes;
  const CountedByPath two = count_by_path(path, read);
  CHECK(two.text == one.text);
  CHECK(two.json == one.json);
  CHECK(two.corrupt == one.corrupt);
  CHECK(one.corrupt.size() > 10);
  CHECK(two.progress == size);
}

/// The statistics of an uncompressed candump file as stats counts it on one thread.
CountedByReader count_candump_file(const std::string& path) {
  ReadOptions read;
  read.threads = 1;
  return count_by_path(path, read);
}

/// stats of the compressed candump log at `path` in blocks of 4 KiB cut as it inflates against `one`: the figures,
/// the corrupt records' reports, the records counted and progress to the compressed size.
void check_stats_of_text(const std::string& path, const CountedByReader& one) {
  ReadOptions read;
  read.block = 4096;
  const CountedByPath two = count_by_path(path, read);
  CHECK(two.text == one.text);
  CHECK(two.json == one.json);
  CHECK(two.corrupt == one.corrupt);
  CHECK(two.records == two.counted);
  CHECK(two.progress == std::filesystem::file_size(path));
}

}  // namespace

TEST_CASE("fast decode: a pcap file in blocks on two threads gives the bytes and reports of one thread and of PcapReader") {
  // Random frames, with corrupt records among them (a fraction of a second too large, a record longer than any
  // SocketCAN packet: both skipped) and a record cut by the end of the file (the end).
  std::mt19937_64 rng(11);
  const auto frames = random_frames(rng, 20000);
  std::ostringstream pcap;
  PcapWriter writer(pcap);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    writer.write(frames[i], "can0");
    writer.flush();
    if (i % 997 == 0) pcap << raw_pcap_record(1763800000, 1'000'000, 16);
    if (i % 1999 == 0) pcap << raw_pcap_record(1763800000, 5, 100);
  }
  pcap << raw_pcap_record(1763800001, 5, 16).substr(0, 20);
  TempFile file(pcap.str());
  for (auto format : {DecodeFormat::text, DecodeFormat::csv, DecodeFormat::jsonl}) {
    for (auto mode : {TimeMode::absolute, TimeMode::relative}) {
      INFO("format " << static_cast<int>(format) << " time " << static_cast<int>(mode));
      FrameDecodeOptions o;
      o.format = format;
      o.time = mode;
      o.read.threads = 1;
      const Decoded one = run_pcap(file.path, o);
      o.read.threads = 2;
      o.read.parallel_from = 0;
      o.read.block = 4096;
      const Decoded two = run_pcap(file.path, o);
      CHECK(one.out == two.out);
      CHECK(one.corrupt == two.corrupt);
      CHECK(one.result.records == two.result.records);
      CHECK(one.result.counts.decoded == two.result.counts.decoded);

      std::istringstream in(pcap.str());
      PcapReader reader(in);
      const auto [expected, corrupt] = expected_from(reader, format, mode);
      CHECK(two.out == expected);
      CHECK(two.corrupt == corrupt);
      CHECK(corrupt.size() == 20000 / 997 + 1 + 20000 / 1999 + 1 + 1);
      CHECK(two.progress_bytes == pcap.str().size());  // progress counts each block's bytes once
    }
  }
  SECTION("stats in blocks: one thread's figures and reports") {
    std::istringstream in(pcap.str());
    PcapReader reader(in);
    check_stats_in_blocks(file.path, reader, 4096, pcap.str().size());
  }
}

namespace {

/// A little-endian Enhanced Packet Block of interface `iface` with a 16-byte SocketCAN packet of id 0x123 and
/// `length` data bytes (1; above 8 is bad), written out by hand; `trailing` the length at its end and `captured` the
/// packet's captured length (48 and 16 unless testing bad ones).
std::string raw_epb(std::uint32_t iface, std::uint32_t trailing = 48, std::uint32_t captured = 16, char length = 1) {
  std::string b;
  put_u32(b, 6);
  put_u32(b, 48);
  put_u32(b, iface);
  put_u32(b, 0);       // timestamp high
  put_u32(b, 12345);   // timestamp low
  put_u32(b, captured);
  put_u32(b, 16);      // original
  b += std::string("\x00\x00\x01\x23", 4) + length + std::string("\x00\x00\x00\x42\x00\x00\x00\x00\x00\x00\x00", 11);
  put_u32(b, trailing);
  return b;
}

/// A 16-byte block of a type no reader knows (0x0BAD), its trailing length `trailing` (16 unless testing a bad one).
std::string raw_unknown_block(std::uint32_t trailing = 16) {
  std::string b;
  put_u32(b, 0x0BAD);
  put_u32(b, 16);
  put_u32(b, 0);
  put_u32(b, trailing);
  return b;
}

Decoded run_pcapng(const std::string& path, const FrameDecodeOptions& o) { return run(path, o); }

}  // namespace

TEST_CASE("fast decode: a pcapng file in blocks on two threads gives the bytes and reports of PcapngReader") {
  // Random frames on two interfaces (the second one's description block comes late: from there the file is not
  // cut), with bad blocks among them: a trailing length that differs, a packet of an undeclared interface, a
  // captured length past the block, a SocketCAN packet with 9 data bytes (each skipped and reported), an unknown
  // block type, and a block cut by the end of the file.
  std::mt19937_64 rng(13);
  const auto frames = random_frames(rng, 20000);
  std::ostringstream png;
  PcapngWriter writer(png);
  // Before the first packet, so in what every block reads first: reported once. Its trailing length differs.
  png << raw_unknown_block(20);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    writer.write(frames[i], i >= 15000 && i % 3 == 0 ? "vcan1" : "can0");
    writer.flush();
    if (i % 997 == 0) png << raw_epb(0, 52);
    if (i % 1999 == 0) png << raw_epb(9);
    if (i % 1499 == 0) png << raw_epb(0, 48, 17);     // captured past the block's end
    if (i % 1777 == 0) png << raw_epb(0, 48, 16, 9);  // SocketCAN payload_length 9
    if (i == 17000) png << raw_unknown_block();
  }
  png << raw_epb(0).substr(0, 30);
  TempFile file(png.str());
  {
    const int fd = ::open(file.path.c_str(), O_RDONLY);
    const auto cut = cut_starts(*detail::pcapng_block_cutter(fd, png.str().size(), 4096));
    CHECK(cut.starts.size() > 100);  // it was cut...
    CHECK(cut.starts[cut.starts.size() - 2] < png.str().size() * 3 / 4);  // ...up to the second interface
    // CaptureBlocks cuts it as its blocks are asked for, here by two threads at once in no order: the same blocks.
    const auto blocks = CaptureBlocks::of(fd, png.str().size(), CaptureFormat::pcapng, 4096);
    REQUIRE(blocks);
    std::vector<std::size_t> asked(cut.starts.size() + 5);
    std::iota(asked.begin(), asked.end(), std::size_t{0});
    std::shuffle(asked.begin(), asked.end(), rng);
    std::atomic<std::size_t> wrong{0};
    auto ask = [&](std::size_t from) {
      for (std::size_t i = from; i < asked.size(); i += 2)
        if (blocks->has(asked[i]) != (asked[i] + 1 < cut.starts.size())) ++wrong;
    };
    std::thread other(ask, 1);
    ask(0);
    other.join();
    CHECK(wrong == 0);
    CHECK(blocks->count() == cut.starts.size() - 1);
    ::close(fd);
  }
  for (auto format : {DecodeFormat::text, DecodeFormat::jsonl}) {
    for (auto mode : {TimeMode::absolute, TimeMode::relative}) {
      INFO("format " << static_cast<int>(format) << " time " << static_cast<int>(mode));
      FrameDecodeOptions o;
      o.format = format;
      o.time = mode;
      o.read.threads = 2;
      o.read.parallel_from = 0;
      o.read.block = 4096;
      const Decoded two = run_pcapng(file.path, o);

      std::istringstream in(png.str());
      PcapngReader reader(in);
      const auto [expected, corrupt] = expected_from(reader, format, mode);
      CHECK(two.out == expected);
      CHECK(two.corrupt == corrupt);
      CHECK(corrupt.size() == 1 + 20000 / 997 + 1 + 20000 / 1999 + 1 + 20000 / 1499 + 1 + 20000 / 1777 + 1 + 1);
      CHECK(two.result.records == frames.size());
      CHECK(two.progress_bytes == png.str().size());
    }
  }
  SECTION("stats in blocks: one thread's figures and reports") {
    std::istringstream in(png.str());
    PcapngReader reader(in);
    check_stats_in_blocks(file.path, reader, 4096, png.str().size());
  }
}

// A block whose end another thread's has(k + 1) found first (no reader to lend to then) is still lent when its
// reader asks: every block's bytes are read from the file once, and they are the block's.
TEST_CASE("pcap and pcapng blocks cut ahead of their readers are lent late, read once, and read right") {
  std::string png = raw_pcapng_head();  // then 20 000 packets
  std::string pcap = raw_pcap_header();
  for (int i = 0; i < 20000; ++i) {
    png += raw_epb(0);
    pcap += raw_pcap_record(1763800000, static_cast<std::uint32_t>(i), 16);
  }
  for (const auto& [bytes, format] : {std::pair{png, CaptureFormat::pcapng}, std::pair{pcap, CaptureFormat::pcap}}) {
    INFO(to_string(format));
    TempFile file(bytes);
    std::istringstream in(bytes);
    const auto reader = format == CaptureFormat::pcap ? std::unique_ptr<CaptureReader>(new PcapReader(in))
                                                      : std::unique_ptr<CaptureReader>(new PcapngReader(in));
    std::vector<CanFrame> expected;
    for (FrameBatch batch; reader->next_batch(batch);) {
      REQUIRE(batch.corrupt.empty());
      expected.insert(expected.end(), batch.frames.begin(), batch.frames.end());
    }
    REQUIRE(expected.size() == 20000);
    const int fd = ::open(file.path.c_str(), O_RDONLY);
    REQUIRE(fd >= 0);
    const std::uint64_t before = bytes_read_so_far();
    const auto blocks = CaptureBlocks::of(fd, bytes.size(), format, 64 * 1024);
    REQUIRE(blocks);
    CaptureBlocks::Scratch scratch;
    std::vector<CanFrame> got;
    for (std::size_t k = 0; blocks->has(k); ++k) {
      (void)blocks->has(k + 1);  // the walk finds block k's end before block k's reader asks for it
      blocks->read(k, scratch, [&](const FrameBatch& batch) {
        got.insert(got.end(), batch.frames.begin(), batch.frames.end());
        return true;
      });
    }
    const std::uint64_t read = bytes_read_so_far() - before;
    CHECK(got == expected);
    // the file once, and its first 4 KiB (the header, read to open it), and the pcapng header blocks once more
    CHECK(read <= bytes.size() + 4096 + 64 + read_count_cost());
    ::close(fd);
  }
}

// The cutter lends a block's bytes to its reader when it still holds them, and room for the pcapng header blocks is
// kept in front of them: a section header too large for that room, and a pcap file whose cutting stops at an
// implausible record (the rest, larger than the cutter's window, is one block), are read from the file as before.
TEST_CASE("fast decode: pcap/pcapng blocks the cutter cannot lend are read from the file as the readers read them") {
  // pcapng: a section header with a 5000-byte comment (more than the 4 KiB kept in front), interface 0, packets
  std::string png;
  put_u32(png, 0x0A0D0D0A), put_u32(png, 5036), put_u32(png, 0x1A2B3C4D), put_u32(png, 1), put_u32(png, 0xFFFFFFFF),
      put_u32(png, 0xFFFFFFFF);
  put_u32(png, 5000u << 16 | 1);  // opt_comment (code 1, little-endian: the code first) of 5000 bytes
  png.append(5000, 'x');
  put_u32(png, 0), put_u32(png, 5036);  // opt_endofopt, the block's length again
  put_u32(png, 1), put_u32(png, 20), put_u32(png, 227), put_u32(png, 0), put_u32(png, 20);
  for (int i = 0; i < 3000; ++i) png += raw_epb(0);
  // pcap: packets, a record of an implausible length (the reader stops there), 200 KB more
  std::string pcap = raw_pcap_header();
  for (int i = 0; i < 3000; ++i)  // 0x300 with 4 bytes
    pcap += raw_pcap_record(1763800000, static_cast<std::uint32_t>(i), 16)
                .replace(16, 8, std::string("\x00\x00\x03\x00\x04\x00\x00\x00", 8));
  pcap += raw_pcap_record(1763800001, 0, 300 * 1024).substr(0, 16);
  pcap.append(200 * 1024, '\0');
  TempFile png_file(png), pcap_file(pcap);
  FrameDecodeOptions o;
  o.read.threads = 2;
  o.read.parallel_from = 0;
  o.read.block = 4096;
  auto check = [&](const Decoded& two, CaptureReader& reader, std::size_t corrupt_records) {
    const auto [expected, corrupt] = expected_from(reader, o.format, o.time);
    CHECK(two.result.records == 3000);
    CHECK(two.out == expected);
    CHECK(two.corrupt == corrupt);
    CHECK(corrupt.size() == corrupt_records);
  };
  std::istringstream png_in(png), pcap_in(pcap);
  PcapngReader png_reader(png_in);
  PcapReader pcap_reader(pcap_in);
  check(run_pcapng(png_file.path, o), png_reader, 0);
  check(run_pcap(pcap_file.path, o), pcap_reader, 1);  // the record it stopped at
}

namespace {

std::uint32_t get_u32(const std::string& s, std::uint64_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = v << 8 | static_cast<unsigned char>(s[at + static_cast<std::uint64_t>(i)]);
  return v;
}

/// Where a little-endian pcap file is cut into blocks of about `block` bytes, written out plainly: record by record
/// from the first, a start at the first record at least `block` bytes after the last start, until a record that is
/// implausible (longer than 256 KiB) or reaches the end; then the size.
std::vector<std::uint64_t> pcap_starts_model(const std::string& file, std::uint64_t block) {
  std::vector<std::uint64_t> starts{24};
  std::uint64_t pos = 24, last = 24;
  while (pos + 16 <= file.size()) {
    const std::uint32_t incl = get_u32(file, pos + 8);
    if (incl > 256 * 1024) break;
    const std::uint64_t next = pos + 16 + incl;
    if (next >= file.size()) break;
    pos = next;
    if (next - last >= block) starts.push_back(last = next);
  }
  starts.push_back(file.size());
  return starts;
}

/// The same for a little-endian pcapng file: packet blocks (enhanced, simple) after the header blocks, a start at
/// the first packet at least `block` bytes after the last start; the walk stops at a block of a bad length, a second
/// section, or any other block among the packets.
PcapngBlocks pcapng_starts_model(const std::string& file, std::uint64_t block) {
  PcapngBlocks out;
  out.starts = {0};
  std::uint64_t pos = 0, last = 0;
  bool packets = false;
  while (pos + 12 <= file.size()) {
    const std::uint32_t type = get_u32(file, pos);
    if (type == 0x0A0D0D0A && pos != 0) break;
    const std::uint32_t length = get_u32(file, pos + 4);
    if (length < 12 || length % 4 != 0 || pos + length > file.size()) break;
    const bool packet = type == 6 || type == 3;
    if (!packets && packet) {
      packets = true;
      out.prefix_end = pos;
    } else if (packets && !packet) {
      break;
    }
    const std::uint64_t at = pos;
    pos += length;
    if (packet && at - last >= block && at > out.prefix_end) out.starts.push_back(last = at);
  }
  out.starts.push_back(file.size());
  return out;
}

}  // namespace

// The cutters step over runs of records of one length eight at a time: runs of every length up to past eight, of
// other lengths, around every block size, must cut where the record-by-record walk cuts.
TEST_CASE("pcap and pcapng files are cut where a record-by-record walk cuts them") {
  std::mt19937_64 rng(8);
  for (int round = 0; round < 60; ++round) {
    INFO("round " << round);
    std::string pcap = raw_pcap_header();
    std::string png = raw_pcapng_head();
    for (int run = 0, runs = 5 + static_cast<int>(rng() % 60); run < runs; ++run) {
      const std::uint32_t payload = std::array<std::uint32_t, 6>{16, 16, 16, 72, 20, 0}[rng() % 6];
      const std::size_t n = rng() % 3 == 0 ? rng() % 10 : rng() % 40;  // runs shorter and longer than eight
      const bool simple = rng() % 4 == 0;  // simple packet blocks: another type, another length
      for (std::size_t k = 0; k < n; ++k) {
        pcap += raw_pcap_record(1763800000, static_cast<std::uint32_t>(k), payload);
        const std::uint32_t length = (simple ? 16 : 32) + payload;
        put_u32(png, simple ? 3 : 6), put_u32(png, length);
        if (!simple) put_u32(png, 0), put_u32(png, 0), put_u32(png, static_cast<std::uint32_t>(k));  // iface, time
        put_u32(png, payload);
        if (!simple) put_u32(png, payload);
        png.append(payload, '\0');
        put_u32(png, length);
      }
    }
    if (rng() % 3 == 0) pcap += raw_pcap_record(1763800000, 0, 300 * 1024).substr(0, 40);  // implausible: stops
    if (rng() % 3 == 0) png += raw_unknown_block();  // among the packets: stops the cutting
    for (const std::uint64_t block : {1, 31, 32, 48, 100, 255, 256, 257, 1000, 4096, 1 << 30}) {
      INFO("block " << block);
      TempFile a(pcap), b(png);
      const int fa = ::open(a.path.c_str(), O_RDONLY), fb = ::open(b.path.c_str(), O_RDONLY);
      CHECK(cut_starts(*detail::pcap_block_cutter(fa, pcap.size(), false, block)).starts ==
            pcap_starts_model(pcap, block));
      const PcapngBlocks cut = cut_starts(*detail::pcapng_block_cutter(fb, png.size(), block));
      const PcapngBlocks model = pcapng_starts_model(png, block);
      CHECK(cut.starts == model.starts);
      CHECK(cut.prefix_end == model.prefix_end);
      ::close(fa), ::close(fb);
    }
  }
}

namespace {

/// decode_capture of the compressed candump log at `path`: its text cut into blocks as it inflates.
Decoded run_text(const std::string& path, const FrameDecodeOptions& o) {
  REQUIRE(open_capture(path).compressed);
  return run(path, o);
}

}  // namespace

TEST_CASE("fast decode: a compressed candump log cut into blocks as it inflates gives the uncompressed file's decode and stats") {
  // random_log has corrupt lines, CRLF, blank lines, a line longer than kMaxCandumpLine, a last line without
  // newline; here also a comment longer than that. decode_capture over the gzip and zstd forms, in blocks of
  // 4 KiB on two threads, must give what it gives for the plain text on one thread: the same bytes,
  // reports (line numbers across blocks, the over-long lines reported once), counts, and progress to the size of
  // the compressed file.
  std::mt19937_64 rng(17);
  std::string log = random_log(rng, 20000);
  log.insert(log.find('\n', log.size() / 3) + 1, "# " + std::string(3 * kMaxCandumpLine, 'c') + "\n");
  TempFile plain(log);
  FrameDecodeOptions o;
  o.read.threads = 1;
  const Decoded expected = run(plain.path, o);
  REQUIRE(expected.corrupt.size() > 50);
  o.read.threads = 2;
  o.read.block = 4096;
  for (const Compression compression : {Compression::gzip, Compression::zstd}) {
    INFO(to_string(compression));
    TempFile copy(log);
    const std::string packed = compress_file(copy.path, compression);
    struct Remove {
      std::string path;
      ~Remove() { std::remove(path.c_str()); }
    } remove{packed};
    for (const auto format : {DecodeFormat::text, DecodeFormat::jsonl}) {
      o.format = format;
      o.read.threads = 1;
      const Decoded one = run(plain.path, o);
      o.read.threads = 2;
      const Decoded two = run_text(packed, o);
      CHECK(two.out == one.out);
      CHECK(two.corrupt == one.corrupt);
      CHECK(two.result.records == one.result.records);
      CHECK(two.result.corrupt == one.result.corrupt);
      CHECK(two.result.counts.decoded == one.result.counts.decoded);
      CHECK(two.progress_bytes == std::filesystem::file_size(packed));
    }
    // stats: the plain file's figures and reports (an over-long line too: as the scanner reports it)
    const CountedByReader plain_stats = count_candump_file(plain.path);
    CHECK(plain_stats.corrupt.size() == expected.corrupt.size());
    check_stats_of_text(packed, plain_stats);
    o.format = DecodeFormat::text;
    o.time = TimeMode::relative;  // needs the first frame's time before the blocks: read in batches, in order
    o.read.threads = 1;
    const Decoded relative_one = run(plain.path, o);
    o.read.threads = 2;
    CHECK(run_text(packed, o).out == relative_one.out);
    o.time = TimeMode::absolute;
  }

  SECTION("a truncated gzip log: the frames before the cut, then the reader's decompression error") {
    std::string small;
    for (std::size_t i = 0; i < 5000; ++i) small += fmt::format("(1763800000.{:06}) can0 300#E8030CFE\n", i);
    TempFile copy(small);
    const std::string packed = compress_file(copy.path, Compression::gzip);
    std::string bytes;
    {
      std::ifstream in(packed, std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    std::remove(packed.c_str());
    TempFile cut(bytes.substr(0, bytes.size() * 2 / 3));
    o.read.threads = 1;
    const Decoded by_reader = run(cut.path, o);
    REQUIRE_FALSE(by_reader.corrupt.empty());  // the decompression error, at the end
    o.read.threads = 2;
    const Decoded two = run_text(cut.path, o);
    CHECK(two.out == by_reader.out);
    CHECK(two.corrupt == by_reader.corrupt);
    CHECK(two.result.records == by_reader.result.records);
    auto again = open_capture_reader(cut.path);
    const CountedByReader reader_stats = count_by_reader(*again);
    CHECK(reader_stats.corrupt.back().find("gzip") != std::string::npos);  // the decompression error, last
    check_stats_of_text(cut.path, reader_stats);
  }
}

TEST_CASE("memo judge: a cache with too few hits is skipped for a while, then judged again") {
  MemoJudge judge;
  const auto misses = [&](int n) {
    for (int i = 0; i < n; ++i) {
      REQUIRE(judge.use());
      judge.looked(false);
    }
  };
  misses(256);  // judged: no hits
  int skipped = 0;
  while (!judge.use()) ++skipped;
  CHECK(skipped == 4096);
  judge.looked(false);
  // 16 hits in 256 (1 in 16) keep it
  for (int i = 0; i < 255; ++i) {
    REQUIRE(judge.use());
    judge.looked(i < 16);
  }
  CHECK(judge.use());
  judge.looked(false);
  for (int i = 0; i < 255; ++i) {  // 15 in 256 do not
    REQUIRE(judge.use());
    judge.looked(i < 15);
  }
  CHECK_FALSE(judge.use());
}

TEST_CASE("frame emitter: its cache, on, skipped by its judge where contents never repeat, then on again, changes no line") {
  // Phases: 5 contents over and over (the cache answers), then contents that never repeat (a counter: the judge
  // turns the cache off), the first 5 again (still off, then on), random frames of every kind, a counter again.
  std::mt19937_64 rng(34);
  const auto varied = random_frames(rng, 3000);
  std::vector<CanFrame> frames;
  std::uint64_t ns = 1'763'800'000'000'000'000ULL;
  const auto add = [&](CanFrame f) {
    f.timestamp_ns = ns += 1000;
    frames.push_back(f);
  };
  const auto counter = [&](std::uint32_t n) {
    for (std::uint32_t i = 0; i < n; ++i) {
      CanFrame f;
      f.id = (27u << 8) | 68;  // VESC STATUS_5
      f.extended = true;
      f.dlc = 8;
      for (std::size_t b = 0; b < 4; ++b) f.data[b] = static_cast<std::uint8_t>(i >> (8 * b));
      add(f);
    }
  };
  for (int i = 0; i < 2000; ++i) add(varied[static_cast<std::size_t>(i % 5)]);
  counter(6000);
  for (int i = 0; i < 6000; ++i) add(varied[static_cast<std::size_t>(i % 5)]);
  for (const auto& f : varied) add(f);
  counter(5000);
  for (auto format : {DecodeFormat::text, DecodeFormat::csv, DecodeFormat::jsonl}) {
    INFO("format " << static_cast<int>(format));
    FrameEmitter emitter(format, TimeMode::absolute);
    DecodeCounts counts, cold_counts;
    std::size_t differ = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      fmt::memory_buffer line, cold_line;
      emitter.add(frames[i], "can0", line, counts);
      FrameEmitter cold(format, TimeMode::absolute);  // the reference: an emitter that has seen nothing
      cold.add(frames[i], "can0", cold_line, cold_counts);
      if (fmt::to_string(line) != fmt::to_string(cold_line) && differ++ < 3)
        CHECK(fmt::to_string(line) == fmt::to_string(cold_line));
    }
    CHECK(differ == 0);
    CHECK(counts.frames == cold_counts.frames);
    CHECK(counts.decoded == cold_counts.decoded);
    CHECK(counts.rejected == cold_counts.rejected);
  }
}
