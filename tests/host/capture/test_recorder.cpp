// Recording into rotating files: file names, sizes, rotation by time and size with every file complete on its
// own. (The plot's binning and ticks are tested in tests/host/report/test_plot.cpp.)
#include <catch2/catch.hpp>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/recorder.hpp"
#include "saulproto/host/capture/serial_capture.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

constexpr std::uint64_t kMs = 1'000'000ULL;

std::filesystem::path scratch_dir() {
  const auto dir = std::filesystem::temp_directory_path() / ("saul_test_recorder_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

CanFrame velocity(std::uint64_t ns) {
  CanFrame f;
  f.id = 0x300;
  f.dlc = 4;
  f.timestamp_ns = ns;
  return f;
}

std::vector<std::uint64_t> stamps_in(const std::string& path) {
  auto reader = open_capture_reader(path);
  std::vector<std::uint64_t> out;
  for (FrameBatch batch; reader->next_batch(batch);) {
    REQUIRE(batch.corrupt.empty());
    for (const auto& f : batch.frames) out.push_back(*f.timestamp_ns);
  }
  return out;
}

}  // namespace

TEST_CASE("numbered file names and sizes") {
  CHECK(numbered_path("run.log", 0) == "run-000.log");
  CHECK(numbered_path("/tmp/a.b/run.pcapng", 12) == "/tmp/a.b/run-012.pcapng");
  CHECK(numbered_path("/tmp/a.b/run", 3) == "/tmp/a.b/run-003");
  CHECK(numbered_path(".hidden", 1) == ".hidden-001");
  CHECK(parse_size("100M") == 100ULL * 1024 * 1024);
  CHECK(parse_size("1.5G") == 1536ULL * 1024 * 1024);
  CHECK(parse_size("64kB") == 65536);
  CHECK(parse_size("4096") == 4096);
  CHECK(parse_size("2MiB") == 2ULL * 1024 * 1024);
  CHECK_THROWS_AS(parse_size("lots"), std::invalid_argument);
  CHECK_THROWS_AS(parse_size("10T"), std::invalid_argument);
}

TEST_CASE("rotation by time: every file readable, every frame once, in order") {
  const auto dir = scratch_dir();
  const std::string format_name = GENERATE("log", "pcapng", "asc", "pcap");
  const CaptureFormat format = *capture_format_from_name(format_name);
  const std::string path = (dir / ("run." + format_name)).string();
  std::vector<std::string> opened;
  {
    RotationOptions rotation;
    rotation.max_duration_ns = 1'000 * kMs;
    RotatingCaptureWriter writer(path, format, rotation, [&](const std::string& p) { opened.push_back(p); });
    for (std::uint64_t t = 0; t < 2'500; t += 100) writer.write(velocity(1'700'000'000'000 * kMs + t * kMs), "can0");
    CHECK(writer.files() == 3);
    writer.close();
  }
  REQUIRE(opened.size() == 3);
  CHECK(opened[0] == (dir / ("run-000." + format_name)).string());
  // 0..900 ms, 1000..1900 ms, 2000..2400 ms
  std::vector<std::size_t> sizes;
  std::vector<std::uint64_t> all;
  for (const auto& p : opened) {
    const auto s = stamps_in(p);
    sizes.push_back(s.size());
    all.insert(all.end(), s.begin(), s.end());
  }
  CHECK(sizes == std::vector<std::size_t>{10, 10, 5});
  REQUIRE(all.size() == 25);
  for (std::size_t i = 0; i < all.size(); ++i) CHECK(all[i] == 1'700'000'000'000 * kMs + i * 100 * kMs);
  std::filesystem::remove_all(dir);
}

TEST_CASE("rotation by size, and no rotation") {
  const auto dir = scratch_dir();
  {
    RotationOptions rotation;
    rotation.max_bytes = 100;  // candump lines of 0x300 are 39 bytes: three lines pass 100
    RotatingCaptureWriter writer((dir / "s.log").string(), CaptureFormat::candump, rotation);
    for (int i = 0; i < 7; ++i) writer.write(velocity(static_cast<std::uint64_t>(i) * kMs), "can0");
    writer.close();
    CHECK(writer.files() == 3);
  }
  CHECK(stamps_in((dir / "s-000.log").string()).size() == 3);
  CHECK(stamps_in((dir / "s-001.log").string()).size() == 3);
  CHECK(stamps_in((dir / "s-002.log").string()).size() == 1);
  {
    RotatingCaptureWriter writer((dir / "plain.pcapng").string(), CaptureFormat::pcapng);
    writer.write(velocity(kMs), "can0");
    CHECK(writer.current_path() == (dir / "plain.pcapng").string());
  }  // the destructor closes
  CHECK(stamps_in((dir / "plain.pcapng").string()).size() == 1);
  CHECK_THROWS_AS(RotatingCaptureWriter((dir / "x.serial").string(), CaptureFormat::serial), CaptureOpenError);
  std::filesystem::remove_all(dir);
}

TEST_CASE("serial recordings rotate too") {
  const auto dir = scratch_dir();
  RotationOptions rotation;
  rotation.max_duration_ns = 10 * kMs;
  {
    RotatingSerialWriter writer((dir / "u.serial").string(), rotation);
    SerialChunk c;
    c.link = "serial:/dev/ttyUSB1@38400:8E1";
    c.protocol = SerialProtocol::pride;
    for (std::uint64_t t = 0; t < 20; t += 5) {
      c.timestamp_ns = t * kMs;
      c.bytes = {0xFE, 0x54, static_cast<std::uint8_t>(t)};
      writer.write(c);
    }
    writer.close();
    CHECK(writer.files() == 2);
  }
  for (const char* name : {"u-000.serial", "u-001.serial"}) {
    auto reader = open_serial_capture_reader((dir / name).string());
    int n = 0;
    while (reader->next() == SerialCaptureReader::Status::chunk) ++n;
    CHECK(n == 2);
  }
  std::filesystem::remove_all(dir);
}

