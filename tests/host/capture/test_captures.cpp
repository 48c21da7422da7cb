// Capture formats: one round trip every format plugs into, then each format against bytes and lines written
// out by hand or produced by the reference tools (docs: /work/shared/docs/protocols.md §6; tcpdump's
// LINKTYPE_CAN_SOCKETCAN page; log2asc 2020.11 and python-can 4.1.0 output).
#include <catch2/catch.hpp>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/asc.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/pcap.hpp"
#include "saulproto/host/capture/pcapng.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

constexpr std::uint64_t kSec = 1'000'000'000ULL;

CanFrame make(std::uint32_t id, bool extended, std::initializer_list<std::uint8_t> bytes, std::uint64_t ns) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  f.timestamp_ns = ns;
  return f;
}

CanFrame remote(std::uint32_t id, bool extended, std::uint8_t dlc, std::uint64_t ns) {
  CanFrame f = make(id, extended, {}, ns);
  f.remote = true;
  f.dlc = dlc;
  return f;
}

CanFrame error_frame(std::uint32_t error_class, std::initializer_list<std::uint8_t> bytes, std::uint64_t ns) {
  CanFrame f = make(error_class, false, bytes, ns);
  f.error = true;
  return f;
}

struct Read {
  std::vector<CanFrame> frames;
  std::vector<std::string> names;
  std::vector<CaptureError> errors;
};

Read read_all(CaptureReader& reader) {
  Read r;
  for (;;) {
    const auto st = reader.next();
    if (st == CaptureReader::Status::end) break;
    if (st == CaptureReader::Status::corrupt) {
      r.errors.push_back(reader.error());
      continue;
    }
    r.frames.push_back(reader.frame());
    r.names.emplace_back(reader.interface());
  }
  return r;
}

Read read_text(const std::string& text, CaptureFormat format) {
  std::istringstream in(text);
  auto reader = make_capture_reader(in, format);
  return read_all(*reader);
}

std::string as_string(const std::vector<std::uint8_t>& bytes) { return {bytes.begin(), bytes.end()}; }

/// A scratch folder of this test process (other builds may run these tests at the same time).
std::filesystem::path scratch_dir() {
  const auto dir = std::filesystem::temp_directory_path() / ("saul_test_captures_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

std::vector<std::uint8_t> as_bytes(const std::string& s) { return {s.begin(), s.end()}; }

/// Little helper to write pcapng blocks by hand, in either byte order (independent of the library's writer).
struct Blocks {
  bool big = false;
  std::vector<std::uint8_t> out;
  void u16(std::vector<std::uint8_t>& v, std::uint16_t x) const {
    if (big) {
      v.push_back(static_cast<std::uint8_t>(x >> 8));
      v.push_back(static_cast<std::uint8_t>(x));
    } else {
      v.push_back(static_cast<std::uint8_t>(x));
      v.push_back(static_cast<std::uint8_t>(x >> 8));
    }
  }
  void u32(std::vector<std::uint8_t>& v, std::uint32_t x) const {
    for (int i = 0; i < 4; ++i) v.push_back(static_cast<std::uint8_t>(x >> (big ? 24 - 8 * i : 8 * i)));
  }
  void block(std::uint32_t type, std::vector<std::uint8_t> body) {
    while (body.size() % 4) body.push_back(0);
    const auto total = static_cast<std::uint32_t>(body.size() + 12);
    u32(out, type);
    u32(out, total);
    out.insert(out.end(), body.begin(), body.end());
    u32(out, total);
  }
  void shb() {
    std::vector<std::uint8_t> b;
    u32(b, 0x1A2B3C4D);
    u16(b, 1);
    u16(b, 0);
    u32(b, 0xFFFFFFFF);
    u32(b, 0xFFFFFFFF);
    block(0x0A0D0D0A, b);
  }
  void option(std::vector<std::uint8_t>& b, std::uint16_t code, std::vector<std::uint8_t> value) const {
    u16(b, code);
    u16(b, static_cast<std::uint16_t>(value.size()));
    b.insert(b.end(), value.begin(), value.end());
    while (b.size() % 4) b.push_back(0);
  }
  void idb(std::uint16_t linktype, const std::string& name, int tsresol) {
    std::vector<std::uint8_t> b;
    u16(b, linktype);
    u16(b, 0);
    u32(b, 0);
    if (!name.empty()) option(b, 2, as_bytes(name));
    if (tsresol >= 0) option(b, 9, {static_cast<std::uint8_t>(tsresol)});
    option(b, 0, {});
    block(1, b);
  }
  void epb(std::uint32_t iface, std::uint64_t ticks, const std::vector<std::uint8_t>& packet) {
    std::vector<std::uint8_t> b;
    u32(b, iface);
    u32(b, static_cast<std::uint32_t>(ticks >> 32));
    u32(b, static_cast<std::uint32_t>(ticks));
    u32(b, static_cast<std::uint32_t>(packet.size()));
    u32(b, static_cast<std::uint32_t>(packet.size()));
    b.insert(b.end(), packet.begin(), packet.end());
    block(6, b);
  }
};

/// protocols.md §6.2, byte-exact and tshark-verified: EFF 0x344 00 00 05 DC; EFF 0x938 STATUS; SFF 0x7FF 11 22.
const std::vector<std::uint8_t> kDocPcap = {
    0xd4, 0xc3, 0xb2, 0xa1, 0x02, 0x00, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0xff, 0xff, 0x00, 0x00, 0xe3, 0x00, 0x00, 0x00,  // global header, linktype 227
    0x00, 0xf1, 0x53, 0x65, 0x00, 0x00, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00,
    0x80, 0x00, 0x03, 0x44, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x05, 0xdc, 0x00, 0x00, 0x00, 0x00,
    0x00, 0xf1, 0x53, 0x65, 0xe2, 0x04, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00,
    0x80, 0x00, 0x09, 0x38, 0x08, 0x00, 0x00, 0x00, 0xff, 0xff, 0xfb, 0x50, 0x00, 0x23, 0x00, 0xfa,
    0x00, 0xf1, 0x53, 0x65, 0xa0, 0x0f, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x07, 0xff, 0x02, 0x00, 0x00, 0x00, 0x11, 0x22, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
};

const std::vector<CanFrame> kDocFrames = {
    make(0x344, true, {0x00, 0x00, 0x05, 0xDC}, 1700000000 * kSec),
    make(0x938, true, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA}, 1700000000 * kSec + 1'250'000),
    make(0x7FF, false, {0x11, 0x22}, 1700000000 * kSec + 4'000'000),
};

/// The same file with every header field byte-swapped (a big-endian writer); packets are big-endian anyway.
std::vector<std::uint8_t> doc_pcap_big_endian(bool nanosecond) {
  std::vector<std::uint8_t> b = kDocPcap;
  auto swap32 = [&b](std::size_t at) {
    std::swap(b[at], b[at + 3]);
    std::swap(b[at + 1], b[at + 2]);
  };
  auto set32be = [&b](std::size_t at, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (24 - 8 * i));
  };
  for (std::size_t at : {0U, 8U, 12U, 16U, 20U}) swap32(at);
  std::swap(b[4], b[5]);
  std::swap(b[6], b[7]);
  if (nanosecond) set32be(0, 0xA1B23C4D);
  for (std::size_t rec = 24; rec < b.size(); rec += 32) {
    for (std::size_t f = 0; f < 16; f += 4) swap32(rec + f);
    if (nanosecond) {
      const std::uint32_t usec = std::uint32_t{b[rec + 4]} << 24 | std::uint32_t{b[rec + 5]} << 16 |
                                 std::uint32_t{b[rec + 6]} << 8 | b[rec + 7];
      set32be(rec + 4, usec * 1000);
    }
  }
  return b;
}

}  // namespace

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

// ---- pcap ----

TEST_CASE("pcap: the tshark-verified file of protocols.md 6.2 reads as its three frames") {
  std::istringstream in(as_string(kDocPcap));
  PcapReader reader(in);
  CHECK_FALSE(reader.big_endian());
  CHECK_FALSE(reader.nanosecond());
  const Read r = read_all(reader);
  CHECK(r.errors.empty());
  REQUIRE(r.frames.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) {
    CHECK(r.frames[i] == kDocFrames[i]);
    CHECK(r.names[i] == "can0");
  }
}

TEST_CASE("pcap: writing those three frames gives the same bytes") {
  std::ostringstream out;
  PcapWriter writer(out);
  for (const auto& f : kDocFrames) writer.write(f, "can0");
  writer.close();
  CHECK(as_bytes(out.str()) == kDocPcap);
}

TEST_CASE("pcap: big-endian files and the nanosecond magic read the same") {
  const bool nano = GENERATE(false, true);
  const auto bytes = doc_pcap_big_endian(nano);
  CHECK(detect_capture_format(bytes) == CaptureFormat::pcap);
  std::istringstream in(as_string(bytes));
  PcapReader reader(in);
  CHECK(reader.big_endian());
  CHECK(reader.nanosecond() == nano);
  const Read r = read_all(reader);
  REQUIRE(r.frames.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) CHECK(r.frames[i] == kDocFrames[i]);
}

TEST_CASE("pcap: nanosecond writer keeps nanoseconds") {
  std::stringstream buffer;
  PcapWriter writer(buffer, {.nanosecond = true});
  const CanFrame f = make(0x123, false, {1}, 1700000000 * kSec + 123'456'789);
  writer.write(f, "can0");
  writer.close();
  const std::string bytes = buffer.str();
  CHECK(static_cast<std::uint8_t>(bytes[0]) == 0x4D);  // A1B23C4D little-endian
  PcapReader reader(buffer);
  REQUIRE(reader.next() == CaptureReader::Status::frame);
  CHECK(reader.frame() == f);
}

TEST_CASE("pcap: SocketCAN packet flags and payload_length") {
  CanFrame f;
  SECTION("RTR with a requested length, no data bytes in the packet") {
    const std::vector<std::uint8_t> p = {0x40, 0x00, 0x01, 0x23, 0x04, 0, 0, 0};
    CHECK(decode_socketcan_packet(p, f).empty());
    CHECK(f.remote);
    CHECK_FALSE(f.extended);
    CHECK(f.id == 0x123);
    CHECK(f.dlc == 4);
  }
  SECTION("error frame: ERR flag, class in the id, data kept") {
    const std::vector<std::uint8_t> p = {0x20, 0x00, 0x00, 0x04, 0x08, 0, 0, 0, 0, 0x20, 0, 0, 0, 0, 0, 0};
    CHECK(decode_socketcan_packet(p, f).empty());
    CHECK(f.error);
    CHECK(f.id == 0x004);
    CHECK(f.data[1] == 0x20);
    CHECK(encode_socketcan_packet(f)[0] == 0x20);
  }
  SECTION("trimmed packet: payload_length is authoritative") {
    const std::vector<std::uint8_t> p = {0x80, 0x00, 0x03, 0x44, 0x02, 0, 0, 0, 0xAA, 0xBB};
    CHECK(decode_socketcan_packet(p, f).empty());
    CHECK(f.dlc == 2);
    CHECK(f.data[1] == 0xBB);
  }
  SECTION("refused packets say why") {
    CHECK_FALSE(decode_socketcan_packet(std::vector<std::uint8_t>{0x80, 0, 3, 0x44}, f).empty());  // short
    CHECK(decode_socketcan_packet(std::vector<std::uint8_t>{0, 0, 1, 0x23, 3, 0x04, 0, 0, 1, 2, 3}, f)
              .find("FD") != std::string_view::npos);  // CANFD_FDF
    CHECK_FALSE(decode_socketcan_packet(std::vector<std::uint8_t>{0, 0, 1, 0x23, 9, 0, 0, 0}, f).empty());
    CHECK_FALSE(decode_socketcan_packet(std::vector<std::uint8_t>{0, 0, 0x08, 0x00, 0, 0, 0, 0}, f).empty());
    CHECK_FALSE(decode_socketcan_packet(std::vector<std::uint8_t>{0, 0, 1, 0x23, 4, 0, 0, 0, 1, 2}, f).empty());
  }
}

TEST_CASE("pcap: corrupt records are reported with their byte offset") {
  SECTION("a truncated last record stops reading after the good ones") {
    auto bytes = kDocPcap;
    bytes.resize(bytes.size() - 4);
    std::istringstream in(as_string(bytes));
    PcapReader reader(in);
    const Read r = read_all(reader);
    CHECK(r.frames.size() == 2);
    REQUIRE(r.errors.size() == 1);
    CHECK(r.errors[0].kind == PositionKind::byte_offset);
    CHECK(r.errors[0].position == 24 + 2 * 32);
    CHECK(r.errors[0].recovery == Recovery::stop);
    CHECK(r.errors[0].message == "file ends inside a record (12 of 16 bytes)");
    CHECK(format_capture_error("x.pcap", r.errors[0]) ==
          "x.pcap: byte 88: file ends inside a record (12 of 16 bytes) (reading stopped)");
  }
  SECTION("a record too short for a CAN packet is skipped, the next one still reads") {
    std::vector<std::uint8_t> bytes(kDocPcap.begin(), kDocPcap.begin() + 24);
    const std::vector<std::uint8_t> bad = {0, 0, 0, 0, 0, 0, 0, 0, 4, 0, 0, 0, 4, 0, 0, 0, 0x80, 0, 3, 0x44};
    bytes.insert(bytes.end(), bad.begin(), bad.end());
    bytes.insert(bytes.end(), kDocPcap.begin() + 24 + 64, kDocPcap.end());
    std::istringstream in(as_string(bytes));
    PcapReader reader(in);
    const Read r = read_all(reader);
    REQUIRE(r.errors.size() == 1);
    CHECK(r.errors[0].position == 24);
    CHECK(r.errors[0].recovery == Recovery::next_record);
    REQUIRE(r.frames.size() == 1);
    CHECK(r.frames[0] == kDocFrames[2]);
  }
  SECTION("an implausible record length stops reading") {
    std::vector<std::uint8_t> bytes(kDocPcap.begin(), kDocPcap.begin() + 24);
    const std::vector<std::uint8_t> bad = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x10, 0, 0, 0, 0x10};
    bytes.insert(bytes.end(), bad.begin(), bad.end());
    std::istringstream in(as_string(bytes));
    PcapReader reader(in);
    const Read r = read_all(reader);
    REQUIRE(r.errors.size() == 1);
    CHECK(r.errors[0].recovery == Recovery::stop);
    CHECK(r.frames.empty());
  }
  SECTION("a header that is not usable throws at open") {
    auto ethernet = kDocPcap;
    ethernet[20] = 1;  // LINKTYPE_ETHERNET
    std::istringstream a(as_string(ethernet));
    CHECK_THROWS_AS(PcapReader(a), CaptureOpenError);
    std::istringstream b(as_string(std::vector<std::uint8_t>(kDocPcap.begin(), kDocPcap.begin() + 10)));
    CHECK_THROWS_AS(PcapReader(b), CaptureOpenError);
    std::istringstream c("(1700000000.000000) can0 123#\n");
    CHECK_THROWS_AS(PcapReader(c), CaptureOpenError);
  }
}

// ---- pcapng ----

TEST_CASE("pcapng: sections in both byte orders, interface names and resolutions, unknown blocks skipped") {
  Blocks b;
  b.big = true;
  b.shb();
  b.idb(227, "can1", 6);  // interface 0: microseconds
  b.block(0x00000BAD, {1, 2, 3, 4, 5, 6, 7, 8});  // a custom block: skipped by its length
  b.idb(1, "eth0", -1);                            // interface 1: Ethernet, its packets are skipped
  b.epb(1, 0, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF});
  b.epb(0, 1700000000ULL * 1'000'000 + 1250, {0x80, 0x00, 0x09, 0x38, 0x03, 0, 0, 0, 0xFF, 0xFF, 0xFB});
  b.big = false;
  b.shb();                     // a second section, little-endian: interface ids restart
  b.idb(227, "", 0x80 | 10);   // no name, 2^-10 s ticks
  b.epb(0, 1024 * 5 + 512, {0x00, 0x00, 0x07, 0xFF, 0x00, 0, 0, 0});
  CHECK(detect_capture_format(b.out) == CaptureFormat::pcapng);

  std::istringstream in(as_string(b.out));
  PcapngReader reader(in);
  CHECK(reader.big_endian());
  const Read r = read_all(reader);
  CHECK(r.errors.empty());
  REQUIRE(r.frames.size() == 2);
  CHECK(r.frames[0] == make(0x938, true, {0xFF, 0xFF, 0xFB}, 1700000000 * kSec + 1'250'000));
  CHECK(r.names[0] == "can1");
  CHECK(r.frames[1] == make(0x7FF, false, {}, 5 * kSec + 500'000'000));
  CHECK(r.names[1] == "can0");
  CHECK_FALSE(reader.big_endian());
}

TEST_CASE("pcapng: one IDB per interface, names kept, nanoseconds kept") {
  std::stringstream buffer;
  PcapngWriter writer(buffer);
  writer.write(make(0x100, false, {1}, 1 * kSec + 1), "vcan0");
  writer.write(make(0x101, false, {2}, 2 * kSec + 2), "can_bench");
  writer.write(make(0x102, false, {3}, 3 * kSec + 3), "vcan0");
  writer.close();
  const Read r = read_all(*make_capture_reader(buffer, CaptureFormat::pcapng));
  REQUIRE(r.frames.size() == 3);
  CHECK(r.names == std::vector<std::string>{"vcan0", "can_bench", "vcan0"});
  CHECK(r.frames[2].timestamp_ns == 3 * kSec + 3);
  // SHB (48 bytes) + IDBs of vcan0 (44) and can_bench (48) + 3 EPBs of 48: an IDB only at an interface's first frame
  CHECK(buffer.str().size() == 48 + 44 + 48 + 3 * 48);
}

TEST_CASE("pcapng: corrupt blocks are reported with their byte offset") {
  Blocks b;
  b.shb();
  b.idb(227, "can0", 6);
  const std::size_t bad_epb = b.out.size();
  b.epb(5, 0, {0x00, 0x00, 0x01, 0x23, 0x00, 0, 0, 0});  // interface 5 was never declared
  const std::size_t good_epb = b.out.size();
  b.epb(0, 7, {0x00, 0x00, 0x01, 0x23, 0x01, 0, 0, 0, 0x42});

  SECTION("a packet of an undeclared interface is skipped, reading goes on") {
    std::istringstream in(as_string(b.out));
    PcapngReader reader(in);
    const Read r = read_all(reader);
    REQUIRE(r.errors.size() == 1);
    CHECK(r.errors[0].position == bad_epb);
    CHECK(r.errors[0].recovery == Recovery::next_block);
    REQUIRE(r.frames.size() == 1);
    CHECK(r.frames[0].data[0] == 0x42);
  }
  SECTION("a trailing length that differs skips the block") {
    auto bytes = b.out;
    bytes[good_epb - 4] ^= 0x04;  // the trailing length of the bad EPB
    std::istringstream in(as_string(bytes));
    const Read r = read_all(*make_capture_reader(in, CaptureFormat::pcapng));
    REQUIRE(r.errors.size() == 1);
    CHECK(r.errors[0].message.find("differs") != std::string::npos);
    CHECK(r.frames.size() == 1);
  }
  SECTION("a block length that is not a multiple of 4 stops reading") {
    auto bytes = b.out;
    bytes[bad_epb + 4] = 13;
    std::istringstream in(as_string(bytes));
    const Read r = read_all(*make_capture_reader(in, CaptureFormat::pcapng));
    REQUIRE(r.errors.size() == 1);
    CHECK(r.errors[0].position == bad_epb);
    CHECK(r.errors[0].recovery == Recovery::stop);
    CHECK(r.frames.empty());
  }
  SECTION("a file that ends inside a block stops reading") {
    auto bytes = b.out;
    bytes.resize(bytes.size() - 6);
    std::istringstream in(as_string(bytes));
    const Read r = read_all(*make_capture_reader(in, CaptureFormat::pcapng));
    REQUIRE(r.errors.size() == 2);
    CHECK(r.errors[1].position == good_epb);
    CHECK(r.errors[1].recovery == Recovery::stop);
  }
  SECTION("a file without a section header does not open") {
    std::istringstream in(as_string(std::vector<std::uint8_t>(b.out.begin() + 28, b.out.end())));
    CHECK_THROWS_AS(PcapngReader(in), CaptureOpenError);
  }
}

// ---- Vector ASC ----

TEST_CASE("asc: log2asc 2020.11 output of protocols.md 6.3 parses, the CAN FD line is refused with its line") {
  const std::string log2asc =
      "date Tue Nov 14 22:13:20 2023\n"
      "base hex  timestamps absolute\n"
      "no internal events logged\n"
      "   0.000000 1  344x            Rx   d 4 00 00 05 DC\n"
      "   0.001250 1  938x            Rx   d 8 FF FF FB 50 00 23 00 FA\n"
      "   0.002500 1  123             Rx   r 0\n"
      "   0.003000 1  123             Rx   r 4\n"
      "   0.004000 1  7FF             Rx   d 2 11 22\n"
      "   0.005000 1  ErrorFrame\n"
      "   0.006000 CANFD   1 Rx        123                                   1 0 3  3 11 22 33   130000  130     "
      "3000 0 0 0 0 0\n";
  CHECK(detect_capture_format(as_bytes(log2asc)) == CaptureFormat::asc);
  const Read r = read_text(log2asc, CaptureFormat::asc);
  const std::uint64_t t0 = 1700000000 * kSec;  // the date line, read as UTC
  REQUIRE(r.frames.size() == 6);
  CHECK(r.frames[0] == kDocFrames[0]);
  CHECK(r.frames[1] == kDocFrames[1]);
  CHECK(r.frames[2] == remote(0x123, false, 0, t0 + 2'500'000));
  CHECK(r.frames[3] == remote(0x123, false, 4, t0 + 3'000'000));
  CHECK(r.frames[4] == kDocFrames[2]);
  CHECK(r.frames[5].error);
  CHECK(r.frames[5].id == 0x080);
  CHECK(*r.frames[5].timestamp_ns == t0 + 5'000'000);
  CHECK(r.names[0] == "can0");
  REQUIRE(r.errors.size() == 1);
  CHECK(r.errors[0].position == 10);
  CHECK(r.errors[0].column == 12);
  CHECK(r.errors[0].message.find("CAN FD") != std::string::npos);
}

TEST_CASE("asc: python-can 4.1.0 writer output parses (AM/PM date, trigger block, events)") {
  const std::string python_can =
      "date Sun Nov 22 06:54:33.675 PM 2026\n"  // when the file was made: the trigger block date wins
      "base hex  timestamps absolute\n"
      "internal events logged\n"
      "Begin Triggerblock Tue Nov 14 10:13:20.000 PM 2023\n"
      " 0.000000 Start of measurement\n"
      " 0.001250 1  938x            Rx   d 8 FF FF FB 50 00 23 00 FA\n"
      " 0.002000 1  123             Rx   r 4 \n"
      " 0.003000 1  ErrorFrame\n"
      " 0.004000 2  7FF             Rx   d 0 \n"
      "End TriggerBlock\n";
  std::istringstream in(python_can);
  AscReader reader(in);
  const Read r = read_all(reader);
  CHECK(reader.wall_clock());
  CHECK(r.errors.empty());
  REQUIRE(r.frames.size() == 4);
  CHECK(r.frames[0] == kDocFrames[1]);
  CHECK(r.frames[1] == remote(0x123, false, 4, 1700000000 * kSec + 2'000'000));
  CHECK(r.frames[2].error);
  CHECK(r.frames[3] == make(0x7FF, false, {}, 1700000000 * kSec + 4'000'000));
  CHECK(r.names[3] == "can1");
}

TEST_CASE("asc: base dec, timestamps relative (each time counted from the previous frame), no date") {
  const std::string text =
      "base dec  timestamps relative\n"
      "no internal events logged\n"
      "0.5 2  836x Rx d 4 0 0 5 220\n"
      "0.25 2  2047 Tx d 2 17 34 Length = 0 BitCount = 0 ID = 2047\n"
      "0.25 1  Statistic: D 0 R 0 XD 0 XR 0 E 0 O 0 B 0.00%\n"
      "0.25 1  291 TxRq d 0\n";
  std::istringstream in(text);
  AscReader reader(in);
  const Read r = read_all(reader);
  CHECK_FALSE(reader.wall_clock());
  CHECK(r.errors.empty());
  REQUIRE(r.frames.size() == 2);
  CHECK(r.frames[0] == make(0x344, true, {0x00, 0x00, 0x05, 0xDC}, 500'000'000));
  CHECK(r.frames[1] == make(0x7FF, false, {0x11, 0x22}, 750'000'000));
  CHECK(r.names[0] == "can1");
}

TEST_CASE("asc: corrupt lines are reported with line and column, the next lines still read") {
  const std::string text =
      "date Tue Nov 14 22:13:20 2023\n"              // 1
      "base hex  timestamps absolute\n"              // 2
      "   0.000000 1  3G4             Rx   d 1 00\n"  // 3  id not hex
      "   0.000100 1  123             Rx   d 4 01 02\n"  // 4  2 of 4 bytes
      "   0.000200 1  123             Rx   d 9 01\n"  // 5  DLC 9
      "   0.000300 1  800             Rx   d 0\n"     // 6  11-bit id too big
      "   0.000400 1  123             Rx   q 0\n"     // 7  neither d nor r
      "   0.000500 1  124\n"                          // 8  cut short
      "hello\n"                                       // 9  not ASC
      "   1.5x 1  123 Rx d 0\n"                       // 10 bad time
      "   0.000900 1  7FF             Rx   d 1 AA\n";  // 11 good
  const Read r = read_text(text, CaptureFormat::asc);
  REQUIRE(r.frames.size() == 1);
  CHECK(r.frames[0].data[0] == 0xAA);
  REQUIRE(r.errors.size() == 8);
  const std::vector<std::pair<std::uint64_t, std::size_t>> where = {{3, 15}, {4, 45}, {5, 38}, {6, 15},
                                                                    {7, 36}, {8, 18}, {9, 0},  {10, 3}};
  for (std::size_t i = 0; i < where.size(); ++i) {
    INFO("error " << i << ": " << r.errors[i].message);
    CHECK(r.errors[i].position == where[i].first);
    CHECK(r.errors[i].column == where[i].second);
    CHECK(r.errors[i].recovery == Recovery::next_line);
  }
  CHECK(format_capture_error("v.asc", r.errors[0]) == "v.asc:3:16: id is not hexadecimal (line skipped)");
}

TEST_CASE("asc: dates") {
  CHECK(parse_asc_date("Tue Nov 14 22:13:20 2023") == 1700000000 * kSec);
  CHECK(parse_asc_date("Tue Nov 14 10:13:20.250 pm 2023") == 1700000000 * kSec + 250'000'000);
  CHECK(parse_asc_date("Nov 14 12:00:00 AM 2023") == (1700000000ULL - 22 * 3600 - 13 * 60 - 20) * kSec);
  CHECK(parse_asc_date("Do Mär 07 08:00:00 2024") == 1709798400 * kSec);
  CHECK(parse_asc_date("Thu Feb 29 00:00:00 2024") == 1709164800 * kSec);
  CHECK_FALSE(parse_asc_date("yesterday"));
  CHECK_FALSE(parse_asc_date("Tue Nov 14 25:13:20 2023"));
  CHECK(format_asc_date(1700000000 * kSec + 999) == "Tue Nov 14 22:13:20 2023");
  CHECK(format_asc_date(1709164800 * kSec) == "Thu Feb 29 00:00:00 2024");
  CHECK(format_asc_date(0) == "Thu Jan 01 00:00:00 1970");
}

TEST_CASE("asc: the writer's lines follow log2asc's layout, times from the whole second before the first frame") {
  std::ostringstream out;
  AscWriter writer(out);
  writer.write(kDocFrames[0], "can0");
  writer.write(kDocFrames[1], "can0");
  writer.write(remote(0x123, false, 4, 1700000000 * kSec + 3'000'000), "can0");
  writer.write(error_frame(0x004, {0, 0x20}, 1700000000 * kSec + 5'000'000), "vcan7");
  writer.close();
  CHECK(out.str() ==
        "date Tue Nov 14 22:13:20 2023\n"
        "base hex  timestamps absolute\n"
        "internal events logged\n"
        "Begin Triggerblock Tue Nov 14 22:13:20 2023\n"
        "   0.000000 Start of measurement\n"
        "   0.000000 1  344x            Rx   d 4 00 00 05 DC\n"
        "   0.001250 1  938x            Rx   d 8 FF FF FB 50 00 23 00 FA\n"
        "   0.003000 1  123             Rx   r 4\n"
        "   0.005000 2  ErrorFrame\n"
        "End TriggerBlock\n");
}

// ---- candump through the common interface ----

TEST_CASE("candump: corrupt lines carry their line number and column through CaptureError") {
  const std::string text =
      "# a comment\n"
      "(1.000000) can0 123#11\n"
      "(2.0 can0 123#\n"
      "(3.000000) can0 12G#00\n"
      "(4.000000) can0 123##1\n"
      "DROPCOUNT: dropped 3 CAN frame(s) on 'can0' socket (total drops 3)\n"
      "(5.000000) can0 456#22\n";
  const Read r = read_text(text, CaptureFormat::candump);
  REQUIRE(r.frames.size() == 2);
  CHECK(r.frames[1] == make(0x456, false, {0x22}, 5 * kSec));
  REQUIRE(r.errors.size() == 3);
  CHECK(r.errors[0].position == 3);
  CHECK(r.errors[0].column == 0);
  CHECK(r.errors[1].position == 4);
  CHECK(r.errors[1].column == 18);
  CHECK(r.errors[2].position == 5);
  CHECK(r.errors[2].message.find("CAN FD") != std::string::npos);
  CHECK(format_capture_error("g.log", r.errors[1]) == "g.log:4:19: id is not hexadecimal (line skipped)");
}

TEST_CASE("candump writer: the lines candump -l writes") {
  std::ostringstream out;
  CandumpWriter writer(out);
  writer.write(kDocFrames[0], "can0");
  writer.write(remote(0x123, false, 4, 1700000000 * kSec + 3'000'000), "vcan1");
  writer.write(error_frame(0x080, {0, 0, 0, 0, 0, 0, 0, 0}, 1700000000 * kSec + 5'000'000), "");
  writer.close();
  CHECK(out.str() ==
        "(1700000000.000000) can0 00000344#000005DC\n"
        "(1700000000.003000) vcan1 123#R4\n"
        "(1700000000.005000) can0 20000080#0000000000000000\n");
  CHECK_THROWS_AS(CandumpWriter(out).write(kDocFrames[0], "can 0"), std::invalid_argument);
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
  CHECK_FALSE(capture_format_from_name("blf"));
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

TEST_CASE("copy_frames counts what it copies and conversion_losses says what a format drops") {
  std::istringstream in(
      "(1.000000) vcan0 123#11\n(2.000000) can1 20000080#0000000000000000\nbroken\n(x) can0 1#\n");
  CandumpReader reader(in);
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
