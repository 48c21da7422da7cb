// What the capture-format tests share (test_captures*.cpp): building frames, reading a whole capture with its
// errors, a scratch folder, and the three frames of protocols.md §6.2 that every format's reference file holds.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/capture.hpp"

namespace capture_test {

using saul::CanFrame;
using namespace saul::host;

inline constexpr std::uint64_t kSec = 1'000'000'000ULL;

inline CanFrame make(std::uint32_t id, bool extended, std::initializer_list<std::uint8_t> bytes, std::uint64_t ns) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  f.timestamp_ns = ns;
  return f;
}

inline CanFrame remote(std::uint32_t id, bool extended, std::uint8_t dlc, std::uint64_t ns) {
  CanFrame f = make(id, extended, {}, ns);
  f.remote = true;
  f.dlc = dlc;
  return f;
}

inline CanFrame error_frame(std::uint32_t error_class, std::initializer_list<std::uint8_t> bytes, std::uint64_t ns) {
  CanFrame f = make(error_class, false, bytes, ns);
  f.error = true;
  return f;
}

struct Read {
  std::vector<CanFrame> frames;
  std::vector<std::string> names;
  std::vector<CaptureError> errors;
};

inline Read read_all(CaptureReader& reader) {
  Read r;
  FrameBatch batch;
  while (reader.next_batch(batch))
    batch.walk(
        [&](std::size_t i) {
          r.frames.push_back(batch.frames[i]);
          r.names.emplace_back(batch.interfaces[i]);
        },
        [&](const CaptureError& e) { r.errors.push_back(e); });
  return r;
}

inline Read read_text(const std::string& text, CaptureFormat format) {
  std::istringstream in(text);
  auto reader = make_capture_reader(in, format);
  return read_all(*reader);
}

inline std::string as_string(const std::vector<std::uint8_t>& bytes) { return {bytes.begin(), bytes.end()}; }

/// A scratch folder of this test process, shared by its test files (other builds may run these tests at the same time).
inline std::filesystem::path scratch_dir() {
  const auto dir = std::filesystem::temp_directory_path() / ("saul_test_captures_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

inline std::vector<std::uint8_t> as_bytes(const std::string& s) { return {s.begin(), s.end()}; }

/// The three frames of protocols.md §6.2 (EFF 0x344 00 00 05 DC; EFF 0x938 STATUS; SFF 0x7FF 11 22), which the
/// pcap, ASC and candump tests meet in their reference files.
inline const std::vector<CanFrame> kDocFrames = {
    make(0x344, true, {0x00, 0x00, 0x05, 0xDC}, 1700000000 * kSec),
    make(0x938, true, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA}, 1700000000 * kSec + 1'250'000),
    make(0x7FF, false, {0x11, 0x22}, 1700000000 * kSec + 4'000'000),
};

}  // namespace capture_test
