// saulctl stats' arithmetic: CAN frame lengths on the wire, and the per-id, load and silence statistics of a
// small hand-made capture whose numbers are worked out by hand in the comments.
#include <catch2/catch.hpp>

#include <initializer_list>
#include <sstream>

#include "saulproto/host/report/bus_stats.hpp"
#include "saulproto/host/capture/candump.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

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
  //   exact:        this frame's bits and CRC-15 (0x18D8) need 4 stuff bits -> 83 bits (from an independent
  //                 bit-level model in Python, not from this code)
  const CanFrame velocity = frame(0x300, false, {0xE8, 0x03, 0x0C, 0xFE});
  CHECK(can_frame_bits(velocity, StuffBits::none) == 79);
  CHECK(can_frame_bits(velocity, StuffBits::worst_case) == 95);
  CHECK(can_crc15(velocity) == 0x18D8);
  CHECK(can_frame_bits(velocity, StuffBits::exact) == 83);
  // id 0, no data: all 34 stuffed bits are 0 (the CRC of zeros is 0), so one stuff bit after each 5 zeros:
  // 34 / 5 -> 6 stuff bits, 47 + 6 = 53; the worst case says floor(33 / 4) = 8 -> 55.
  const CanFrame zero = frame(0x000, false, {});
  CHECK(can_crc15(zero) == 0);
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
  CHECK(can_crc15(status) == 0x63C6);
  CHECK(can_frame_bits(status, StuffBits::exact) == 143);
  const CanFrame zeros29 = frame(0x1FFFFFFF, true, {0, 0, 0, 0, 0, 0, 0, 0});
  CHECK(can_crc15(zeros29) == 0x7DA3);
  CHECK(can_frame_bits(zeros29, StuffBits::exact) == 151);
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
  CHECK(velocity.cadence.mean_gap_ns == Approx(1e9 / 3));  // (50 + 600 + 350) / 3 ms
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
  while (reader->next() == CaptureReader::Status::frame) stats.add(reader->frame(), reader->interface());
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
