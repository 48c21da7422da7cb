// Capture formats through their common interface: one round trip every format plugs into, telling a format by
// content and by extension, the open_* factories, copy_frames and conversion_losses. Each format against bytes
// and lines written out by hand or by the reference tools is in test_captures_pcap.cpp (pcap, pcapng) and
// test_captures_text.cpp (Vector ASC, candump), corrupt input included.
#include <catch2/catch.hpp>
#include <fmt/format.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/asc.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "test_captures.hpp"
#include "../temp_file.hpp"

using saul::CanFrame;
using namespace saul::host;
using namespace capture_test;

// ---- one round trip, every format ----

TEST_CASE("every capture format writes and reads back the same frames at its resolution") {
  const std::uint64_t t0 = 1763800000 * kSec;
  const std::vector<std::pair<CanFrame, std::string>> frames = {
      {make(0x300, false, {0xE8, 0x03, 0x0C, 0xFE}, t0 + 900'123), "can0"},              // standard, ns truncated
      {make(0x1FFFFFFF, true, {1, 2, 3, 4, 5, 6, 7, 8}, t0 + 500'000'000), "can0"},      // extended, 8 bytes
      {remote(0x123, false, 4, t0 + 600'000'000), "can1"},                               // remote, length 4
      {remote(0x344, true, 0, t0 + 600'000'001), "can1"},                                // extended remote, length 0
      {error_frame(0x040, {0, 0, 0, 0, 0, 0, 0x7F, 0x80}, t0 + 700'000'000), "can0"},    // bus-off, counters
      {make(0x7FF, false, {}, t0 + 800'000'000), "can1"},                                // 0 bytes
      {make(0x000, false, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}, t0 + 900'000'000), "can0"},
      {make(0x300, true, {0x01, 0x02}, t0 + 2 * kSec + 999), "can0"},  // a 29-bit id that looks like 0x300
      {make(0x401, false, {0xB0, 0x04}, t0 + 3'600 * kSec + 1'000), "can0"},  // an hour later
  };
  const CaptureFormat format =
      GENERATE(CaptureFormat::candump, CaptureFormat::pcap, CaptureFormat::pcapng, CaptureFormat::asc);
  const CaptureTraits traits = capture_traits(format);
  INFO("format " << to_string(format));

  // What the format keeps of each frame.
  std::vector<CanFrame> expected;
  std::vector<std::string> expected_names;
  for (const auto& [f, name] : frames) {
    CanFrame e = f;
    e.timestamp_ns = *f.timestamp_ns - *f.timestamp_ns % traits.resolution_ns;
    if (e.error && !traits.error_details) {
      e.id = 0x080;
      e.dlc = 8;
      e.data = {};
    }
    expected.push_back(e);
    expected_names.push_back(traits.interface_names || traits.channel_order ? name : "can0");
  }
  auto check = [&](const Read& r) {
    CHECK(r.errors.empty());
    REQUIRE(r.frames.size() == expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
      INFO("frame " << i);
      CHECK(r.frames[i].same_wire(expected[i]));
      CHECK(r.frames[i].timestamp_ns == expected[i].timestamp_ns);
      CHECK(r.names[i] == expected_names[i]);
    }
  };

  SECTION("through a stream") {
    std::stringstream buffer;
    auto writer = make_capture_writer(buffer, format);
    for (const auto& [f, name] : frames) writer->write(f, name);
    writer->close();
    writer->close();  // idempotent
    CHECK_THROWS_AS(writer->write(frames[0].first, "can0"), std::runtime_error);
    const std::string bytes = buffer.str();
    CHECK(detect_capture_format(as_bytes(bytes)) == format);
    std::istringstream in(bytes);
    auto reader = make_capture_reader(in, format);
    CHECK(reader->format() == format);
    check(read_all(*reader));
  }

  SECTION("through a file, told by content") {
    const std::string path = (scratch_dir() / ("round_trip_" + std::string(to_string(format)) + ".dat")).string();
    {
      auto writer = open_capture_writer(path, format);
      for (const auto& [f, name] : frames) writer->write(f, name);
      writer->close();
    }
    auto reader = open_capture_reader(path);  // ".dat" says nothing: the content does
    CHECK(reader->format() == format);
    check(read_all(*reader));
    std::filesystem::remove(path);
    std::error_code ignored;
    std::filesystem::remove(scratch_dir(), ignored);  // only once empty
  }

  SECTION("invalid frames are refused") {
    std::stringstream buffer;
    auto writer = make_capture_writer(buffer, format);
    CHECK_THROWS_AS(writer->write(make(0x800, false, {}, 0), "can0"), std::invalid_argument);
    CanFrame long_frame = make(0x100, false, {}, 0);
    long_frame.dlc = 9;
    CHECK_THROWS_AS(writer->write(long_frame, "can0"), std::invalid_argument);
  }
}

// ---- detection and the factories ----

TEST_CASE("capture formats are told by content, then by extension") {
  auto detect = [](const std::string& s) { return detect_capture_format(as_bytes(s)); };
  CHECK(detect("\xD4\xC3\xB2\xA1....") == CaptureFormat::pcap);
  CHECK(detect("\xA1\xB2\xC3\xD4....") == CaptureFormat::pcap);
  CHECK(detect("\x4D\x3C\xB2\xA1....") == CaptureFormat::pcap);
  CHECK(detect("\xA1\xB2\x3C\x4D....") == CaptureFormat::pcap);
  CHECK(detect(std::string("\x0A\x0D\x0D\x0A\x1C\x00\x00\x00", 8)) == CaptureFormat::pcapng);
  CHECK(detect("# made by hand\n\n(1700000000.000000) can0 123#\n") == CaptureFormat::candump);
  CHECK(detect("// version 18.2.0\ndate Tue Nov 14 22:13:20 2023\n") == CaptureFormat::asc);
  CHECK(detect("base hex  timestamps absolute\n") == CaptureFormat::asc);
  CHECK(detect("Begin Triggerblock\n") == CaptureFormat::asc);
  CHECK_FALSE(detect("hello world\n"));
  CHECK_FALSE(detect(""));
  CHECK(capture_format_from_extension("/tmp/run.PCAPNG") == CaptureFormat::pcapng);
  CHECK(capture_format_from_extension("a.b/run.log") == CaptureFormat::candump);
  CHECK(capture_format_from_extension("x.asc") == CaptureFormat::asc);
  CHECK(capture_format_from_extension("x.pcap") == CaptureFormat::pcap);
  CHECK_FALSE(capture_format_from_extension("a.b/run"));
  CHECK(capture_format_from_name("log") == CaptureFormat::candump);
  CHECK_FALSE(capture_format_from_name("mf4"));
}

TEST_CASE("open_capture_reader: the bundled sample, and files that do not open") {
  auto reader = open_capture_reader(std::string(SAUL_SOURCE_DIR) + "/captures/robot_bus.log");
  CHECK(reader->format() == CaptureFormat::candump);
  const Read r = read_all(*reader);
  CHECK(r.frames.size() == 452);
  CHECK(r.errors.empty());

  CHECK_THROWS_AS(open_capture_reader("/nonexistent/x.log"), CaptureOpenError);
  const auto dir = scratch_dir();
  const std::string unknown = (dir / "notes.txt").string();
  std::ofstream(unknown) << "nothing here\n";
  CHECK_THROWS_WITH(open_capture_reader(unknown), Catch::Contains("cannot tell the format"));
  const std::string empty_log = (dir / "empty.log").string();
  std::ofstream(empty_log).close();
  CHECK(read_all(*open_capture_reader(empty_log)).frames.empty());  // by extension
  CHECK_THROWS_AS(open_capture_writer((dir / "out.xyz").string()), CaptureOpenError);
  std::filesystem::remove(unknown);
  std::filesystem::remove(empty_log);
  std::error_code ignored;
  std::filesystem::remove(dir, ignored);  // only once empty
}

TEST_CASE("read_in_order gives next_batch()'s records in file order, read ahead or not, and stops when told") {
  std::string text;  // 20 000 frames over a few batches, a corrupt line every 997
  for (int i = 0; i < 20000; ++i) {
    text += fmt::format("(1700000000.{:06}) can{} {:03X}#{:02X}\n", i, i % 3, i % 0x7FF, i % 256);
    if (i % 997 == 5) text += "(1700000000.000000) can0 3G0#00\n";
  }
  const TempFile file(text);
  std::vector<std::string> want;  // "can1 123" per frame, "!LINE" per corrupt record, from next_batch()
  auto one = open_capture_reader(file.path);
  for (FrameBatch b; one->next_batch(b);)
    b.walk([&](std::size_t i) { want.push_back(fmt::format("{} {:X}", b.interfaces[i], b.frames[i].id)); },
           [&](const CaptureError& e) { want.push_back(fmt::format("!{}", e.position)); });
  REQUIRE(want.size() == 20000 + 21);
  for (const std::uint64_t from : {std::uint64_t{0}, std::uint64_t{1} << 40}) {  // read ahead on a thread, or not
    INFO(from);
    ReadOptions o;
    o.parallel_from = from;
    auto reader = open_capture_reader(file.path);
    std::vector<std::string> got;
    std::uint64_t progress = 0;
    const ReadCounts counts = read_in_order(
        reader, o,
        [&](const FrameBatch& b) {
          b.walk([&](std::size_t i) { got.push_back(fmt::format("{} {:X}", b.interfaces[i], b.frames[i].id)); },
                 [&](const CaptureError& e) { got.push_back(fmt::format("!{}", e.position)); });
          return true;
        },
        [&](std::uint64_t records, std::uint64_t) { progress = records; });
    CHECK(got == want);
    CHECK(counts.frames == 20000);
    CHECK(counts.corrupt == 21);
    CHECK(progress == 20021);
    auto again = open_capture_reader(file.path);
    int calls = 0;
    const ReadCounts stopped = read_in_order(again, o, [&](const FrameBatch&) { return ++calls < 2; });
    CHECK(calls == 2);  // the batch that said stop was the last one handed on
    CHECK(stopped.frames < 20000);
  }
}

TEST_CASE("copy_frames counts what it copies and conversion_losses says what a format drops") {
  std::istringstream in(
      "(1.000000) vcan0 123#11\n(2.000000) can1 20000080#0000000000000000\nbroken\n(x) can0 1#\n");
  std::unique_ptr<CaptureReader> reader = std::make_unique<CandumpReader>(in);
  std::ostringstream out;
  AscWriter writer(out);
  std::vector<std::uint64_t> bad_lines;
  const CopyStats stats = copy_frames(reader, writer, [&](const CaptureError& e) { bad_lines.push_back(e.position); });
  CHECK(stats.frames == 2);
  CHECK(stats.corrupt == 1);
  CHECK(bad_lines == std::vector<std::uint64_t>{4});
  CHECK(stats.interfaces == std::vector<std::string>{"vcan0", "can1"});
  const auto notes = conversion_losses(stats, CaptureFormat::asc);
  REQUIRE(notes.size() == 2);
  CHECK(notes[0] == "asc keeps no interface names: vcan0 reads back as can0");
  CHECK(notes[1].find("1 error frame(s)") != std::string::npos);
  CHECK(conversion_losses(stats, CaptureFormat::pcapng).empty());
}
