// The loop trace record (trace.hpp, docs/protocol.md section 10): the worked example's bytes written out by hand
// (little-endian fields, CRC-8/MAXIM computed bit by bit here), and the console decoder that separates text lines
// from records checked against a plain reference model over long seeded random streams.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "saulproto/core/trace.hpp"

using namespace saul;
using namespace saul::trace;
using Bytes = std::vector<std::uint8_t>;

namespace {

std::uint8_t crc8_maxim_bitwise(const std::uint8_t* data, std::size_t n) {
  std::uint8_t crc = 0;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= data[i];
    for (int bit = 0; bit < 8; ++bit) crc = (crc & 1U) != 0 ? static_cast<std::uint8_t>((crc >> 1) ^ 0x8C) : crc >> 1;
  }
  return crc;
}

// docs/protocol.md section 10, the worked example.
const LoopTrace kExample{1'000'000, 1000, -123, 456, -50, 200, -15, -30, 155, 400, 410, 180, 0, 1, 0x02, 2, 100};
const Bytes kExampleBytes{
    0xAA, 0x23, 0x20,                    // start, LEN 35, TYPE 0x20
    0x40, 0x42, 0x0F, 0x00,              // time_us 1 000 000 = 0x000F4240
    0xE8, 0x03, 0x00, 0x00,              // seq 1000
    0x85, 0xFF,                          // pitch -1.23 deg = -123 = 0xFF85
    0xC8, 0x01,                          // rate 45.6 deg/s = 456
    0xCE, 0xFF,                          // setpoint -0.50 deg = -50
    0xC8, 0x00, 0xF1, 0xFF, 0xE2, 0xFF,  // P 200, I -15, D -30 permille
    0x9B, 0x00,                          // output 155 permille
    0x90, 0x01, 0x9A, 0x01,              // ERPM left 400, right 410
    0xB4, 0x00, 0x00, 0x00,              // wheel 180 mm/s, request 0 mm/s
    0x01, 0x02, 0x02,                    // state BALANCE, faults 0x02, excite chirp
    0x64, 0x00,                          // excitation +1.00 deg
    0x86};                               // CRC-8/MAXIM of 20 .. 00

struct Collect {
  std::vector<std::pair<LoopTrace, std::uint64_t>> records;
  std::string text;  // lines joined with '\n' after each
  std::vector<std::pair<Reason, std::uint64_t>> rejections;
  void record(const LoopTrace& r, std::uint64_t offset) { records.emplace_back(r, offset); }
  void line(std::string_view l, bool) {
    text += l;
    text += '\n';
  }
  void rejected(Reason reason, std::uint64_t offset) { rejections.emplace_back(reason, offset); }
};

bool is_record_at(const Bytes& in, std::size_t i) {
  return in.size() - i >= kFrameSize && in[i] == 0xAA && in[i + 1] == 35 && in[i + 2] == 0x20 &&
         crc8_maxim_bitwise(&in[i + 2], 36) == in[i + 38];
}

}  // namespace

TEST_CASE("trace: the worked example encodes to its hand-written bytes and decodes back") {
  REQUIRE(crc8_maxim_bitwise(reinterpret_cast<const std::uint8_t*>("123456789"), 9) == 0xA1);
  REQUIRE(kExampleBytes.size() == kFrameSize);
  REQUIRE(crc8_maxim_bitwise(&kExampleBytes[2], 36) == kExampleBytes.back());
  std::array<std::uint8_t, kFrameSize> out{};
  const auto n = encode(kExample, out);
  REQUIRE(n.ok());
  CHECK(Bytes(out.begin(), out.end()) == kExampleBytes);
  const auto back = decode_payload(std::span<const std::uint8_t>(kExampleBytes).subspan(3, kPayloadLength));
  REQUIRE(back.ok());
  CHECK(*back == kExample);
  CHECK(decode_payload(std::span<const std::uint8_t>(kExampleBytes).subspan(3, 34)).reason() == Reason::bad_length);
  std::array<std::uint8_t, kFrameSize - 1> small{};
  CHECK(encode(kExample, small).reason() == Reason::buffer_too_small);
}

TEST_CASE("trace: every field lands at its own offset (each field alone at its extreme values)") {
  // One field at a time set to a pattern; every other byte of the payload must stay zero.
  LoopTrace r{};
  r.excite_x100 = -2;  // FE FF at 33..34
  std::array<std::uint8_t, kFrameSize> out{};
  REQUIRE(encode(r, out).ok());
  for (std::size_t i = 3; i < 3 + 33; ++i) CHECK(out[i] == 0);
  CHECK(out[36] == 0xFE);
  CHECK(out[37] == 0xFF);
  r = {};
  r.seq = 0x11223344;
  REQUIRE(encode(r, out).ok());
  CHECK(Bytes(out.begin() + 7, out.begin() + 11) == Bytes{0x44, 0x33, 0x22, 0x11});
  r = {};
  r.request_mmps = -32768;  // offset 28
  REQUIRE(encode(r, out).ok());
  CHECK(out[3 + 28] == 0x00);
  CHECK(out[3 + 29] == 0x80);
}

TEST_CASE("trace: the console decoder hands text lines and records on in stream order, with offsets") {
  Bytes in;
  const std::string a = "ok\r\nstatus line\n";
  in.insert(in.end(), a.begin(), a.end());
  in.insert(in.end(), kExampleBytes.begin(), kExampleBytes.end());  // offset 16
  const std::string b = "after";
  in.insert(in.end(), b.begin(), b.end());
  Bytes bad = kExampleBytes;
  bad[20] ^= 0x01;  // a corrupt record at offset 60: CRC error, its bytes scanned again
  in.insert(in.end(), bad.begin(), bad.end());
  in.push_back('\n');
  ConsoleDecoder d;
  Collect c;
  d.push(in, c);
  d.finish(c);
  REQUIRE(c.records.size() == 1);
  CHECK(c.records[0].first == kExample);
  CHECK(c.records[0].second == 16);
  REQUIRE(c.rejections.size() == 1);
  CHECK(c.rejections[0] == std::pair{Reason::bad_crc, std::uint64_t{60}});
  CHECK(d.counters().crc_errors == 1);
  CHECK(d.counters().records == 1);
  CHECK(d.counters().bytes_skipped == 1);
  // The corrupt record's bytes after its 0xAA hold no 0xAA: they come out as text, in order.
  CHECK(c.text == "ok\nstatus line\nafter" + std::string(bad.begin() + 1, bad.end()) + "\n");
  CHECK(d.counters().text_bytes == in.size() - kFrameSize - 1);
}

TEST_CASE("trace: the console decoder agrees with a plain model on long random streams of text, records and noise") {
  for (std::uint32_t seed = 1; seed <= 200; ++seed) {
    INFO("seed " << seed);
    std::mt19937 engine(seed);
    const auto rng = [&engine] { return static_cast<std::uint32_t>(engine()); };
    Bytes in;
    std::size_t records_sent = 0;
    for (int piece = 0; piece < 60; ++piece) {
      const auto kind = rng() % 6;
      if (kind <= 1) {  // a text line
        const auto n = rng() % 40;
        for (std::size_t i = 0; i < n; ++i) in.push_back(static_cast<std::uint8_t>(0x20 + rng() % 95));
        in.push_back('\n');
      } else if (kind <= 3) {  // a record
        LoopTrace r{};
        r.time_us = rng();
        r.seq = rng();
        r.pitch_x100 = static_cast<std::int16_t>(rng());
        r.output = static_cast<std::int16_t>(rng());
        r.excite_x100 = static_cast<std::int16_t>(rng());
        std::array<std::uint8_t, kFrameSize> f{};
        REQUIRE(encode(r, f).ok());
        in.insert(in.end(), f.begin(), f.end());
        ++records_sent;
      } else if (kind == 4) {  // a record cut short or with a flipped bit
        std::array<std::uint8_t, kFrameSize> f{};
        REQUIRE(encode(LoopTrace{rng(), rng()}, f).ok());
        const auto cut = 1 + rng() % kFrameSize;
        if (cut < kFrameSize) {
          in.insert(in.end(), f.begin(), f.begin() + static_cast<std::ptrdiff_t>(cut));
        } else {
          f[1 + rng() % (kFrameSize - 1)] ^= static_cast<std::uint8_t>(1U << (rng() % 8));
          in.insert(in.end(), f.begin(), f.end());
        }
      } else {  // noise, 0xAA often
        const auto n = 1 + rng() % 8;
        for (std::size_t i = 0; i < n; ++i) in.push_back(rng() % 3 == 0 ? 0xAA : static_cast<std::uint8_t>(rng()));
      }
    }
    // The model: at every offset, a whole valid record is taken and jumped over; else a non-0xAA byte is text and
    // a 0xAA is skipped. Lines end at '\n'.
    std::vector<std::uint64_t> offsets;
    std::uint64_t text = 0, skipped = 0;
    for (std::size_t i = 0; i < in.size();) {
      if (is_record_at(in, i)) {
        offsets.push_back(i);
        i += kFrameSize;
      } else {
        (in[i] == 0xAA ? skipped : text) += 1;
        ++i;
      }
    }
    ConsoleDecoder d;
    Collect c;
    for (std::size_t i = 0; i < in.size(); ++i) {
      d.push(in[i], c);
      REQUIRE(d.offset() == i + 1);
    }
    d.finish(c);
    REQUIRE(c.records.size() == offsets.size());
    for (std::size_t i = 0; i < offsets.size(); ++i) CHECK(c.records[i].second == offsets[i]);
    CHECK(records_sent <= offsets.size());  // a cut record's prefix never hides a whole one after it
    CHECK(d.counters().text_bytes == text);
    CHECK(d.counters().bytes_skipped == skipped);
    CHECK(d.counters().records == offsets.size());
    CHECK(d.pending() == 0);
    const auto& k = d.counters();
    CHECK(k.crc_errors + k.length_errors + k.unknown_types + k.truncated == c.rejections.size());
    for (const auto& [reason, offset] : c.rejections) CHECK(in[offset] == 0xAA);
  }
}

TEST_CASE("trace: console commands read back from their own formatting, and the refusals name the rule") {
  const Command commands[] = {TraceOn{1}, TraceOn{1000}, TraceOff{}, TraceDump{}, TraceArm{}, ExciteOff{},
                              ExciteStart{Excite::step, -1.5F, 0, 0, 20.0F}, ExciteStart{Excite::prbs, 2.0F, 0, 0, 0.25F},
                              ExciteStart{Excite::chirp, 0.1F, 0.05F, 100.0F, 7.5F}};
  for (const auto& c : commands) {
    char line[64];
    const auto n = format_command(c, line);
    REQUIRE(n.ok());
    INFO(line);
    const auto back = parse_command(std::string_view(line, *n));
    REQUIRE(back.matched);
    REQUIRE(back.error.reason == Reason::ok);
    CHECK(back.command.index() == c.index());
    if (const auto* e = std::get_if<ExciteStart>(&c)) {
      const auto& b = std::get<ExciteStart>(back.command);
      CHECK(b.kind == e->kind);
      CHECK(b.amplitude_deg == e->amplitude_deg);
      CHECK(b.f0_hz == e->f0_hz);
      CHECK(b.f1_hz == e->f1_hz);
      CHECK(b.duration_s == e->duration_s);
    }
    if (const auto* on = std::get_if<TraceOn>(&c)) CHECK(std::get<TraceOn>(back.command).divider == on->divider);
  }
  CHECK(std::string_view(format_command(TraceOn{7}, std::span<char>()).ok() ? "" : "too small") == "too small");
  CHECK_FALSE(parse_command("status").matched);
  CHECK_FALSE(parse_command("").matched);
  CHECK(parse_command("Excite OFF").error.reason == Reason::unknown_command);  // the sub-word is exact
  CHECK(parse_command("excite step 0 2").error.reason == Reason::out_of_range);
  CHECK(parse_command("excite step 2.01 2").error.reason == Reason::out_of_range);
  CHECK(parse_command("excite step -2 20").error.reason == Reason::ok);
  CHECK(parse_command("excite prbs 1 20.001").error.reason == Reason::out_of_range);
  CHECK(parse_command("excite prbs 1 0").error.reason == Reason::out_of_range);
  CHECK(parse_command("excite chirp 1 0.04 5 2").error.argument == 3);
  CHECK(parse_command("excite chirp 1 1 nan 2").error.reason == Reason::not_finite);
  CHECK(parse_command("excite step 1 2 3").error.reason == Reason::extra_argument);
  CHECK(parse_command("trace on 1 2 3 4 5 6 7 8").error.reason == Reason::extra_argument);
  CHECK(parse_command("trace").error.reason == Reason::missing_argument);
  CHECK(parse_command("trace on 1001").error.reason == Reason::out_of_range);
}
