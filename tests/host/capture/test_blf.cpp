// Vector BLF: files built here byte by byte from the layout (blf.hpp: file header, LOBJ objects, zlib log
// containers), compressed with zlib itself, never with the writer under test; and the writer's bytes read back by
// hand. Hostile files: object size 0, sizes past the end, containers that inflate to another size, garbage.
#include <catch2/catch.hpp>
#include <zlib.h>

#include <array>
#include <sstream>
#include <string>
#include <vector>

#include "formats_test.hpp"
#include "saulproto/host/capture/blf.hpp"

using namespace saul;
using namespace saul::host;

namespace {

using Bytes = std::vector<std::uint8_t>;

void u16(Bytes& b, unsigned v) {
  b.push_back(static_cast<std::uint8_t>(v));
  b.push_back(static_cast<std::uint8_t>(v >> 8));
}
void u32(Bytes& b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void u64(Bytes& b, std::uint64_t v) {
  u32(b, static_cast<std::uint32_t>(v));
  u32(b, static_cast<std::uint32_t>(v >> 32));
}
void append(Bytes& b, const Bytes& more) { b.insert(b.end(), more.begin(), more.end()); }

/// The 144-byte file header, start 2023-11-14 22:13:20.250 (a Tuesday), as Vector's SYSTEMTIME.
Bytes file_header() {
  Bytes h = {'L', 'O', 'G', 'G'};
  u32(h, 144);
  append(h, Bytes{5, 0, 0, 0, 2, 6, 8, 1});  // application, its version, BLF format version
  u64(h, 0);  // file size
  u64(h, 0);  // uncompressed size
  u32(h, 0);  // objects
  u32(h, 0);
  for (unsigned v : {2023U, 11U, 2U, 14U, 22U, 13U, 20U, 250U}) u16(h, v);  // start
  for (unsigned v : {2023U, 11U, 2U, 14U, 22U, 13U, 21U, 0U}) u16(h, v);    // stop
  h.resize(144, 0);
  return h;
}
constexpr std::uint64_t kStartNs = 1'700'000'000'250'000'000ULL;

/// An object with a version-1 header: flags 2 = nanoseconds (1 = 10 us), then its body and (size % 4) padding.
Bytes object(std::uint32_t type, const Bytes& body, std::uint64_t time, std::uint32_t flags = 2) {
  Bytes o = {'L', 'O', 'B', 'J'};
  u16(o, 32);
  u16(o, 1);
  u32(o, static_cast<std::uint32_t>(32 + body.size()));
  u32(o, type);
  u32(o, flags);
  u16(o, 0);
  u16(o, 0);
  u64(o, time);
  append(o, body);
  o.resize(o.size() + (32 + body.size()) % 4, 0);
  return o;
}

Bytes can_message(unsigned channel, std::uint8_t flags, std::uint8_t dlc, std::uint32_t id, Bytes data) {
  Bytes b;
  u16(b, channel);
  b.push_back(flags);
  b.push_back(dlc);
  u32(b, id);
  data.resize(8, 0);
  append(b, data);
  return b;
}

/// A log container: zlib-compressed (method 2) unless `stored`; `declared` overrides the uncompressed size.
Bytes container(const Bytes& payload, bool stored = false, std::optional<std::uint32_t> declared = std::nullopt) {
  Bytes data = payload;
  if (!stored) {
    uLongf n = compressBound(static_cast<uLong>(payload.size()));
    data.assign(n, 0);
    REQUIRE(compress2(data.data(), &n, payload.data(), static_cast<uLong>(payload.size()), 9) == Z_OK);
    data.resize(n);
  }
  Bytes c = {'L', 'O', 'B', 'J'};
  u16(c, 16);
  u16(c, 1);
  u32(c, static_cast<std::uint32_t>(32 + data.size()));
  u32(c, 10);
  u16(c, stored ? 0 : 2);
  c.resize(c.size() + 6, 0);
  u32(c, declared.value_or(static_cast<std::uint32_t>(payload.size())));
  c.resize(c.size() + 4, 0);
  append(c, data);
  c.resize(c.size() + (32 + data.size()) % 4, 0);
  return c;
}

struct Read {
  std::vector<CanFrame> frames;
  std::vector<std::string> names;
  std::vector<std::string> errors;
  std::uint64_t skipped = 0;
};

Read read(const Bytes& file) {
  std::istringstream in(std::string(file.begin(), file.end()));
  BlfReader r(in);
  const auto all = capture_test::read_all(r);
  return {all.frames, all.names, capture_test::messages(all), r.skipped_objects()};
}

}  // namespace

TEST_CASE("BLF: CAN objects of every kind, unknown objects counted and skipped") {
  Bytes objects;
  append(objects, object(1, can_message(1, 0, 4, 0x300, {0xE8, 0x03, 0x0C, 0xFE}), 1'000));
  append(objects, object(86, [] {  // CAN_MESSAGE2: the same 16 bytes plus frame length, bit count, reserved
           Bytes b = can_message(2, 0x01, 8, 0x80000938, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA});
           b.resize(24, 0);
           return b;
         }(), 2'000));
  append(objects, object(1, can_message(1, 0x80, 4, 0x123, {}), 300, 1));  // remote, 10 us units: 3 ms
  append(objects, object(1, can_message(1, 0, 13, 0x3FF, {0x55, 0xAA, 1, 2, 3, 4, 5, 6}), 4'000));  // DLC 13
  Bytes error_ext;  // channel, length, flags, ecc, position, dlc, reserved, frame length, id, flags ext, reserved, data
  u16(error_ext, 2);
  error_ext.resize(32, 0);
  append(objects, object(73, error_ext, 5'000));
  Bytes fd_classic;  // CAN_FD_MESSAGE with EDL clear: a classic frame on an FD channel
  u16(fd_classic, 1);
  fd_classic.push_back(0);
  fd_classic.push_back(2);
  u32(fd_classic, 0x7FF);
  u32(fd_classic, 0);
  fd_classic.push_back(0);     // bit count
  fd_classic.push_back(0);     // fd flags: no EDL
  fd_classic.push_back(2);     // valid bytes
  fd_classic.resize(20, 0);
  fd_classic.push_back(0x11);
  fd_classic.push_back(0x22);
  fd_classic.resize(84, 0);
  append(objects, object(100, fd_classic, 6'000));
  Bytes fd = fd_classic;
  fd[13] = 0x01;  // EDL: CAN FD
  append(objects, object(100, fd, 7'000));
  Bytes fd64;  // CAN_FD_MESSAGE_64, classic: channel, dlc, valid bytes, tx count, id, frame length, flags, ...
  fd64.push_back(1);
  fd64.push_back(1);
  fd64.push_back(1);
  fd64.push_back(0);
  u32(fd64, 0x80000344);
  u32(fd64, 0);
  u32(fd64, 0x0000);  // flags: EDL (0x1000) clear
  fd64.resize(40, 0);
  fd64.push_back(0x42);
  append(objects, object(101, fd64, 8'000));
  append(objects, object(96, Bytes(20, 0x33), 9'000));  // GLOBAL_MARKER: not a frame
  append(objects, object(65, Bytes(8, 0x44), 9'500));   // an Ethernet object, say
  Bytes file = file_header();
  append(file, container(objects));

  const Read r = read(file);
  REQUIRE(r.errors == std::vector<std::string>{
                          "CAN FD frame: the robot's bus is classic CAN, FD is not supported"});
  REQUIRE(r.frames.size() == 7);
  CHECK(r.skipped == 2);
  CHECK(r.names == std::vector<std::string>{"can0", "can1", "can0", "can0", "can1", "can0", "can0"});
  const auto& f = r.frames;
  CHECK((f[0].id == 0x300 && !f[0].extended && f[0].dlc == 4 && f[0].data[3] == 0xFE));
  CHECK(*f[0].timestamp_ns == kStartNs + 1'000);
  CHECK((f[1].id == 0x938 && f[1].extended && f[1].dlc == 8 && f[1].data[7] == 0xFA));
  CHECK((f[2].remote && f[2].dlc == 4 && *f[2].timestamp_ns == kStartNs + 3'000'000));
  CHECK((f[3].id == 0x3FF && f[3].dlc == 8 && f[3].data[7] == 6));  // DLC 13 on classic CAN: 8 bytes
  CHECK((f[4].error && f[4].id == 0x080 && f[4].dlc == 8));
  CHECK((f[5].id == 0x7FF && f[5].dlc == 2 && f[5].data[1] == 0x22));
  CHECK((f[6].id == 0x344 && f[6].extended && f[6].dlc == 1 && f[6].data[0] == 0x42));
}

TEST_CASE("BLF: an object continues in the next container; stored containers; top-level objects") {
  Bytes objects;
  for (std::uint32_t i = 0; i < 3; ++i) append(objects, object(1, can_message(1, 0, 1, 0x100 + i, {std::uint8_t(i)}), i));
  // cut the second object in the middle: 48 + 20 bytes in the first container, the rest in the second
  const Bytes first(objects.begin(), objects.begin() + 68);
  const Bytes second(objects.begin() + 68, objects.end());
  Bytes file = file_header();
  append(file, container(first));
  append(file, container(second, true));
  append(file, object(1, can_message(1, 0, 0, 0x7AA, {}), 9));  // outside any container
  const Read r = read(file);
  CHECK(r.errors.empty());
  REQUIRE(r.frames.size() == 4);
  CHECK(r.frames[1].id == 0x101);
  CHECK(r.frames[2].id == 0x102);
  CHECK(r.frames[3].id == 0x7AA);
}

TEST_CASE("BLF: hostile lengths are corrupt records, never a hang or a huge allocation") {
  const Bytes good = object(1, can_message(1, 0, 1, 0x111, {0x11}), 0);
  SECTION("object size 0 (python-can's BLF reader hung on it)") {
    Bytes zero = {'L', 'O', 'B', 'J'};
    u16(zero, 32);
    u16(zero, 1);
    u32(zero, 0);  // object size
    u32(zero, 1);
    zero.resize(32, 0);
    Bytes objects = zero;
    append(objects, good);
    Bytes file = file_header();
    append(file, container(objects));
    const Read r = read(file);
    REQUIRE(r.frames.size() == 1);  // the reader found the next object after the bad one
    CHECK(r.frames[0].id == 0x111);
    REQUIRE(r.errors.size() == 2);
    CHECK(r.errors[0] == "object size 0 (header 32) is not valid");
  }
  SECTION("an object longer than what is left in the file") {
    Bytes big = good;
    big[8] = 0xFF;  // object size 0x..FF: more than the container and the file hold
    big[9] = 0xFF;
    Bytes file = file_header();
    append(file, container(big));
    const Read r = read(file);
    CHECK(r.frames.empty());
    REQUIRE(r.errors.size() == 1);
    CHECK(r.errors[0] == "file ends inside an object (48 bytes of it)");
  }
  SECTION("a container that inflates to another size than it declares") {
    Bytes file = file_header();
    append(file, container(good, false, 1000));
    append(file, container(good));
    const Read r = read(file);
    CHECK(r.frames.size() == 1);
    REQUIRE(!r.errors.empty());
    CHECK(r.errors[0] == "log container inflates to 48 bytes, its header says 1000");
  }
  SECTION("a container declaring more than 16 MiB, and one of an unknown compression method") {
    Bytes file = file_header();
    append(file, container(good, false, 0xFFFFFFF0U));
    Bytes odd = container(good);
    odd[16] = 7;  // compression method
    append(file, odd);
    append(file, container(good));
    const Read r = read(file);
    CHECK(r.frames.size() == 1);
    REQUIRE(r.errors.size() == 2);
    CHECK(r.errors[0] == "log container declares 4294967280 uncompressed bytes, more than this reader accepts");
    CHECK(r.errors[1] == "log container compressed with method 7, which is not zlib (2)");
  }
  SECTION("garbage between containers, and a file cut inside a container") {
    Bytes file = file_header();
    append(file, container(good));
    append(file, Bytes{'x', 'y', 'L', 'O', 'B', 'z', 0, 0, 0});
    append(file, container(good));
    const Bytes last = container(good);
    append(file, Bytes(last.begin(), last.begin() + 40));
    const Read r = read(file);
    CHECK(r.frames.size() == 2);
    REQUIRE(r.errors.size() == 2);
    CHECK(r.errors[0] == "no object signature \"LOBJ\": 9 bytes skipped to the next object");
    CHECK(r.errors[1].starts_with("file ends inside an object ("));
  }
  SECTION("not a BLF file") {
    std::istringstream in("LOGX" + std::string(200, '\0'));
    CHECK_THROWS_AS(BlfReader(in), CaptureOpenError);
  }
}

TEST_CASE("BLF writer: header, objects and containers as Vector's layout has them") {
  std::stringstream out;
  BlfWriter w(out);
  CanFrame f;
  f.id = 0x938;
  f.extended = true;
  f.dlc = 2;
  f.data = {0xAB, 0xCD};
  f.timestamp_ns = kStartNs + 1'234'567;  // the start is the first frame's millisecond
  w.write(f, "can0");
  CanFrame e;
  e.error = true;
  e.id = 0x004;
  e.dlc = 8;
  e.timestamp_ns = kStartNs + 2'000'000;
  w.write(e, "can1");
  w.close();
  const std::string s = out.str();
  const Bytes b(s.begin(), s.end());
  auto le16 = [&](std::size_t at) { return unsigned(b[at] | b[at + 1] << 8); };
  auto le32 = [&](std::size_t at) { return std::uint32_t(le16(at) | le16(at + 2) << 16); };
  REQUIRE(b.size() > 144 + 32);
  CHECK(std::string(s, 0, 4) == "LOGG");
  CHECK(le32(4) == 144);
  CHECK(le32(16) == b.size());  // file size, fixed at close()
  CHECK(le32(32) == 2);         // object count
  const std::array<unsigned, 8> start = {2023, 11, 2, 14, 22, 13, 20, 251};  // the first frame's millisecond
  for (std::size_t i = 0; i < 8; ++i) CHECK(le16(40 + 2 * i) == start[i]);
  // one zlib container with both objects
  CHECK(std::string(s, 144, 4) == "LOBJ");
  CHECK(le32(144 + 12) == 10);
  CHECK(le16(144 + 16) == 2);
  const std::uint32_t inflated = le32(144 + 24);
  CHECK(inflated == 48 + 64);
  Bytes objects(inflated);
  uLongf n = inflated;
  REQUIRE(uncompress(objects.data(), &n, b.data() + 144 + 32, static_cast<uLong>(le32(144 + 8) - 32)) == Z_OK);
  const Bytes first = object(1, can_message(1, 0, 2, 0x80000938, {0xAB, 0xCD}), 234'567);
  CHECK(Bytes(objects.begin(), objects.begin() + 48) == first);
  Bytes error_ext;
  u16(error_ext, 2);
  error_ext.resize(32, 0);
  CHECK(Bytes(objects.begin() + 48, objects.end()) == object(73, error_ext, 1'000'000));
}

TEST_CASE("BLF: many containers: every frame read back in order") {
  std::stringstream out;
  {
    BlfWriter w(out);
    for (std::uint32_t i = 0; i < 20'000; ++i) {  // 20 000 x 48 bytes: 8 containers of 128 KiB
      CanFrame f;
      f.id = i & 0x7FF;
      f.dlc = 4;
      f.data = {std::uint8_t(i), std::uint8_t(i >> 8), std::uint8_t(i >> 16), 0};
      f.timestamp_ns = kStartNs + i * 1000ULL;
      w.write(f, i % 3 ? "can0" : "can1");
    }
    w.close();
  }
  const std::string s = out.str();
  const Read a = read(Bytes(s.begin(), s.end()));
  REQUIRE(a.frames.size() == 20'000);
  CHECK(a.errors.empty());
  for (std::uint32_t i = 0; i < 20'000; ++i) {
    CHECK(a.frames[i].id == (i & 0x7FF));
    CHECK(a.frames[i].data[1] == std::uint8_t(i >> 8));
    CHECK(a.names[i] == (i % 3 ? "can1" : "can0"));  // channels in order of first appearance: can1 came first
  }
}
