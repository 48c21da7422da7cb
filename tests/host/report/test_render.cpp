// The one renderer of decoded messages (format.hpp's append_message, through describe(), to_json() and decode's
// FrameEmitter lines): every line here is written out by hand from the bytes and docs/protocol.md (the VESC
// status frame is protocols.md's test vector), never produced by the code under test. Plus a property on random
// frames of every CAN message: each wire integer in the JSON is the one read from the bytes by the plain reader
// below, and every line parses.
#include <catch2/catch.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <random>
#include <string>
#include <vector>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/signals.hpp"
#include "saulproto/host/report/bus_stats.hpp"
#include "saulproto/host/report/fast_emit.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/frame_text.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

CanFrame frame(std::uint32_t id, bool extended, std::vector<std::uint8_t> bytes) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) f.data[i] = bytes[i];
  f.timestamp_ns = 1'700'000'000'050'000'000ULL;
  return f;
}

std::string line(DecodeFormat format, const CanFrame& f, std::string_view interface = "can0", bool detail = false) {
  FrameEmitter emitter(format, TimeMode::absolute);
  if (detail) emitter.show_error_detail();
  fmt::memory_buffer out;
  DecodeCounts counts;
  emitter.add(f, interface, out, counts);
  return std::string(out.data(), out.size());
}

struct Case {
  CanFrame frame;
  const char* candump;  ///< the frame column
  const char* text;     ///< the message as text shows it
  const char* json;     ///< the message's JSON object
};

// clang-format off
const std::vector<Case> kCases = {
    // 0x3E8 = 1000 mm/s, 0xFE0C = -500 mrad
    {frame(0x300, false, {0xE8, 0x03, 0x0C, 0xFE}), "300#E8030CFE",
     "velocity_cmd speed_mmps=1000 steer_mrad=-500",
     R"({"speed_mmps":1000,"steer_mrad":-500,"type":"velocity_cmd"})"},
    // gain 1 = ki, sequence 7, bytes 2..3 reserved, 1.5f = 0x3FC00000 little-endian
    {frame(0x301, false, {0x01, 0x07, 0x00, 0x00, 0x00, 0x00, 0xC0, 0x3F}), "301#010700000000C03F",
     "pid_gain gain=ki sequence=7 ki=1.5",
     R"({"gain":"ki","ki":1.5,"sequence":7,"type":"pid_gain"})"},
    {frame(0x302, false, {0x03}), "302#03", "mode_cmd mode=estop", R"({"mode":"estop","type":"mode_cmd"})"},
    // tilt 0x05DC = 1500 x 1/100 deg, max speed 0x0320 = 800 mm/s
    {frame(0x303, false, {0xDC, 0x05, 0x20, 0x03}), "303#DC052003",
     "config_cmd tilt_limit=15.00\u00B0 max_speed_mmps=800",
     R"({"max_speed_mmps":800,"tilt_limit":15.0,"tilt_limit_raw":1500,"type":"config_cmd"})"},
    // pitch 0x04D2 = 1234 x 1/100 deg, pid_out 0x78 = 120, speed 0x190 = 400, state 1 = BALANCE
    {frame(0x400, false, {0xD2, 0x04, 0x78, 0x00, 0x90, 0x01, 0x01}), "400#D2047800900101",
     "telemetry_a pitch=12.34\u00B0 pid_out=120 speed_mmps=400 state=BALANCE",
     R"({"pid_out":120,"pitch":12.34,"pitch_raw":1234,"speed_mmps":400,"state":"BALANCE","type":"telemetry_a"})"},
    // pitch 0xFB2E = -1234, pid_out 0xFC18 = -1000, speed 0, state 5 = FAULT
    {frame(0x400, false, {0x2E, 0xFB, 0x18, 0xFC, 0x00, 0x00, 0x05}), "400#2EFB18FC000005",
     "telemetry_a pitch=-12.34\u00B0 pid_out=-1000 speed_mmps=0 state=FAULT",
     R"({"pid_out":-1000,"pitch":-12.34,"pitch_raw":-1234,"speed_mmps":0,"state":"FAULT","type":"telemetry_a"})"},
    // 100 rpm, -100 rpm, battery 0x9BC4 = 39876 mV, fault bits 0 and 2
    {frame(0x401, false, {0x64, 0x00, 0x9C, 0xFF, 0xC4, 0x9B, 0x05}), "401#64009CFFC49B05",
     "telemetry_b vesc_l_rpm=100 vesc_r_rpm=-100 battery=39.876V fault=5",
     R"({"battery":39.876,"battery_raw":39876,"fault":5,"type":"telemetry_b","vesc_l_rpm":100,"vesc_r_rpm":-100})"},
    {frame(0x402, false, {0x01, 0x07, 0x00}), "402#010700", "command_ack command=1 sequence=7 result=applied",
     R"({"command":1,"result":"applied","sequence":7,"type":"command_ack"})"},
    // protocols.md: STATUS from 56: ERPM -1200, 3.5 A, duty 0.25 = 0x938 FF FF FB 50 00 23 00 FA
    {frame(0x938, true, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA}), "00000938#FFFFFB50002300FA",
     "vesc_status_1 controller_id=56 erpm=-1200 current=3.5 duty=0.25",
     R"({"controller_id":56,"current":3.5,"duty":0.25,"erpm":-1200,"type":"vesc_status_1"})"},
    // protocols.md: SET_RPM 1500 -> ID 68 = 0x344: 00 00 05 DC; SET_DUTY 0.10 -> 0x44: 00 00 27 10
    {frame(0x344, true, {0x00, 0x00, 0x05, 0xDC}), "00000344#000005DC", "vesc_set_rpm controller_id=68 erpm=1500",
     R"({"controller_id":68,"erpm":1500,"type":"vesc_set_rpm"})"},
    {frame(0x044, true, {0x00, 0x00, 0x27, 0x10}), "00000044#00002710", "vesc_set_duty controller_id=68 duty=0.1",
     R"({"controller_id":68,"duty":0.1,"type":"vesc_set_duty"})"},
    // STATUS_5 (27 = 0x1B) from 68: tachometer 0x10 = 16, 0x01A4 = 420 x 1/10 V, bytes 6..7 reserved
    {frame(0x1B44, true, {0x00, 0x00, 0x00, 0x10, 0x01, 0xA4, 0x00, 0x00}), "00001B44#0000001001A40000",
     "vesc_status_5 controller_id=68 tachometer=16 voltage_in=42",
     R"({"controller_id":68,"tachometer":16,"type":"vesc_status_5","voltage_in":42.0})"},
    // PONG (18 = 0x12) to 68 from 56, hardware type 0 (a VESC)
    {frame(0x1244, true, {0x38, 0x00}), "00001244#3800", "vesc_pong controller_id=68 responder_id=56 hw_type=0",
     R"({"controller_id":68,"hw_type":0,"responder_id":56,"type":"vesc_pong"})"},
};
// clang-format on

}  // namespace

TEST_CASE("render: each message in text, CSV and JSON, written out by hand") {
  for (const auto& c : kCases) {
    INFO(c.candump);
    const auto decoded = saul::decode_bus_frame(c.frame);
    REQUIRE(decoded);
    CHECK(describe(decoded.value()) == c.text);
    CHECK(json_line(to_json(decoded.value())) == c.json);
    // decode's lines: the time column, the interface, the frame (padded to 24), the message
    CHECK(line(DecodeFormat::text, c.frame) ==
          fmt::format("(1700000000.050000) can0 {:<24} {}\n", c.candump, c.text));
    const std::string_view text = c.text;
    const std::string_view data = std::string_view(c.candump).substr(std::string_view(c.candump).find('#') + 1);
    CHECK(line(DecodeFormat::csv, c.frame) ==
          fmt::format("1700000000.050000,can0,{:X},{},0,{},{},{},{}\n", c.frame.id, c.frame.extended ? 1 : 0,
                      c.frame.dlc, data, text.substr(0, text.find(' ')), text.substr(text.find(' ') + 1)));
    CHECK(line(DecodeFormat::jsonl, c.frame) ==
          fmt::format(R"({{"frame":{{"data":"{}","dlc":{},"error":false,"extended":{},"id":{},"remote":false,)"
                      R"("timestamp_ns":1700000000050000000}},"interface":"can0","message":{},)"
                      R"("time":"1700000000.050000"}})"
                      "\n",
                      data, c.frame.dlc, c.frame.extended ? "true" : "false", c.frame.id, c.json));
  }
}

TEST_CASE("render: frames that do not decode, and error frames with and without what they report") {
  CHECK(line(DecodeFormat::text, frame(0x300, false, {0xE8, 0x03})) ==
        "(1700000000.050000) can0 300#E803                 !wrong_dlc\n");
  CHECK(line(DecodeFormat::csv, frame(0x123, false, {0x11})) ==
        "1700000000.050000,can0,123,0,0,1,11,!unknown_id,\n");
  CHECK(line(DecodeFormat::jsonl, frame(0x302, false, {0x09})) ==
        R"({"error":"out_of_range","frame":{"data":"09","dlc":1,"error":false,"extended":false,"id":770,)"
        R"("remote":false,"timestamp_ns":1700000000050000000},"interface":"can0","time":"1700000000.050000"})"
        "\n");
  // CAN_ERR_BUSOFF (0x40) in the id: decode says only that it is an error frame, sniff what it reports
  CanFrame bus_off = frame(0x40, false, {0, 0, 0, 0, 0, 0, 0, 0});
  bus_off.error = true;
  CHECK(line(DecodeFormat::text, bus_off) ==
        "(1700000000.050000) can0 20000040#0000000000000000 !error_frame\n");
  CHECK(line(DecodeFormat::text, bus_off, "can0", true) ==
        "(1700000000.050000) can0 20000040#0000000000000000 !error_frame BUS-OFF\n");
  CHECK(line(DecodeFormat::jsonl, bus_off, "can0", true) ==
        R"({"error":"error_frame","error_detail":"BUS-OFF","frame":{"data":"0000000000000000","dlc":8,"error":true,)"
        R"("extended":false,"id":64,"remote":false,"timestamp_ns":1700000000050000000},"interface":"can0",)"
        R"("time":"1700000000.050000"})"
        "\n");
}

TEST_CASE("names from files that are not UTF-8, or hold a comma, a quote or a space, still give valid lines") {
  // an interface name of bytes that are not UTF-8 made nlohmann throw: decode --json and stats --json ended with
  // no output at all; a ',' or '"' in a name shifted the frame CSV's columns
  const CanFrame f = frame(0x300, false, {0xE8, 0x03, 0x0C, 0xFE});
  CHECK(nlohmann::json::parse(line(DecodeFormat::jsonl, f, "c\xff\xfe"))["interface"] ==
        "c\xEF\xBF\xBD\xEF\xBF\xBD");  // each byte a U+FFFD
  CHECK(line(DecodeFormat::jsonl, f, "a\"b\\c").find(R"("interface":"a\"b\\c",)") != std::string::npos);
  CHECK(line(DecodeFormat::csv, f, "a,\"b").starts_with("1700000000.050000,\"a,\"\"b\",300,0,0,4,"));
  CHECK(line(DecodeFormat::csv, f, "a\nb").starts_with("1700000000.050000,\"a\nb\",300,"));  // one row, as RFC 4180
  CHECK(line(DecodeFormat::text, f, "a b\tc").starts_with("(1700000000.050000) a_b_c 300#E8030CFE "));
  CHECK(line(DecodeFormat::text, f, "").starts_with("(1700000000.050000) can0 300#"));
  BusStats stats;
  stats.add(f, "c\xff");
  const auto j = nlohmann::json::parse(json_line(stats.json("run\xfe.log")));
  CHECK(j["file"] == "run\xEF\xBF\xBD.log");
  CHECK(j["load"].contains("c\xEF\xBF\xBD"));
  // and the text report sends no control character from a name to the terminal (an escape sequence clears it)
  BusStats escape;
  escape.add(f, "c\x1b[2J");
  CHECK(escape.text("run.log").find("bus load on c_[2J at 500 kbit/s") != std::string::npos);
}

TEST_CASE("a time before the first or the previous frame's is negative, written out by hand") {
  // a log whose times went back (a merge, a clock step): rel and delta once wrapped to "(18446744073.659551)"
  const std::uint64_t t0 = 1'700'000'000'100'000'000ULL;
  const std::uint64_t stamps[] = {t0, t0 - 50'000'000, t0 + 100'000'000, t0 - 2'000'000'000};
  const std::vector<std::string> rel = {"(   0.000000)", "(  -0.050000)", "(   0.100000)", "(  -2.000000)"};
  const std::vector<std::string> delta = {"(   0.000000)", "(  -0.050000)", "(   0.150000)", "(  -2.100000)"};
  for (auto mode : {TimeMode::relative, TimeMode::delta}) {
    const auto& want = mode == TimeMode::relative ? rel : delta;
    TimeColumn column(mode);
    FrameEmitter emitter(DecodeFormat::text, mode);
    fmt::memory_buffer out;
    DecodeCounts counts;
    for (std::size_t i = 0; i < 4; ++i) {
      CHECK(column(stamps[i]) == want[i]);
      CanFrame f;
      f.id = 0x7FF;
      f.timestamp_ns = stamps[i];
      out.clear();
      emitter.add(f, "can0", out, counts);
      CHECK(std::string(out.data(), out.size()).substr(0, want[i].size()) == want[i]);
    }
  }
}

namespace {

/// A byte-aligned integer of the payload, read plainly (not with core/signals' bit walk).
std::int64_t plain_read(const CanFrame& f, const saul::signals::SignalDesc& s) {
  const std::size_t n = s.length / 8;
  const bool le = s.order == saul::signals::ByteOrder::little_endian;
  const std::size_t first = le ? s.start_bit / 8 : (s.start_bit - 7) / 8;
  std::uint64_t u = 0;
  for (std::size_t i = 0; i < n; ++i) u = u << 8 | f.data[le ? first + n - 1 - i : first + i];
  if (s.kind == saul::signals::Kind::signed_int && n < 8 && (u >> (8 * n - 1)) != 0) u |= ~std::uint64_t{0} << (8 * n);
  return static_cast<std::int64_t>(u);
}

}  // namespace

TEST_CASE("render: on random frames of every CAN message, the JSON's wire integers are the bytes' and lines parse") {
  std::mt19937_64 rng(20261129);
  std::size_t checked = 0;
  for (const auto protocol : {saul::signals::Protocol::saul_can, saul::signals::Protocol::vesc_can}) {
    for (const auto& d : saul::signals::messages(protocol)) {
      for (int round = 0; round < 300; ++round) {
        const bool vesc = protocol == saul::signals::Protocol::vesc_can;
        CanFrame f = frame(vesc ? (d.id << 8 | static_cast<std::uint32_t>(rng() % 256)) : d.id, vesc, {});
        f.dlc = d.length;
        for (std::size_t i = 0; i < f.dlc; ++i) f.data[i] = static_cast<std::uint8_t>(round % 2 ? rng() : rng() % 4);
        const std::string json = line(DecodeFormat::jsonl, f);
        const auto j = nlohmann::json::parse(json);
        const auto decoded = saul::decode_bus_frame(f);
        REQUIRE(j.contains("message") == static_cast<bool>(decoded));
        if (!decoded) continue;
        CHECK(line(DecodeFormat::text, f).find(fmt::format(" {} ", d.name)) != std::string::npos);
        const auto& m = j["message"];
        CHECK(m["type"] == d.name);
        for (const auto& s : d.signals) {
          if (s.kind == saul::signals::Kind::string || s.kind == saul::signals::Kind::float32 || s.length % 8 != 0 ||
              s.text != saul::signals::Text::raw || s.mux != saul::signals::Mux::none)
            continue;
          const std::int64_t want = s.place == saul::signals::Place::can_id ? (f.id & 0xFF) : plain_read(f, s);
          // a scaled wire integer is kept under its name + "_raw" (its name holds the physical value)
          const std::string key = saul::signals::text_in_unit(s) ? std::string(s.name) + "_raw" : s.name;
          INFO(d.name << "." << key << " " << json);
          CHECK(m.at(key) == want);
          ++checked;
        }
      }
    }
  }
  CHECK(checked > 8000);
}
