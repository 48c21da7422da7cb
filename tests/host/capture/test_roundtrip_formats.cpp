// One round trip that every CAN capture format plugs into, as python-can's log-format tests do: a set of frames
// covering what the formats differ on (11- and 29-bit ids, DLC 0 and 8, remote, error frames, two interfaces,
// sub-microsecond times) is written, read back, and compared with what the format's CaptureTraits say it keeps.
// Every format also goes through gzip and zstd, on a stream and through files named .gz/.zst, and is told by its
// content. A new format is one more line in kFormats.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "formats_test.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/compressed.hpp"
#include "host/test_frame.hpp"

using namespace saul;
using namespace saul::host;

namespace {

struct Sample {
  CanFrame frame;
  std::string iface;
};

using saul_test::frame;

std::vector<Sample> samples() {
  constexpr std::uint64_t t0 = 1'700'000'000'000'900'123ULL;  // ns below the microsecond on purpose
  std::vector<Sample> s;
  s.push_back({frame(0x300, false, {0xE8, 0x03, 0x0C, 0xFE}, t0), "can0"});
  s.push_back({frame(0x938, true, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA}, t0 + 1'250'000), "can0"});
  s.push_back({frame(0x7FF, false, {}, t0 + 2'000'456), "vcan1"});
  CanFrame remote = frame(0x123, false, {}, t0 + 3'000'000);
  remote.remote = true;
  remote.dlc = 4;
  s.push_back({remote, "can0"});
  CanFrame error = frame(0x004, false, {0x00, 0x04, 0, 0, 0, 0, 0, 0}, t0 + 4'000'000);  // controller, rx warning
  error.error = true;
  s.push_back({error, "vcan1"});
  s.push_back({frame(0x1FFFFFFF, true, {0x01}, t0 + 5'000'999), "can0"});
  s.push_back({frame(0x000, false, {1, 2, 3, 4, 5, 6, 7, 8}, t0 + 1'000'000'000), "vcan1"});
  return s;
}

/// What `format` gives back for the samples, by its traits alone.
std::vector<Sample> expected(CaptureFormat format) {
  const CaptureTraits t = capture_traits(format);
  std::vector<std::string> seen;
  std::vector<Sample> out;
  for (Sample s : samples()) {
    if ((s.frame.error && !t.error_frames) || (s.frame.remote && !t.remote_frames)) continue;
    std::size_t index = 0;
    while (index < seen.size() && seen[index] != s.iface) ++index;
    if (index == seen.size()) seen.push_back(s.iface);
    if (!t.interface_names) s.iface = t.channel_order ? "can" + std::to_string(index) : "can0";
    *s.frame.timestamp_ns -= *s.frame.timestamp_ns % t.resolution_ns;
    if (s.frame.error && !t.error_details) {
      s.frame.id = 0x080;  // a bus error without details, as asc2log reads an ErrorFrame
      s.frame.dlc = 8;
      s.frame.data = {};
    }
    out.push_back(s);
  }
  return out;
}

std::vector<Sample> read_all(CaptureReader& reader) {
  std::vector<Sample> got;
  for (FrameBatch batch; reader.next_batch(batch);) {
    INFO((batch.corrupt.empty() ? std::string() : batch.corrupt[0].error.message));
    REQUIRE(batch.corrupt.empty());
    for (std::size_t i = 0; i < batch.frames.size(); ++i)
      got.push_back({batch.frames[i], std::string(batch.interfaces[i])});
  }
  return got;
}

void compare(const std::vector<Sample>& got, const std::vector<Sample>& want) {
  REQUIRE(got.size() == want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    INFO("frame " << i);
    CHECK(got[i].frame == want[i].frame);  // wire content and timestamp
    CHECK(got[i].iface == want[i].iface);
  }
}

void write_all(CaptureWriter& w) {
  for (const Sample& s : samples()) {
    if ((s.frame.error && !capture_traits(w.format()).error_frames) ||
        (s.frame.remote && !capture_traits(w.format()).remote_frames))
      continue;
    w.write(s.frame, s.iface);
  }
  w.close();
}

struct FormatCase {
  CaptureFormat format;
  const char* extension;
};
constexpr FormatCase kFormats[] = {
    {CaptureFormat::candump, "log"}, {CaptureFormat::pcap, "pcap"}, {CaptureFormat::pcapng, "pcapng"},
    {CaptureFormat::asc, "asc"},     {CaptureFormat::blf, "blf"},   {CaptureFormat::trc, "trc"},
    {CaptureFormat::csv, "csv"},     {CaptureFormat::gvret_csv, "gvret-csv"}, {CaptureFormat::mcap, "mcap"},
};

}  // namespace

TEST_CASE("every capture format: write, read back, compare (plain, gzip, zstd)") {
  for (const FormatCase& fc : kFormats) {
    for (Compression c : {Compression::none, Compression::gzip, Compression::zstd}) {
      INFO(to_string(fc.format) << " " << to_string(c));
      std::ostringstream out;
      {
        std::unique_ptr<CompressingBuf> packer;
        std::unique_ptr<std::ostream> packed;
        if (c != Compression::none) {
          packer = make_compressing_buf(*out.rdbuf(), c);
          packed = std::make_unique<std::ostream>(packer.get());
        }
        auto w = make_capture_writer(packed ? *packed : out, fc.format);
        write_all(*w);
        if (packer) packer->finish();
      }
      const std::string bytes = out.str();
      const auto raw = std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
      CHECK(detect_compression(raw) == c);

      std::istringstream in(bytes);
      std::unique_ptr<DecompressingBuf> inflater;
      std::istream content(in.rdbuf());
      if (c != Compression::none) {
        inflater = make_decompressing_buf(*in.rdbuf(), c);
        content.rdbuf(inflater.get());
      }
      std::string plain((std::istreambuf_iterator<char>(content)), std::istreambuf_iterator<char>());
      if (inflater) CHECK(inflater->error().empty());
      const auto head = std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(plain.data()),
                                                      std::min<std::size_t>(plain.size(), 4096));
      CHECK(detect_capture_format(head) == fc.format);  // told by content, not by name
      std::istringstream again(plain);
      auto reader = make_capture_reader(again, fc.format);
      compare(read_all(*reader), expected(fc.format));
    }
  }
}

TEST_CASE("every capture format through files: .gz and .zst names compress, the content decides when reading") {
  const capture_test::TempDir scratch("roundtrip");
  const auto& dir = scratch.path;
  for (const FormatCase& fc : kFormats) {
    for (std::string suffix : {"", ".gz", ".zst"}) {
      const std::string path = (dir / (std::string("run.") + fc.extension + suffix)).string();
      INFO(path);
      {
        auto w = open_capture_writer(path, fc.format == CaptureFormat::gvret_csv
                                               ? std::optional<CaptureFormat>(fc.format)
                                               : std::nullopt);
        CHECK(w->format() == fc.format);
        write_all(*w);
      }
      // A name that says nothing: compression and format come from the bytes.
      const std::string disguised = (dir / "disguised.bin").string();
      std::filesystem::copy_file(path, disguised, std::filesystem::copy_options::overwrite_existing);
      auto reader = open_capture_reader(disguised);
      CHECK(reader->format() == fc.format);
      compare(read_all(*reader), expected(fc.format));
      REQUIRE(reader->bytes_total());
      CHECK(reader->bytes_read() == *reader->bytes_total());  // progress counts the file's (compressed) bytes
    }
  }
}

TEST_CASE("copy_frames leaves out what the output format cannot hold and says so") {
  std::ostringstream log;
  {
    auto w = make_capture_writer(log, CaptureFormat::candump);
    write_all(*w);
  }
  std::istringstream in(log.str());
  auto reader = make_capture_reader(in, CaptureFormat::candump);
  std::ostringstream csv;
  auto writer = make_capture_writer(csv, CaptureFormat::gvret_csv);
  const CopyStats stats = copy_frames(reader, *writer, {});
  writer->close();
  CHECK(stats.frames == 7);
  CHECK(stats.left_out == 2);
  const auto notes = conversion_losses(stats, CaptureFormat::gvret_csv);
  REQUIRE(!notes.empty());
  CHECK(notes.back() == "gvret-csv holds no remote or error frames: 2 of them left out (1 remote, 1 error)");
}

// The tail every writer shares (StreamCaptureWriter): close() ends the file once, a write after it is refused, and
// a stream that failed is reported with the format's name rather than a file silently cut short.
TEST_CASE("every capture format's writer: close once, no write after close, a failed stream named") {
  const CanFrame one = frame(0x400, false, {1, 2, 3}, 1'000'000'000ULL);
  for (const FormatCase& fc : kFormats) {
    INFO(to_string(fc.format));
    std::ostringstream out;
    auto w = make_capture_writer(out, fc.format);
    w->write(one, "can0");
    w->close();
    const std::string closed = out.str();
    w->close();  // idempotent: no second trailer (ASC's "End TriggerBlock", BLF's header rewrite)
    CHECK(out.str() == closed);
    CHECK_THROWS_WITH(w->write(one, "can0"), Catch::Matchers::Contains("after close") || Catch::Matchers::Contains("writer is closed"));

    std::ostringstream broken;
    auto b = make_capture_writer(broken, fc.format);
    broken.setstate(std::ios::badbit);
    if (fc.format == CaptureFormat::mcap) continue;  // McapWriter keeps its own chunk buffer (test_mcap.cpp)
    CHECK_THROWS_WITH((b->write(one, "can0"), b->flush()), Catch::Matchers::Contains("write failed"));
  }
}
