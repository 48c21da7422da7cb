// saulctl stats' arithmetic: CAN frame lengths on the wire, and the per-id, load and silence statistics of a
// small hand-made capture whose numbers are worked out by hand in the comments.
#include <algorithm>
#include <array>
#include <cmath>
#include <catch2/catch.hpp>

#include <fmt/format.h>

#include <initializer_list>
#include <map>
#include <random>
#include <sstream>
#include <vector>

#include "saulproto/host/report/bus_stats.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "host/temp_file.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

/// stats of the candump file at `path` through add_capture: with `ahead` in blocks of `block` bytes on two threads
/// (whatever its size), else in batches on one thread.
void add_candump_path(BusStats& stats, const std::string& path, bool ahead,
                      const std::function<void(const saul::host::CaptureError&)>& on_corrupt,
                      const std::function<void(std::uint64_t, std::uint64_t)>& on_progress,
                      const std::function<void(const saul::CanFrame&)>& also, std::uint64_t block) {
  auto opened = saul::host::open_capture(path);
  saul::host::ReadOptions read;
  read.threads = ahead ? 2 : 1;
  read.parallel_from = 0;
  read.block = block;
  add_capture(stats, path, opened.frames, opened.compressed, read, on_corrupt, on_progress, also);
}

constexpr std::uint64_t kMs = 1'000'000ULL;

CanFrame frame(std::uint32_t id, bool extended, std::initializer_list<std::uint8_t> bytes,
               std::optional<std::uint64_t> ns = std::nullopt) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  f.timestamp_ns = ns;
  return f;
}

}  // namespace

TEST_CASE("CAN frame lengths on the wire") {
  // A 4-byte standard data frame (0x300 E8 03 0C FE), by hand:
  //   stuffed part: SOF 1 + id 11 + RTR 1 + IDE 1 + r0 1 + DLC 4 = 19, data 4 x 8 = 32, CRC 15  -> 66 bits
  //   fixed tail:   CRC delimiter 1 + ACK slot 1 + ACK delimiter 1 + EOF 7 + intermission 3    -> 13 bits
  //   no stuffing:  66 + 13 = 79 bits
  //   worst case:   a stuff bit after the first 5 equal bits, then after every 4 more (each stuff bit starts the
  //                 next run): floor((66 - 1) / 4) = 16 -> 95 bits (can-utils canbusload's default)
  //   exact:        this frame's bits and CRC-15 (0x18D8, checked in test_can_bits.cpp) need 4 stuff bits -> 83 bits
  //                 (from an independent bit-level model in Python, not from this code)
  const CanFrame velocity = frame(0x300, false, {0xE8, 0x03, 0x0C, 0xFE});
  CHECK(can_frame_bits(velocity, StuffBits::none) == 79);
  CHECK(can_frame_bits(velocity, StuffBits::worst_case) == 95);
  CHECK(can_frame_bits(velocity, StuffBits::exact) == 83);
  // id 0, no data: all 34 stuffed bits are 0 (the CRC of zeros is 0), so one stuff bit after each 5 zeros:
  // 34 / 5 -> 6 stuff bits, 47 + 6 = 53; the worst case says floor(33 / 4) = 8 -> 55.
  const CanFrame zero = frame(0x000, false, {});
  CHECK(can_frame_bits(zero, StuffBits::exact) == 53);
  CHECK(can_frame_bits(zero, StuffBits::worst_case) == 55);
  // 8 bytes, standard: 47 + 64 + floor(97 / 4) = 135 worst case, 111 without stuffing; so at most 3703 and at
  // least 4504 such frames per second fit 500 kbit/s.
  const CanFrame eight = frame(0x7FF, false, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF});
  CHECK(can_frame_bits(eight, StuffBits::worst_case) == 135);
  CHECK(can_frame_bits(eight, StuffBits::none) == 111);
  CHECK(can_frame_bits(eight, StuffBits::exact) == 126);  // Python model: 15 stuff bits
  // 29-bit: SOF 1 + base id 11 + SRR 1 + IDE 1 + id 18 + RTR 1 + r1 r0 2 + DLC 4 + data + CRC 15 = 54 + 8n,
  // + 13 -> 67 + 8n. VESC SET_RPM (4 bytes): 99 bits, worst 99 + floor(85 / 4) = 120; exact 109 (Python model).
  const CanFrame rpm = frame(0x344, true, {0x00, 0x00, 0x00, 0x85});
  CHECK(can_frame_bits(rpm, StuffBits::none) == 99);
  CHECK(can_frame_bits(rpm, StuffBits::worst_case) == 120);
  CHECK(can_frame_bits(rpm, StuffBits::exact) == 109);
  // A remote frame carries no data whatever its DLC; an error frame is no frame on the wire.
  CanFrame rtr = frame(0x123, false, {});
  rtr.remote = true;
  rtr.dlc = 4;
  CHECK(can_frame_bits(rtr, StuffBits::none) == 47);
  CanFrame err = frame(0x040, false, {0, 0, 0, 0, 0, 0, 0, 0});
  err.error = true;
  CHECK(can_frame_bits(err, StuffBits::worst_case) == 0);
  // 29-bit with 8 bytes, the longest frame (VESC STATUS from controller 56, 0x938 FF FF FB 50 00 23 00 FA): 67 + 64 =
  // 131 bits without stuffing; CRC-15 0x63C6 and 12 stuff bits -> 143 exact (Python model). All 8 bytes zero on
  // id 0x1FFFFFFF: CRC 0x7DA3, 20 stuff bits -> 151. (Regression: these once overran the bit buffer.)
  const CanFrame status = frame(0x938, true, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA});
  CHECK(can_frame_bits(status, StuffBits::none) == 131);
  CHECK(can_frame_bits(status, StuffBits::exact) == 143);
  const CanFrame zeros29 = frame(0x1FFFFFFF, true, {0, 0, 0, 0, 0, 0, 0, 0});
  CHECK(can_frame_bits(zeros29, StuffBits::exact) == 151);
}

TEST_CASE("bus statistics: error frames counted by class bit, none of them 'unspecified'") {
  // linux/can/error.h: CAN_ERR_LOSTARB 0x002, CAN_ERR_CRTL 0x004, CAN_ERR_BUSOFF 0x040, CAN_ERR_CNT 0x200; bits
  // above 0x3FF name no class.
  BusStats stats;
  for (std::uint32_t id : {0x000u, 0x046u, 0x200u, 0x400u, 0x002u}) {
    CanFrame e = frame(id, false, {0, 0, 0, 0, 0, 0, 0, 0});
    e.error = true;
    stats.add(e, "can0");
  }
  CHECK(stats.error_frames() == 5);
  const std::map<std::string, std::uint64_t> expected = {{"unspecified", 2},    {"lost_arbitration", 2},
                                                         {"controller", 1},     {"bus_off", 1},
                                                         {"error_counters", 1}};
  CHECK(stats.error_kinds() == expected);
}

TEST_CASE("bus statistics of a hand-made capture") {
  // t (ms): 0 and 50: 0x300 (4 bytes); 650: 0x300 (a 600 ms silence, over the 500 ms Orin timeout);
  // 700: 0x123 (2 bytes, unknown id); 800: an error frame (bus-off); 1000: 0x300 with 3 bytes (wrong DLC).
  BusStats stats;
  stats.add(frame(0x300, false, {0xE8, 0x03, 0x0C, 0xFE}, 0), "can0");
  stats.add(frame(0x300, false, {0xE8, 0x03, 0x0C, 0xFE}, 50 * kMs), "can0");
  stats.add(frame(0x300, false, {0xE8, 0x03, 0x0C, 0xFE}, 650 * kMs), "can0");
  stats.add(frame(0x123, false, {0x01, 0x02}, 700 * kMs), "can0");
  CanFrame busoff = frame(0x040, false, {0, 0, 0, 0, 0, 0, 0, 0}, 800 * kMs);
  busoff.error = true;
  stats.add(busoff, "can0");
  stats.add(frame(0x300, false, {0xE8, 0x03, 0x0C}, 1000 * kMs), "can0");
  stats.add_corrupt();

  CHECK(stats.frames() == 6);
  CHECK(stats.corrupt() == 1);
  CHECK(stats.error_frames() == 1);
  CHECK(stats.error_kinds().at("bus_off") == 1);
  CHECK(stats.decode_errors() == 2);
  CHECK(stats.decode_failures().at("unknown_id") == 1);
  CHECK(stats.decode_failures().at("wrong_dlc") == 1);

  // Worst-case bits: 3 x 95 (0x300, 4 bytes) + 85 (0x300, 3 bytes: 47 + 24 + floor(57 / 4)) + 75 (0x123, 2 bytes:
  // 47 + 16 + floor(49 / 4)) = 445 bits in 1.000 s at 500 kbit/s = 0.089 %.
  const auto& load = stats.interfaces().at("can0");
  CHECK(load.bits_worst == 445);
  CHECK(stats.load_percent(load, StuffBits::worst_case) == Approx(0.089));
  // Busiest 100 ms window: the first, with two 0x300 (190 bits of 50 000): 0.38 %.
  CHECK(load.peak_bits == 190);
  CHECK(stats.peak_percent(load) == Approx(0.38));

  const auto& velocity = stats.ids().at({false, 0x300});
  CHECK(velocity.type == "velocity_cmd");
  CHECK(velocity.cadence.count == 4);
  CHECK(velocity.cadence.max_gap_ns == 600 * kMs);
  CHECK(velocity.cadence.max_gap_start_ns == 50 * kMs);
  CHECK(velocity.cadence.gaps_over_timeout == 1);
  CHECK(velocity.cadence.rate_hz() == Approx(3.0));        // 3 gaps in 1 s
  CHECK(velocity.cadence.mean_gap_ns() == Approx(1e9 / 3));  // (50 + 600 + 350) / 3 ms
  // deviations from 333.33 ms: -283.33, 266.67, 16.67; mean square 50 555.6 ms^2; root 224.85 ms
  CHECK(velocity.cadence.jitter_ns() == Approx(224.8456e6).epsilon(1e-6));
  CHECK(velocity.decode_errors == 1);
  CHECK(stats.ids().at({false, 0x123}).type == "!unknown_id");

  const auto j = stats.json("hand.log");
  CHECK(j["frames"] == 6);
  CHECK(j["load"]["can0"]["bits_worst_case"] == 445);
  CHECK(j["ids"][1]["id_hex"] == "300");
  CHECK(j["ids"][1]["max_gap_s"] == Approx(0.6));
  CHECK(j["ids"][1]["silences_over_orin_timeout"] == 1);
  const std::string text = stats.text("hand.log");
  CHECK(text.find("0x300 velocity_cmd: longest silence 600.000 ms from +0.050 s; 1 silences over the 500 ms Orin "
                  "timeout") != std::string::npos);
  CHECK(text.find("error frames: 1 (1 bus_off)") != std::string::npos);
  CHECK(text.find("decode errors: 2 (1 unknown_id, 1 wrong_dlc)") != std::string::npos);
}

TEST_CASE("stats of the bundled sample match make_robot_bus.py's story") {
  auto reader = open_capture_reader(std::string(SAUL_SOURCE_DIR) + "/captures/robot_bus.log");
  BusStats stats;
  for (FrameBatch batch; reader->next_batch(batch);) {
    REQUIRE(batch.corrupt.empty());
    for (std::size_t i = 0; i < batch.frames.size(); ++i) stats.add(batch.frames[i], batch.interfaces[i]);
  }
  CHECK(stats.frames() == 452);
  // Worst-case bits by hand, per id x count: 0x300 95 x 44, 0x400/0x401 125 x 30 each, 0x302 65, 0x402 85 x 3,
  // 0x301 135 x 3, 0x303 95, SET_RPM 120 x 250, STATUS and STATUS_5 160 x 90 = 56 900 bits; first frame at
  // 0.0009 s, last (SET_RPM of step 298) at 2.9803 s: 56 900 / (2.9794 s x 500 000) = 3.819 %.
  const auto& load = stats.interfaces().at("can0");
  CHECK(load.bits_worst == 56'900);
  CHECK(stats.load_percent(load, StuffBits::worst_case) == Approx(3.819).epsilon(0.001));
  const auto& velocity = stats.ids().at({false, 0x300});
  CHECK(velocity.cadence.count == 44);  // steps 80, 85, ..., 295
  CHECK(velocity.cadence.max_gap_ns == 50 * kMs);
  CHECK(velocity.cadence.gaps_over_timeout == 0);
  CHECK(stats.ids().at({true, 0x344}).cadence.count == 125);
  CHECK(stats.decode_errors() == 0);
}

TEST_CASE("serial statistics: counts per message type and the decoder's counters") {
  auto reader = open_serial_capture_reader(std::string(SAUL_SOURCE_DIR) + "/captures/pride_uart.serial");
  SerialStats stats;
  while (reader->next() == SerialCaptureReader::Status::chunk) stats.add(reader->chunk());
  stats.finish();
  const auto& link = stats.links().at("serial:/dev/ttyUSB1@38400:8E1");
  CHECK(link.baud == 38400);
  CHECK(link.bits_per_byte == 11);  // 8E1: start, 8 data, parity, stop
  CHECK(link.bytes == 48);
  CHECK(link.messages.at("vcu_command").count == 4);
  CHECK(link.messages.at("vcu_command").max_gap_ns == 5 * kMs);
  CHECK(link.messages.at("controller_status").count == 4);
  CHECK(stats.decode_errors() == 0);
  const auto j = stats.json("pride");
  CHECK(j["links"][0]["decoder"]["frames"] == 8);
}

TEST_CASE("serial statistics decode the first links and count the chunks of the others apart") {
  // a capture whose link column is noise once took a decoder per name, found by a walk (300 000 names: 1 GB, 344 s)
  SerialStats stats;
  const std::vector<std::uint8_t> pride = {0xFE, 0x54, 0x07, 0x32, 0x00, 0x74};  // vcu_command, as in pride_uart.serial
  std::uint64_t other_chunks = 0, other_bytes = 0;
  for (int round = 0; round < 3; ++round) {
    for (std::size_t i = 0; i < SerialCaptureDecoder::kMaxLinks + 36; ++i) {
      SerialChunk c;
      c.timestamp_ns = 1'000'000ULL * (round * 1000 + i);
      c.link = fmt::format("serial:/dev/ttyUSB{}@38400:8E1", i);
      c.protocol = SerialProtocol::pride;
      c.bytes = pride;
      if (i >= SerialCaptureDecoder::kMaxLinks) {
        ++other_chunks;
        other_bytes += c.bytes.size();
      }
      stats.add(c);
    }
  }
  stats.finish();
  CHECK(stats.links().size() == SerialCaptureDecoder::kMaxLinks);
  CHECK(stats.links().at("serial:/dev/ttyUSB63@38400:8E1").messages.at("vcu_command").count == 3);
  CHECK(stats.links().count("serial:/dev/ttyUSB64@38400:8E1") == 0);
  CHECK(stats.decoder().links().size() == SerialCaptureDecoder::kMaxLinks);
  CHECK(stats.decoder().unlisted().chunks == other_chunks);
  CHECK(stats.decoder().unlisted().bytes == other_bytes);
  const auto j = stats.json("noise");
  CHECK(j["links"].size() == SerialCaptureDecoder::kMaxLinks);
  CHECK(j["links_not_listed"]["chunks"] == other_chunks);
  CHECK(stats.text("noise").find("108 chunks (648 bytes) on links beyond the first 64: not decoded") !=
        std::string::npos);
}

// ---- blocks counted apart and appended (stats on both cores) ----------------------------------------------------
// The property: for any frames and any cut into blocks, appending the blocks' BusStats(options, Block{}) in order
// gives what add() of every frame on one BusStats gives, to the last bit of every figure (the text and the JSON).

namespace {

struct Event {
  CanFrame frame;
  std::string interface;
  bool corrupt = false;
};

/// Frames a capture can hold, hostile ones included: several interfaces, standard and extended ids (0x300 among
/// them, with silences over the Orin timeout), remote and error frames, payloads that decode and that do not, times
/// that repeat (equal gaps: the first longest gap must win), go back, are missing or sit near 2^64.
std::vector<Event> random_events(std::mt19937_64& rng, std::size_t n) {
  static const char* const kInterfaces[] = {"can0", "can1", "vcan7"};
  static const std::uint32_t kStandard[] = {0x300, 0x301, 0x400, 0x401, 0x402, 0x123};
  static const std::uint32_t kExtended[] = {0x944, 0x938, 0x1B44, 0x344, 0x1FFFFFFF};
  std::vector<Event> events;
  std::uint64_t t = (rng() % 4 == 0) ? ~std::uint64_t{0} - 5'000'000'000ULL : 1'763'800'000'000'000'000ULL;
  for (std::size_t i = 0; i < n; ++i) {
    Event e;
    if (rng() % 40 == 0) {
      e.corrupt = true;
      events.push_back(e);
      continue;
    }
    CanFrame& f = e.frame;
    e.interface = kInterfaces[rng() % (rng() % 3 == 0 ? 3 : 1)];
    f.extended = rng() % 3 == 0;
    f.id = f.extended ? kExtended[rng() % 5] : kStandard[rng() % 6];
    f.dlc = static_cast<std::uint8_t>(rng() % 9);
    if (rng() % 4 != 0 && !f.extended && f.id == 0x300) f.dlc = 4;  // mostly a velocity command that decodes
    for (auto& b : f.data) b = static_cast<std::uint8_t>(rng() % 3 == 0 ? rng() : 0);
    f.remote = rng() % 25 == 0;
    if (rng() % 30 == 0) {
      f.error = true;
      f.id = static_cast<std::uint32_t>(rng() % 0x400);
      f.dlc = 8;
    }
    static const std::uint64_t kGaps[] = {0, 1'000'000, 10'000'000, 10'000'000, 120'000'000, 700'000'000};
    switch (rng() % 20) {
      case 0: f.timestamp_ns = std::nullopt; break;                          // no time
      case 1: f.timestamp_ns = t - std::min<std::uint64_t>(t, 50'000'000); break;  // back in time
      default:
        t += std::min(kGaps[rng() % 6], ~std::uint64_t{0} - t);  // held at 2^64 - 1 at the end
        f.timestamp_ns = t;
    }
    events.push_back(e);
  }
  return events;
}

void add(BusStats& stats, const Event& e) {
  if (e.corrupt)
    stats.add_corrupt();
  else
    stats.add(e.frame, e.interface);
}

/// `events` counted in blocks (`cuts`: block k is events [cuts[k], cuts[k + 1])), appended in order as
/// stats does, with detours: some blocks appended to another block first, which then may count the next block's
/// frames itself before it is appended.
BusStats appended_in_blocks(const std::vector<Event>& events, const std::vector<std::size_t>& cuts,
                            const BusStatsOptions& options, std::mt19937_64& rng) {
  BusStats total(options);
  BusStats block(options, BusStats::Block{});
  BusStats gathered(options, BusStats::Block{});
  bool gathering = false;
  for (std::size_t b = 0; b + 1 < cuts.size(); ++b) {
    if (gathering && rng() % 2 == 0) {  // frames counted straight into a block that was appended to
      for (std::size_t i = cuts[b]; i < cuts[b + 1]; ++i) add(gathered, events[i]);
      continue;
    }
    block.restart_block(options);
    for (std::size_t i = cuts[b]; i < cuts[b + 1]; ++i) add(block, events[i]);
    if (rng() % 3 == 0) {  // into a block first
      gathered.append(block);
      gathering = true;
      continue;
    }
    if (gathering) {
      total.append(gathered);
      gathered.restart_block(options);
      gathering = false;
    }
    total.append(block);
  }
  if (gathering) total.append(gathered);
  return total;
}

}  // namespace

TEST_CASE("stats of blocks appended in order equal one pass over every frame") {
  std::mt19937_64 rng(20261124);
  for (int round = 0; round < 400; ++round) {
    INFO("round " << round);
    BusStatsOptions options;
    options.window_ns = (rng() % 2 == 0 ? 100 : 1 + rng() % 1000) * kMs;
    const auto events = random_events(rng, rng() % 300);
    BusStats one(options);
    for (const Event& e : events) add(one, e);

    // cut anywhere, empty blocks included
    std::vector<std::size_t> cuts{0, events.size()};
    for (int c = static_cast<int>(rng() % 6); c-- > 0;) cuts.push_back(events.empty() ? 0 : rng() % events.size());
    std::sort(cuts.begin(), cuts.end());
    BusStats appended(options);
    for (std::size_t b = 0; b + 1 < cuts.size(); ++b) {
      BusStats block(options, BusStats::Block{});
      for (std::size_t i = cuts[b]; i < cuts[b + 1]; ++i) add(block, events[i]);
      appended.append(block);
    }
    REQUIRE(appended.json("f").dump() == one.json("f").dump());
    REQUIRE(appended.text("f") == one.text("f"));

    // The same with blocks restarted for each block, some appended to another block before the total, which then
    // may count frames of its own.
    const BusStats gathered = appended_in_blocks(events, cuts, options, rng);
    REQUIRE(gathered.json("f").dump() == one.json("f").dump());
    REQUIRE(gathered.text("f") == one.text("f"));

    // The busiest window against the rule written out plainly (a division per frame): windows of window_ns from
    // the interface's first timed frame, in file order; a frame that falls in an earlier window counts in the
    // current one.
    struct Model {
      std::optional<std::uint64_t> first;
      std::uint64_t index = 0, bits = 0, peak = 0, peak_index = 0;
    };
    std::map<std::string, Model> model;
    for (const Event& e : events) {
      if (e.corrupt || e.frame.error || !e.frame.timestamp_ns) continue;
      Model& m = model[e.interface];
      const std::uint64_t ns = *e.frame.timestamp_ns;
      if (!m.first) m.first = ns;
      const std::uint64_t index = (ns >= *m.first ? ns - *m.first : 0) / options.window_ns;
      if (index > m.index) {
        m.index = index;
        m.bits = 0;
      }
      m.bits += can_frame_bits(e.frame, StuffBits::worst_case);
      if (m.bits > m.peak) {
        m.peak = m.bits;
        m.peak_index = m.index;
      }
    }
    for (const auto& [name, m] : model) {
      INFO(name);
      REQUIRE(one.interfaces().at(name).peak_bits == m.peak);
      REQUIRE(one.interfaces().at(name).peak_index == m.peak_index);
    }
  }
}

TEST_CASE("a capture lists its first ids and interfaces, the rest counted apart, in blocks as in one pass") {
  // a log whose id or interface column is noise once took memory without end (2 M ids: 0.9 GB, 3.4 GB for --json)
  std::mt19937_64 rng(20261128);
  for (int round = 0; round < 12; ++round) {
    INFO("round " << round);
    std::vector<Event> events;
    const std::size_t n = 6000 + rng() % 4000;
    for (std::size_t i = 0; i < n; ++i) {
      Event e;
      if (rng() % 50 == 0) {
        e.corrupt = true;
        events.push_back(e);
        continue;
      }
      CanFrame& f = e.frame;
      e.interface = fmt::format("if{}", rng() % (round % 2 == 0 ? 300 : 3));  // over kMaxInterfaces half the rounds
      f.extended = rng() % 2 == 0;
      f.id = static_cast<std::uint32_t>(rng() % (f.extended ? 0x1FFFFFFF : 0x800));
      if (!f.extended && f.id == 0x300) f.id = 0x301;
      f.dlc = static_cast<std::uint8_t>(rng() % 9);
      f.remote = rng() % 20 == 0;
      f.error = rng() % 40 == 0;
      if (i == n - 10) {  // 0x300 late, far beyond the limit: listed all the same
        f = CanFrame{};
        f.id = 0x300;
        f.dlc = 4;
      }
      f.timestamp_ns = 1'763'800'000'000'000'000ULL + i * 1'000'000ULL;
      events.push_back(e);
    }
    BusStats one;
    for (const Event& e : events) add(one, e);

    // the rule written out: the first kMaxIds ids (and 0x300) and kMaxInterfaces interfaces of data and remote
    // frames in file order are listed; the others' frames are counted apart
    std::vector<BusStats::IdKey> ids;
    std::vector<std::string> interfaces;
    BusStats::Unlisted other_ids, other_interfaces;
    for (const Event& e : events) {
      if (e.corrupt || e.frame.error) continue;
      const BusStats::IdKey key{e.frame.extended, e.frame.id};
      if (std::find(ids.begin(), ids.end(), key) == ids.end() &&
          (ids.size() < BusStats::kMaxIds || key == BusStats::IdKey{false, 0x300}))
        ids.push_back(key);
      if (std::find(ids.begin(), ids.end(), key) == ids.end()) {
        ++other_ids.frames;
        other_ids.remote += e.frame.remote ? 1 : 0;
        other_ids.decode_errors += saul::decode_bus_frame(e.frame) ? 0 : 1;
      }
      if (std::find(interfaces.begin(), interfaces.end(), e.interface) == interfaces.end() &&
          interfaces.size() < BusStats::kMaxInterfaces)
        interfaces.push_back(e.interface);
      if (std::find(interfaces.begin(), interfaces.end(), e.interface) == interfaces.end()) ++other_interfaces.frames;
    }
    REQUIRE(one.ids().size() == ids.size());
    for (const auto& key : ids) REQUIRE(one.ids().count(key) == 1);
    CHECK(ids.size() == BusStats::kMaxIds + 1);  // the noise really went beyond the limit, and 0x300 came late
    CHECK(one.unlisted_ids().frames == other_ids.frames);
    CHECK(one.unlisted_ids().remote == other_ids.remote);
    CHECK(one.unlisted_ids().decode_errors == other_ids.decode_errors);
    REQUIRE(one.interfaces().size() == interfaces.size());
    CHECK(one.unlisted_interfaces().frames == other_interfaces.frames);
    CHECK((other_interfaces.frames > 0) == (round % 2 == 0));
    const auto j = one.json("f");
    CHECK(j["ids_not_listed"]["frames"] == other_ids.frames);
    CHECK(j.contains("interfaces_not_listed") == (round % 2 == 0));
    CHECK(one.text("f").find("of ids beyond the first 4096 (not listed)") != std::string::npos);

    // blocks (which list all theirs) appended in order give the same figures
    std::vector<std::size_t> cuts{0, events.size()};
    for (int c = 1 + static_cast<int>(rng() % 8); c-- > 0;) cuts.push_back(rng() % events.size());
    std::sort(cuts.begin(), cuts.end());
    const BusStats appended = appended_in_blocks(events, cuts, BusStatsOptions{}, rng);
    REQUIRE(appended.json("f").dump() == j.dump());
    REQUIRE(appended.text("f") == one.text("f"));
  }
}

// Blocks keep their timed frames for append(), which works the busiest windows out in file order. Times here jump
// back by several windows, before the first frame too, and forward, at block starts and inside blocks, and blocks
// are appended to a block that then counts frames of its own.
TEST_CASE("busiest windows worked out from blocks equal one pass when times go back") {
  std::mt19937_64 rng(777);
  for (int round = 0; round < 300; ++round) {
    INFO("round " << round);
    BusStatsOptions options;
    options.window_ns = 1 + rng() % 5;
    std::vector<Event> events;
    std::uint64_t t = 1000 + rng() % 100;
    const std::uint64_t first_ns = t;
    for (std::size_t i = 0, n = 2 + rng() % 80; i < n; ++i) {
      Event e;
      e.interface = rng() % 4 == 0 ? "can1" : "can0";
      if (i == 0) e.interface = "can0";
      e.frame.id = 0x300;
      e.frame.dlc = static_cast<std::uint8_t>(rng() % 9);
      if (i > 0) {
        switch (rng() % 4) {
          case 0:  // back, maybe before the first frame
            t -= std::min<std::uint64_t>(t, rng() % (4 * options.window_ns + 60));
            break;
          case 1: t += rng() % (6 * options.window_ns); break;
          default: t += rng() % 2; break;
        }
      }
      e.frame.timestamp_ns = t;
      events.push_back(e);
    }
    events[0].frame.timestamp_ns = first_ns;
    BusStats one(options);
    for (const Event& e : events) add(one, e);
    std::vector<std::size_t> cuts{0};
    while (cuts.back() < events.size()) cuts.push_back(std::min(events.size(), cuts.back() + 1 + rng() % 6));
    const BusStats blocks = appended_in_blocks(events, cuts, options, rng);
    for (const char* name : {"can0", "can1"}) {
      if (!one.interfaces().count(name)) continue;
      INFO(name);
      const BusStats::Load& a = one.interfaces().at(name);
      const BusStats::Load& b = blocks.interfaces().at(name);
      REQUIRE(b.peak_bits == a.peak_bits);
      REQUIRE(b.peak_index == a.peak_index);
      REQUIRE(b.window_index == a.window_index);
      REQUIRE(b.window_bits == a.window_bits);
      REQUIRE(b.first_ns == a.first_ns);
      REQUIRE(b.last_ns == a.last_ns);
    }
    REQUIRE(blocks.json("f").dump() == one.json("f").dump());
  }
}

TEST_CASE("cadences of consecutive parts appended equal one cadence over the whole") {
  std::mt19937_64 rng(7);
  for (int round = 0; round < 2000; ++round) {
    std::vector<std::optional<std::uint64_t>> times;
    std::uint64_t t = 1000;
    for (std::size_t i = rng() % 20; i-- > 0;) {
      t += rng() % 3 * 500;  // equal gaps are common: of equal longest gaps the first must stay
      times.push_back(rng() % 8 == 0 ? std::nullopt : std::optional<std::uint64_t>(rng() % 10 == 0 ? t - 700 : t));
    }
    const std::uint64_t timeout = rng() % 2 * 600;
    Cadence one;
    for (auto ns : times) one.add(ns, timeout);
    const std::size_t cut = times.empty() ? 0 : rng() % (times.size() + 1);
    Cadence first, second;
    for (std::size_t i = 0; i < times.size(); ++i) (i < cut ? first : second).add(times[i], timeout);
    first.append(second, timeout);
    INFO("round " << round << " cut " << cut);
    REQUIRE(first.count == one.count);
    REQUIRE(first.first_ns == one.first_ns);
    REQUIRE(first.last_ns == one.last_ns);
    REQUIRE(first.gaps == one.gaps);
    REQUIRE(first.max_gap_ns == one.max_gap_ns);
    REQUIRE(first.max_gap_start_ns == one.max_gap_start_ns);
    REQUIRE(first.gaps_over_timeout == one.gaps_over_timeout);
    REQUIRE(first.gap_sum_ns() == one.gap_sum_ns());
    REQUIRE(first.back_sum_ns == one.back_sum_ns);
    REQUIRE(first.gap_square_sum == one.gap_square_sum);
  }
}

TEST_CASE("a cadence's gap sum, mean and jitter equal the gaps worked out one by one, steps back included") {
  // Cadence sums only the steps back and gets the gaps' sum from its first and last times: checked here against
  // every gap taken as max(0, t[i] - t[i-1]) in turn, on times that go back and forth, events without a time, and
  // times at the ends of the 64-bit range.
  std::mt19937_64 rng(15);
  for (int round = 0; round < 3000; ++round) {
    Cadence c;
    std::optional<std::uint64_t> previous;
    Cadence::Sum sum = 0;
    std::uint64_t n = 0;
    std::vector<std::uint64_t> gaps;
    const bool extreme = round % 10 == 0;
    std::uint64_t t = extreme ? ~std::uint64_t{0} - 5000 : 1'000'000;
    for (std::size_t i = rng() % 30; i-- > 0;) {
      std::optional<std::uint64_t> at;
      switch (rng() % 8) {
        case 0: break;  // no time
        case 1: at = t - rng() % 3000; break;  // back
        case 2: at = extreme ? rng() % 3 : t; break;  // far back (from near 2^64 to near 0), or the same time
        default: t = extreme ? t + rng() % 2 : t + rng() % 1000; at = t;
      }
      c.add(at);
      if (!at) continue;
      if (previous) {
        const std::uint64_t gap = *at >= *previous ? *at - *previous : 0;
        sum += gap;
        gaps.push_back(gap);
        ++n;
      }
      previous = at;
    }
    INFO("round " << round);
    REQUIRE(c.gaps == n);
    REQUIRE(c.gap_sum_ns() == sum);
    if (n == 0) continue;
    CHECK(c.mean_gap_ns() == static_cast<double>(sum) / static_cast<double>(n));
    if (n < 2 || extreme) continue;  // (extreme squares take jitter's long double branch: not exact)
    long double mean = 0, spread = 0;
    for (auto g : gaps) mean += static_cast<long double>(g);
    mean /= static_cast<long double>(n);
    for (auto g : gaps) spread += (static_cast<long double>(g) - mean) * (static_cast<long double>(g) - mean);
    CHECK(c.jitter_ns() == Approx(static_cast<double>(std::sqrt(spread / static_cast<long double>(n)))).margin(1e-6));
  }
}

TEST_CASE("stats of a candump file on both cores equal one thread: figures, corrupt lines and their line numbers") {
  std::mt19937_64 rng(99);
  std::string log;
  std::uint64_t us = 1'763'800'000'000'000ULL;
  for (int i = 0; i < 6000; ++i) {
    us += 100 + rng() % 3 * 400 + (rng() % 500 == 0 ? 600'000 : 0);
    const auto sec = us / 1'000'000, usec = us % 1'000'000;
    switch (rng() % 50) {
      case 0: log += "(garbage line\n"; break;
      case 1: log += fmt::format("({}.{:06}) can0 30#ZZ\n", sec, usec); break;
      case 2: log += "# a comment\n"; break;
      case 3: log += fmt::format("({}.{:06}) can1 20000080#0000000000000040\n", sec, usec); break;  // error frame
      // The lines stats takes by their text (its line memo) next to those it parses: a remote frame, a frame that
      // does not decode (0x300 with 3 bytes), a time of another shape, and texts of up to 42 bytes after the time
      // that differ only in their last byte (the memo's key is 40).
      case 4: log += fmt::format("({}.{:06}) can0 300#R\n", sec, usec); break;
      case 5: log += fmt::format("({}.{:06}) can0 300#0000{:02X}\n", sec, usec, rng() % 2); break;
      case 6: log += fmt::format("({}.{:09}) can0 300#00006400\n", sec, usec * 1000 + rng() % 1000); break;
      case 7:
      case 8:
        // 00 and AA differ in their stuff bits
        log += fmt::format("({}.{:06}) {} 00000944#00000000000000{}\n", sec, usec,
                           std::array{"robot_bus0", "robot_bus0_a_b", "robot_bus0_a_b_c"}[rng() % 3],
                           rng() % 2 ? "00" : "AA");
        break;
      default:
        log += fmt::format("({}.{:06}) can{} {}#{:04X}{:04X}\n", sec, usec, rng() % 7 == 0 ? 1 : 0,
                           rng() % 2 ? "300" : "00000944", rng() % 3 == 0 ? rng() % 0x10000 : 0, rng() % 4);
    }
  }
  // Once with a comment first, once with a first line of the usual shape.
  const bool usual_first = GENERATE(false, true);
  INFO("a usual first line: " << usual_first);
  log = (usual_first ? "(1763799999.999999) can0 00000944#0000000000000000\n" : "# from the bench\n") + log;
  TempFile file(log);
  struct Run {
    std::string text;
    std::vector<std::uint64_t> corrupt_lines;
    std::uint64_t records = 0;
    std::uint64_t last_bytes = 0;
  };
  auto run = [&](bool ahead, std::uint64_t block) {
    BusStats stats(BusStatsOptions{250'000, 7 * kMs});  // not the defaults: the blocks must count with these
    Run r;
    add_candump_path(
        stats, file.path, ahead,
        [&](const saul::host::CaptureError& e) { r.corrupt_lines.push_back(e.position); },
        [&](std::uint64_t records, std::uint64_t bytes) {
          r.records = records;
          r.last_bytes = bytes;
        },
        {}, block);
    r.text = stats.text("f") + stats.json("f").dump();
    return r;
  };
  const Run one = run(false, 0);
  REQUIRE(one.corrupt_lines.size() > 100);
  for (std::uint64_t block : {std::uint64_t{1}, std::uint64_t{777}, std::uint64_t{4096}, std::uint64_t{1} << 30}) {
    INFO("blocks of " << block << " bytes");
    const Run blocks = run(true, block);
    CHECK(blocks.text == one.text);
    CHECK(blocks.corrupt_lines == one.corrupt_lines);
    CHECK(blocks.records == one.records);
    CHECK(blocks.last_bytes == log.size());
  }
}

// stats reads the usual line by its text: a head ("IFACE ID") looked up in a table of 256, the data's hex digits
// compared with the head's last data, else looked up in a table of 16384 contents (unless the head's data seldom
// repeat), the digits read a word at a time. Random lines near every edge of that, long enough to
// evict both tables many times over, must count exactly as the parsed lines of the one-thread path do.
TEST_CASE("stats' line tables on random lines near their edges equal one thread's parse") {
  std::mt19937_64 rng(2026);
  auto pick = [&](std::string_view chars) { return chars[rng() % chars.size()]; };
  auto hex_digits = [&](std::size_t n, bool lower) {
    std::string d;
    for (std::size_t k = 0; k < n; ++k) d += pick(lower ? "0123456789abcdef" : "0123456789ABCDEF");
    return d;
  };
  // 600 heads (more than the table's 256): interfaces of 1 to 24 bytes, one with '#' in it, ids of 3 and 8 digits in
  // either case, ids too large for their format, ids of 2, 4 and 9 digits
  std::vector<std::string> heads;
  for (int h = 0; h < 600; ++h) {
    std::string iface;
    switch (h % 8) {
      case 0: iface = "can0"; break;
      case 1: iface = "ca#0"; break;
      default:
        for (std::size_t k = 1 + rng() % 24; k-- > 0;) iface += pick("abcxyz019_-.");
    }
    std::string id;
    switch (rng() % 12) {
      case 0: id = "8" + hex_digits(2, false); break;            // > 0x7FF: not a standard id
      case 1: id = "3" + hex_digits(7, false); break;            // > 0x1FFFFFFF
      case 2: id = hex_digits(std::array{2, 4, 9}[rng() % 3], false); break;
      case 3: id = "1" + hex_digits(7, true); break;
      default: id = rng() % 2 ? std::string(1, pick("01234567")) + hex_digits(2, rng() % 4 == 0)
                              : "0000" + hex_digits(4, false);  // saul and vesc ids, and unknown ones
    }
    heads.push_back(iface + " " + id);
  }
  // heads of more than the 24 bytes the table holds, alike in those 24
  heads[5] = "bench_bus_left_wheel_0 00000944";
  heads[6] = "bench_bus_left_wheel_0 00000938";
  // data: mostly a few values per head (seen again), some always new, odd lengths, non-hex bytes, 9 bytes
  auto data = [&]() -> std::string {
    switch (rng() % 16) {
      case 0: return hex_digits(rng() % 19, rng() % 2);  // any length up to 18 digits
      case 1: {
        std::string d = hex_digits(2 * (1 + rng() % 8), false);
        using namespace std::string_view_literals;
        d[rng() % d.size()] = pick("Gg:@`/ R\x7f\xc3*\0"sv);  // a byte just outside the hex digits' ranges, or NUL
        return d;
      }
      case 2: return "R";
      case 3: return hex_digits(16, rng() % 2);  // always new
      default: {
        const std::size_t bytes = std::array{0, 2, 3, 4, 8, 8, 8}[rng() % 7];
        std::string d;
        for (std::size_t k = 0; k < bytes; ++k) d += std::array{"00", "FF", "AA", "55", "0F", "ff", "a5"}[rng() % 7];
        return d;
      }
    }
  };
  std::string log;
  std::uint64_t us = 1'763'800'000'000'000ULL;
  for (int i = 0; i < 60000; ++i) {
    us += rng() % 700;
    const auto sec = us / 1'000'000, usec = us % 1'000'000;
    const std::string& head = rng() % 4 ? heads[rng() % 40] : heads[rng() % heads.size()];  // some heads often
    std::string line = fmt::format("({}.{:06}) {}#{}", sec, usec, head, data());
    if (rng() % 8 == 0) {
      // a counter (VESC STATUS_5's tachometer): data that never repeat, so its head stops using the contents' table
      // for a while; in the last sixth the counter runs again over values seen before
      const std::uint64_t count = i < 50000 ? static_cast<std::uint64_t>(i) : static_cast<std::uint64_t>(i) % 9000;
      line = fmt::format("({}.{:06}) can0 00001B44#{:016X}", sec, usec, count * 0x10001);
    }
    switch (rng() % 40) {
      case 0: line += "\r"; break;
      case 1: line = fmt::format("({}.{:06}) {}  {}#11", sec, usec, head.substr(0, head.find(' ')), "300"); break;
      case 2: line = fmt::format("({}.{:09}) {}#{}", sec, usec * 1000, head, data()); break;
      case 3: line += "#"; break;
      case 4: line = fmt::format("({}.{:06}) {}", sec, usec, head) + std::string(1, '\0') + "#" + data(); break;
      case 5: line += std::string(2, '\0'); break;  // the same text as far as the table's zeros go
      default: break;
    }
    if (log.size() < 8192) std::replace(line.begin(), line.end(), '\0', '*');  // the first 4 KiB say it is text
    log += line;
    log += '\n';
  }
  log += "(1763800099.000001) can0 300#0011";  // the last line without its newline
  TempFile file(log);
  auto run = [&](bool ahead, std::uint64_t block) {
    BusStats stats(BusStatsOptions{500'000, 3 * kMs});
    std::vector<std::uint64_t> corrupt;
    add_candump_path(
        stats, file.path, ahead,
        [&](const saul::host::CaptureError& e) { corrupt.push_back(e.position); }, {}, {}, block);
    return std::pair{stats.text("f") + stats.json("f").dump(), corrupt};
  };
  const auto one = run(false, 0);
  REQUIRE(one.second.size() > 1000);
  for (std::uint64_t block : {std::uint64_t{333}, std::uint64_t{1} << 16, std::uint64_t{1} << 30}) {
    INFO("blocks of " << block << " bytes");
    const auto blocks = run(true, block);
    CHECK(blocks.first == one.first);
    CHECK(blocks.second == one.second);
  }
}

// stats counts a line that repeats its id's last data from its head's last content (no table lookup): times that go
// back, below the first of the block and of the file, and repeats across every block edge must give what one pass
// over the parsed frames gives, and the first and last times written out by hand.
TEST_CASE("stats of repeated lines whose times go back equal one pass over the parsed frames") {
  std::mt19937_64 rng(4242);
  std::string log;
  std::uint64_t us = 1'763'800'100'000'000ULL;
  std::uint64_t first_us = us, last_us = us;
  for (int i = 0; i < 20000; ++i) {
    if (rng() % 40 == 0)
      us -= 300'000 + rng() % 50'000'000;  // back, now and then to before every time so far
    else
      us += 50 + rng() % 900;
    first_us = std::min(first_us, us);
    last_us = std::max(last_us, us);
    const auto sec = us / 1'000'000, usec = us % 1'000'000;
    switch (rng() % 5) {
      case 0: log += fmt::format("({}.{:06}) can0 300#0000{:02X}00\n", sec, usec, rng() % 30 == 0 ? 0x64 : 0); break;
      case 1: log += fmt::format("({}.{:06}) can1 300#00000000\n", sec, usec); break;  // the same id elsewhere
      case 2: log += fmt::format("({}.{:06}) can0 300#0000\n", sec, usec); break;      // does not decode, repeated
      default: log += fmt::format("({}.{:06}) can0 00000944#00000000000000{:02X}\n", sec, usec, rng() % 50 == 0);
    }
  }
  // the earliest and the latest time of all on lines that repeat the line before them
  for (const std::uint64_t at : {us, first_us - 1'000'000, last_us + 1'000'000}) {
    log += fmt::format("({}.{:06}) can1 300#00000000\n", at / 1'000'000, at % 1'000'000);
    first_us = std::min(first_us, at);
    last_us = std::max(last_us, at);
  }
  TempFile file(log);
  auto run = [&](bool ahead, std::uint64_t block) {
    BusStats stats(BusStatsOptions{500'000, 20 * kMs});
    add_candump_path(stats, file.path, ahead, {}, {}, {}, block);
    CHECK(stats.first_ns() == first_us * 1000);
    CHECK(stats.last_ns() == last_us * 1000);
    return stats.text("f") + stats.json("f").dump();
  };
  const std::string one = run(false, 0);
  for (std::uint64_t block : {std::uint64_t{500}, std::uint64_t{1} << 14, std::uint64_t{1} << 30}) {
    INFO("blocks of " << block << " bytes");
    CHECK(run(true, block) == one);
  }
}
