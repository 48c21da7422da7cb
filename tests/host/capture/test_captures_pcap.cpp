// pcap and pcapng against bytes written out by hand or checked with tshark (docs: /work/shared/docs/protocols.md
// §6.2; tcpdump's LINKTYPE_CAN_SOCKETCAN page): reading, writing the same bytes, both byte orders, resolutions,
// interface blocks, and corrupt records and blocks reported with their byte offset.
#include <catch2/catch.hpp>

#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/pcap.hpp"
#include "saulproto/host/capture/pcapng.hpp"
#include "test_captures.hpp"

using saul::CanFrame;
using namespace saul::host;
using namespace capture_test;

namespace {

/// protocols.md §6.2, byte-exact and tshark-verified: kDocFrames as a pcap file.
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

}  // namespace

// ---- pcap ----

TEST_CASE("pcap: the tshark-verified file of protocols.md 6.2 reads as its three frames") {
  std::istringstream in(as_string(kDocPcap));
  PcapReader reader(in);
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
  const Read r = read_all(reader);
  REQUIRE(r.frames.size() == 1);
  CHECK(r.frames[0] == f);
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
  const Read r = read_all(reader);
  CHECK(r.errors.empty());
  REQUIRE(r.frames.size() == 2);
  CHECK(r.frames[0] == make(0x938, true, {0xFF, 0xFF, 0xFB}, 1700000000 * kSec + 1'250'000));
  CHECK(r.names[0] == "can1");
  CHECK(r.frames[1] == make(0x7FF, false, {}, 5 * kSec + 500'000'000));
  CHECK(r.names[1] == "can0");
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

