// Serial byte captures: our serial log (round trip, exact bytes, errors with positions), format detection of
// every kind of capture, and the bundled inter-board and Pride captures (captures/make_uart_vcd.py tells their
// story; the counts below are taken from it by hand).
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
#include "saulproto/host/report/serial_decode.hpp"

using namespace saul::host;

namespace {

constexpr std::uint64_t kSec = 1'000'000'000ULL;

SerialChunk chunk(std::uint64_t ns, std::string link, SerialProtocol p, std::vector<std::uint8_t> bytes,
                  std::uint8_t errors = 0) {
  SerialChunk c;
  c.timestamp_ns = ns;
  c.link = std::move(link);
  c.protocol = p;
  c.bytes = std::move(bytes);
  c.errors = errors;
  return c;
}

std::vector<SerialChunk> read_chunks(SerialCaptureReader& reader, std::vector<CaptureError>* errors = nullptr) {
  std::vector<SerialChunk> out;
  for (;;) {
    const auto st = reader.next();
    if (st == SerialCaptureReader::Status::end) break;
    if (st == SerialCaptureReader::Status::corrupt) {
      if (errors) errors->push_back(reader.error());
      continue;
    }
    out.push_back(reader.chunk());
  }
  return out;
}

std::optional<CaptureFormat> detect(const std::string& s) {
  return detect_capture_format(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()));
}

std::filesystem::path scratch_dir() {
  const auto dir = std::filesystem::temp_directory_path() / ("saul_test_serial_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace

TEST_CASE("serial log: every chunk writes and reads back exactly") {
  std::vector<std::uint8_t> long_run(150);
  for (std::size_t i = 0; i < long_run.size(); ++i) long_run[i] = static_cast<std::uint8_t>(i * 7);
  const std::uint64_t t0 = 1763800000 * kSec;
  const std::vector<SerialChunk> chunks = {
      chunk(t0 + 100'000, "serial:/dev/ttyUSB0@460800:8N1", SerialProtocol::interboard,
            {0xAA, 0x05, 0x01, 0xF4, 0x01, 0x06, 0xFF, 0x01, 0x0F}),
      chunk(t0 + 200'000, "serial:/dev/ttyUSB1@38400:8E1", SerialProtocol::pride, {0x4A, 0x01, 0x02}, uart_error::kParity),
      chunk(t0 + 300'000, "serial:/dev/ttyUSB1@38400:8E1", SerialProtocol::pride, {}, uart_error::kBreak),
      chunk(t0 + 400'000, "crsf0", SerialProtocol::crsf, {0xC8, 0x00}, uart_error::kFraming | uart_error::kParity),
      chunk(t0 + 500'000, "raw-tap", SerialProtocol::raw, {0x00, 0xFF}),
  };
  std::stringstream buffer;
  SerialLogWriter writer(buffer);
  for (const auto& c : chunks) writer.write(c);
  // 150 bytes become lines of 64, 64 and 22 bytes with the same time.
  writer.write(chunk(t0 + 600'000, "raw-tap", SerialProtocol::raw, long_run, uart_error::kFraming));
  writer.close();
  CHECK_THROWS_AS(writer.write(chunks[0]), std::runtime_error);
  const std::string text = buffer.str();
  CHECK(text.starts_with(
      "(1763800000.000100) serial:/dev/ttyUSB0@460800:8N1 interboard AA0501F40106FF010F\n"
      "(1763800000.000200) serial:/dev/ttyUSB1@38400:8E1 pride 4A0102 !parity\n"
      "(1763800000.000300) serial:/dev/ttyUSB1@38400:8E1 pride - !break\n"
      "(1763800000.000400) crsf0 crsf C800 !parity !framing\n"));
  CHECK(detect(text) == CaptureFormat::serial);

  std::istringstream in(text);
  auto reader = make_serial_capture_reader(in, CaptureFormat::serial);
  std::vector<CaptureError> errors;
  const auto back = read_chunks(*reader, &errors);
  CHECK(errors.empty());
  REQUIRE(back.size() == chunks.size() + 3);
  for (std::size_t i = 0; i < chunks.size(); ++i) CHECK(back[i] == chunks[i]);
  std::vector<std::uint8_t> joined;
  for (std::size_t i = chunks.size(); i < back.size(); ++i) {
    CHECK(back[i].timestamp_ns == t0 + 600'000);
    CHECK(back[i].errors == (i + 1 == back.size() ? uart_error::kFraming : 0));  // the mark goes with the last line
    joined.insert(joined.end(), back[i].bytes.begin(), back[i].bytes.end());
  }
  CHECK(back[chunks.size()].bytes.size() == 64);
  CHECK(joined == long_run);
}

TEST_CASE("serial log: links with white space and chunks without bytes or marks") {
  std::ostringstream out;
  SerialLogWriter writer(out);
  CHECK_THROWS_AS(writer.write(chunk(0, "my port", SerialProtocol::raw, {1})), std::invalid_argument);
  CHECK_THROWS_AS(writer.write(chunk(0, "", SerialProtocol::raw, {1})), std::invalid_argument);
  writer.write(chunk(0, "x", SerialProtocol::raw, {}));  // nothing to say: no line
  SerialChunk untimed = chunk(0, "x", SerialProtocol::raw, {0x41});
  untimed.timestamp_ns.reset();
  writer.write(untimed);
  CHECK(out.str() == "(0000000000.000000) x raw 41\n");
}

TEST_CASE("serial log: corrupt lines are reported with line and column, the rest still reads") {
  const std::string text =
      "# a comment\n"
      "(1.000000) serial:/dev/ttyUSB0@460800:8N1 interboard AA05\n"
      "(2.000000) serial:/dev/ttyUSB0@460800:8N1 modbus AA05\n"
      "(3.000000) serial:/dev/ttyUSB0@460800:8N1 interboard AAG5\n"
      "(4.000000) serial:/dev/ttyUSB0@460800:8N1 interboard AA0\n"
      "(5.000000 serial:/dev/ttyUSB0@460800:8N1 interboard AA\n"
      "(6.000000) serial:/dev/ttyUSB0@460800:8N1 interboard\n"
      "(7.000000) serial:/dev/ttyUSB0@460800:8N1 interboard AA !glitch\n"
      "(8.000000) serial:/dev/ttyUSB0@460800:8N1 interboard -\n"
      "(9.5) serial:/dev/ttyUSB0@460800:8N1 interboard 01\r\n";
  std::istringstream in(text);
  SerialLogReader reader(in);
  std::vector<CaptureError> errors;
  const auto chunks = read_chunks(reader, &errors);
  REQUIRE(chunks.size() == 2);
  CHECK(chunks[0].bytes == std::vector<std::uint8_t>{0xAA, 0x05});
  CHECK(chunks[1].timestamp_ns == 9 * kSec + 500'000'000);
  REQUIRE(errors.size() == 7);
  CHECK(format_capture_error("u.serial", errors[0]) == "u.serial:3:43: unknown protocol: use interboard, crsf, pride or raw (line skipped)");
  CHECK(format_capture_error("u.serial", errors[1]) == "u.serial:4:56: bytes are not hexadecimal (line skipped)");
  CHECK(errors[2].message == "bytes have an odd number of hex digits");
  CHECK(errors[3].message == "timestamp has no closing ')'");
  CHECK(errors[4].position == 7);
  CHECK(errors[4].message == "missing bytes (hex, or '-' for none)");
  CHECK(errors[5].message == "unexpected text after the bytes (only !parity, !framing, !break)");
  CHECK(errors[6].message == "a line with no bytes must carry an error mark");
}

TEST_CASE("format detection tells CAN logs, serial logs and logic-analyser exports apart") {
  CHECK(detect("(1700000000.000000) can0 123#11\n") == CaptureFormat::candump);
  CHECK(detect("(1700000000.000000) serial:/dev/ttyUSB0@460800:8N1 interboard AA\n") == CaptureFormat::serial);
  CHECK(detect("# saulctl serial capture\n(1.5) uart0 raw -  !break\n") == CaptureFormat::serial);
  CHECK(detect("uart-1: AA\nuart-1: 05\n") == CaptureFormat::sigrok);
  CHECK(detect("1023-1195 uart-1: AA\n") == CaptureFormat::sigrok);
  CHECK(detect("1023-1195 UART: RX: AA\n") == CaptureFormat::sigrok);  // PulseView's annotation export
  CHECK(detect("{\"traceEvents\": [\n{\"ph\": \"B\", \"ts\": 226.000000}\n") == CaptureFormat::sigrok_json);
  CHECK(detect("\"Sample\",\"Time\",\"Decoder\",\"Ann Row\",\"Ann Class\",\"Value\"\r\n") == CaptureFormat::pulseview_csv);
  CHECK(detect("Sample,Time,Decoder,Ann Row,Ann Class,Value\r\n") == CaptureFormat::pulseview_csv);
  // can-utils' drop marker is not an annotation; the candump line after it decides
  CHECK(detect("DROPCOUNT: dropped 3 CAN frame(s)\n(1.000000) can0 123#\n") == CaptureFormat::candump);
  CHECK(capture_format_from_extension("run.serial") == CaptureFormat::serial);
  CHECK(capture_format_from_name("sigrok-json") == CaptureFormat::sigrok_json);
  CHECK(to_string(CaptureFormat::pulseview_csv) == "pulseview-csv");
  CHECK(holds_serial_bytes(CaptureFormat::sigrok));
  CHECK_FALSE(holds_serial_bytes(CaptureFormat::asc));
}

TEST_CASE("open_capture opens either kind; the CAN-only and serial-only openers refuse the other") {
  const std::string root = SAUL_SOURCE_DIR;
  auto can = open_capture(root + "/captures/robot_bus.log");
  CHECK(can.frames);
  CHECK_FALSE(can.chunks);
  auto serial = open_capture(root + "/captures/interboard_uart.serial");
  REQUIRE(serial.chunks);
  CHECK(serial.format == CaptureFormat::serial);
  CHECK(read_chunks(*serial.chunks).size() == 8);
  CHECK_THROWS_WITH(open_capture_reader(root + "/captures/pride_uart.serial"), Catch::Contains("serial bytes"));
  CHECK_THROWS_WITH(open_serial_capture_reader(root + "/captures/robot_bus.log"), Catch::Contains("CAN frames"));
  const auto dir = scratch_dir();
  CHECK_THROWS_AS(open_capture_writer((dir / "x.serial").string()), CaptureOpenError);
  {
    RotatingSerialWriter w((dir / "x.serial").string());
    w.write(chunk(kSec, "tap", SerialProtocol::pride, {0xFE, 0x54}));
    w.close();
  }
  auto back = open_serial_capture_reader((dir / "x.serial").string());
  CHECK(read_chunks(*back) == std::vector<SerialChunk>{chunk(kSec, "tap", SerialProtocol::pride, {0xFE, 0x54})});
  std::filesystem::remove_all(dir);
}

TEST_CASE("the bundled inter-board capture decodes as make_uart_vcd.py wrote it") {
  auto reader = open_serial_capture_reader(std::string(SAUL_SOURCE_DIR) + "/captures/interboard_uart.serial");
  SerialCaptureDecoder decoder;
  std::vector<std::string> lines;
  const SerialCaptureDecoder::Callback on = [&](const SerialChunk& c, SerialProtocol p, const SerialMessage& m) {
    CHECK(p == SerialProtocol::interboard);
    lines.push_back(std::to_string(*c.timestamp_ns / 100'000) + " " + describe(m));
  };
  for (const auto& c : read_chunks(*reader)) decoder.add(c, on);
  decoder.finish(on);
  // rc_cmd(500, -250, armed), state(-1234, 300, 1), noise, sensor(1234, -56, 1), fault 5, the fault with a bad
  // CRC (rejected), led_cmd(2, 255, 128, 0), buzzer(3, 500); frames 1 ms apart from 0.1 ms (units of 0.1 ms below)
  CHECK(lines == std::vector<std::string>{"1 rc_cmd throttle=500 steer=-250 flags=1",
                                          "11 state pitch=-12.34\u00B0 pid_out=300 error_state=1",
                                          "31 sensor tof_mm=1234 baro_delta_pa=-56 nfc_present=1",
                                          "41 fault flags=5",
                                          "61 led_cmd pattern=2 r=255 g=128 b=0",
                                          "71 buzzer tone_id=3 duration_ms=500"});
  const auto links = decoder.links();
  REQUIRE(links.size() == 1);
  CHECK_FALSE(links[0].guessed);
  // 54 bytes: 6 good frames (9 + 9 + 9 + 5 + 8 + 7 = 47 bytes); the bad frame's 5 bytes and the 2 noise bytes
  // are skipped
  CHECK(links[0].counters.bytes == 54);
  CHECK(links[0].counters.frames == 6);
  CHECK(links[0].counters.crc_errors == 1);
  CHECK(links[0].counters.bytes_skipped == 7);
  CHECK(links[0].counters.errors(SerialProtocol::interboard) == 1);
}

TEST_CASE("the protocol of an unnamed byte stream is guessed from its frames") {
  auto bytes_of = [](const std::string& name) {
    auto reader = open_serial_capture_reader(std::string(SAUL_SOURCE_DIR) + "/captures/" + name);
    std::vector<std::uint8_t> all;
    for (const auto& c : read_chunks(*reader)) all.insert(all.end(), c.bytes.begin(), c.bytes.end());
    return all;
  };
  CHECK(guess_serial_protocol(bytes_of("interboard_uart.serial")) == SerialProtocol::interboard);
  CHECK(guess_serial_protocol(bytes_of("pride_uart.serial")) == SerialProtocol::pride);
  const std::vector<std::uint8_t> noise = {0x13, 0x37, 0x00, 0xFF, 0x42};
  CHECK_FALSE(guess_serial_protocol(noise));
  // CRSF: two RC frames (made with the core encoder; its bytes are checked against the spec in unit tests)
  std::vector<std::uint8_t> crsf(52);
  saul::crsf::RcChannels rc;
  rc.ticks.fill(992);
  const auto n = saul::crsf::encode(rc, std::span(crsf).first(26));
  REQUIRE(n);
  REQUIRE(saul::crsf::encode(rc, std::span(crsf).subspan(26)));
  CHECK(guess_serial_protocol(crsf) == SerialProtocol::crsf);
}

TEST_CASE("a link that names no protocol is decoded after its protocol is guessed, nothing lost") {
  SerialCaptureDecoder decoder(std::nullopt, 16);  // guess after 16 bytes
  std::vector<std::string> seen;
  const SerialCaptureDecoder::Callback on = [&](const SerialChunk&, SerialProtocol p, const SerialMessage& m) {
    seen.push_back(std::string(to_string(p)) + " " + name_of(m));
  };
  const std::vector<std::uint8_t> vcu = {0xFE, 0x54, 0x07, 0x32, 0x00, 0x74};
  const std::vector<std::uint8_t> status = {0x4A, 0x01, 0x02, 0x64, 0x00, 0x4E};
  for (int i = 0; i < 4; ++i) {
    decoder.add(chunk(0, "uart-1", SerialProtocol::raw, vcu), on);
    decoder.add(chunk(0, "uart-1", SerialProtocol::raw, status), on);
  }
  decoder.finish(on);
  CHECK(seen.size() == 8);
  CHECK(seen.front() == "pride vcu_command");
  REQUIRE(decoder.links().size() == 1);
  CHECK(decoder.links()[0].guessed);
}
