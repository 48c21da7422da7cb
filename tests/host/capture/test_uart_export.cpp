// Logic-analyser exports of sigrok's UART decoder. The sigrok-cli lines are real output (sigrok-cli 0.7.2,
// libsigrokdecode 0.5.3, on the VCDs captures/make_uart_vcd.py writes; captures/make_sigrok_fixtures.sh); the
// PulseView lines follow PulseView's source (decodetrace.cpp export_annotations with its default "%s %d: %r: %1",
// tabular_decoder view.cpp save_data_as_csv and model.cpp's columns), PulseView itself not being at hand.
#include <catch2/catch.hpp>

#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/serial_decode.hpp"
#include "saulproto/host/capture/uart_export.hpp"

using namespace saul::host;

namespace {

std::vector<SerialChunk> read_text(const std::string& text, CaptureFormat format, SerialReadOptions options = {},
                                   std::vector<CaptureError>* errors = nullptr) {
  std::istringstream in(text);
  auto reader = make_serial_capture_reader(in, format, options);
  std::vector<SerialChunk> out;
  for (;;) {
    const auto st = reader->next();
    if (st == SerialCaptureReader::Status::end) break;
    if (st == SerialCaptureReader::Status::corrupt) {
      if (errors) errors->push_back(reader->error());
      continue;
    }
    out.push_back(reader->chunk());
  }
  return out;
}

std::vector<std::uint8_t> bytes_of(const std::vector<SerialChunk>& chunks) {
  std::vector<std::uint8_t> all;
  for (const auto& c : chunks) all.insert(all.end(), c.bytes.begin(), c.bytes.end());
  return all;
}

}  // namespace

TEST_CASE("sigrok-cli annotations with sample numbers: bytes, times and the parity error") {
  // Lines 30..36 of captures/pride_uart.sigrok.txt (the third controller_status, its 0x64 sent with bad parity).
  const std::string text =
      "12226-12435 uart-1: 4A\n"
      "12512-12721 uart-1: 01\n"
      "12799-13008 uart-1: 02\n"
      "13085-13294 uart-1: 64\n"
      "13293-13320 uart-1: Parity error\n"
      "13372-13581 uart-1: 00\n"
      "13658-13867 uart-1: 4E\n";
  SerialReadOptions options;
  options.samplerate_hz = 1'000'000;
  options.protocol = SerialProtocol::pride;
  const auto chunks = read_text(text, CaptureFormat::sigrok, options);
  REQUIRE(chunks.size() == 6);
  CHECK(bytes_of(chunks) == std::vector<std::uint8_t>{0x4A, 0x01, 0x02, 0x64, 0x00, 0x4E});
  CHECK(chunks[0].timestamp_ns == 12'226'000);  // sample 12226 at 1 MHz
  CHECK(chunks[0].link == "uart-1");
  CHECK(chunks[0].protocol == SerialProtocol::pride);
  CHECK(chunks[3].errors == uart_error::kParity);  // on the byte it follows
  for (std::size_t i : {0U, 1U, 2U, 4U, 5U}) CHECK(chunks[i].errors == 0);

  SECTION("without a sample rate the bytes carry no time") {
    const auto untimed = read_text(text, CaptureFormat::sigrok);
    REQUIRE(untimed.size() == 6);
    CHECK_FALSE(untimed[0].timestamp_ns);
    CHECK(untimed[0].protocol == SerialProtocol::raw);
  }
}

TEST_CASE("sigrok-cli's plain and full annotation output: only bytes and errors count") {
  // sigrok-cli -A uart (every class) for the first byte of a Pride frame, then a framing error far from any byte
  const std::string text =
      "uart-1: Start bit\n"
      "uart-1: 0\nuart-1: 1\nuart-1: 1\nuart-1: 1\nuart-1: 1\nuart-1: 1\nuart-1: 1\nuart-1: 1\n"
      "uart-1: FE\n"
      "uart-1: Parity bit\n"
      "uart-1: Stop bit\n"
      "uart-1: 54\n"
      "uart-1: Frame error\n"
      "uart-1: Break condition\n";
  const auto chunks = read_text(text, CaptureFormat::sigrok);
  REQUIRE(chunks.size() == 2);
  CHECK(chunks[0].bytes == std::vector<std::uint8_t>{0xFE});
  CHECK(chunks[0].errors == 0);
  CHECK(chunks[1].bytes == std::vector<std::uint8_t>{0x54});
  CHECK(chunks[1].errors == (uart_error::kFraming | uart_error::kBreak));  // no sample numbers: the byte before
}

TEST_CASE("errors far from the last byte get a chunk of their own") {
  const std::string text =
      "1000-1172 uart-1: AA\n"   // 8 data bits over 172 samples: 21.5 samples per bit
      "1194-1216 uart-1: Frame error\n"  // the stop bit of that byte
      "5000-5400 uart-1: Break condition\n";
  const auto chunks = read_text(text, CaptureFormat::sigrok);
  REQUIRE(chunks.size() == 2);
  CHECK(chunks[0].errors == uart_error::kFraming);
  CHECK(chunks[1].bytes.empty());
  CHECK(chunks[1].errors == uart_error::kBreak);
}

TEST_CASE("PulseView's annotation export: rows name the direction, quotes are optional") {
  const std::string text =
      "1023-1195 UART: RX: AA\n"
      "1240-1412 UART: RX: 05\n"
      "2000-2172 UART: TX: 11\n"
      "1411-1433 UART: RX warnings: Frame error\n"
      "UART RX AA\n";
  std::vector<CaptureError> errors;
  const auto chunks = read_text(text, CaptureFormat::sigrok, {}, &errors);
  REQUIRE(errors.size() == 1);
  CHECK(format_capture_error("pv.txt", errors[0]) ==
        "pv.txt:5:1: expected 'NAME: TEXT' (a sigrok-cli or PulseView annotation) (line skipped)");
  REQUIRE(chunks.size() == 3);
  CHECK(chunks[0].link == "UART:RX");
  CHECK(chunks[1].link == "UART:RX");
  CHECK(chunks[2].link == "UART:TX");
  CHECK(chunks[2].bytes == std::vector<std::uint8_t>{0x11});
  // the frame error is on RX, after 05 (each link holds its last byte): the TX byte in between does not take it
  CHECK(chunks[1].errors == uart_error::kFraming);
  CHECK(chunks[2].errors == 0);
  const auto quoted = read_text("1023-1195 \"UART\": \"RX\": \"AA\"\n", CaptureFormat::sigrok);
  REQUIRE(quoted.size() == 1);
  CHECK(quoted[0].link == "UART:RX");
  CHECK(quoted[0].bytes == std::vector<std::uint8_t>{0xAA});
}

TEST_CASE("sigrok-cli's JSON trace: microsecond times and rows") {
  // the head of captures/pride_uart.sigrok.json
  const std::string text =
      "{\"traceEvents\": [\n"
      "{\"ph\": \"B\", \"ts\": 226.000000, \"pid\": \"uart-1\", \"tid\": \"RX\", \"name\": \"FE\"},\n"
      "{\"ph\": \"E\", \"ts\": 435.000000, \"pid\": \"uart-1\", \"tid\": \"RX\", \"name\": \"FE\"},\n"
      "{\"ph\": \"B\", \"ts\": 512.000000, \"pid\": \"uart-1\", \"tid\": \"RX\", \"name\": \"54\"},\n"
      "{\"ph\": \"E\", \"ts\": 721.000000, \"pid\": \"uart-1\", \"tid\": \"RX\", \"name\": \"54\"},\n"
      "{\"ph\": \"B\", \"ts\": 720.500000, \"pid\": \"uart-1\", \"tid\": \"RX\", \"name\": \"Parity error\"},\n"
      "not json\n"
      "]}\n";
  std::vector<CaptureError> errors;
  const auto chunks = read_text(text, CaptureFormat::sigrok_json, {}, &errors);
  REQUIRE(chunks.size() == 2);
  CHECK(chunks[0].timestamp_ns == 226'000);
  CHECK(chunks[1].timestamp_ns == 512'000);
  CHECK(chunks[0].link == "uart-1:RX");
  CHECK(chunks[1].errors == uart_error::kParity);
  REQUIRE(errors.size() == 1);
  CHECK(errors[0].position == 7);
  CHECK(errors[0].message == "not a JSON trace event");
}

TEST_CASE("PulseView's table saved as CSV, in both of its styles") {
  SECTION("fields quoted (its default), CRLF, a time in Greek-mu microseconds") {
    const std::string text =
        "\"Sample\",\"Time\",\"Decoder\",\"Ann Row\",\"Ann Class\",\"Value\"\r\n"
        "\"1023\",\"102.300 \xCE\xBCs\",\"UART\",\"RX\",\"RX data\",\"AA\"\r\n"
        "\"1033\",\"103.300 \xCE\xBCs\",\"UART\",\"RX bits\",\"RX data bits\",\"0\"\r\n"
        "\"1240\",\"124.000 \xCE\xBCs\",\"UART\",\"RX\",\"RX data\",\"05\"\r\n"
        "\"1400\",\"140.000 \xCE\xBCs\",\"UART\",\"RX\",\"RX parity error bits\",\"Parity error\"\r\n"
        "\"70000000\",\"1:10.000\",\"UART\",\"TX\",\"TX data\",\"1A\"\r\n";
    const auto chunks = read_text(text, CaptureFormat::pulseview_csv);
    REQUIRE(chunks.size() == 3);
    CHECK(chunks[0].timestamp_ns == 102'300);
    CHECK(chunks[0].link == "UART:RX");
    CHECK(chunks[1].errors == uart_error::kParity);
    CHECK(chunks[2].timestamp_ns == 70'000'000'000ULL);
    CHECK(chunks[2].link == "UART:TX");
    SerialReadOptions options;
    options.samplerate_hz = 10'000'000;  // the exact sample wins over the rounded time
    CHECK(read_text(text, CaptureFormat::pulseview_csv, options)[2].timestamp_ns == 7'000'000'000ULL);
  }
  SECTION("commas escaped, columns moved and hidden") {
    const std::string text =
        "Value,Ann Class,Time\r\n"
        "AA,RX data,1.250 ms\r\n"
        "\\,,RX data,1.300 ms\r\n"
        "4E,TX data,2 s\r\n";
    const auto chunks = read_text(text, CaptureFormat::pulseview_csv);
    REQUIRE(chunks.size() == 2);  // "," is no hex byte
    CHECK(chunks[0].timestamp_ns == 1'250'000);
    CHECK(chunks[1].timestamp_ns == 2'000'000'000ULL);
    CHECK(chunks[1].link == "uart:TX");
  }
  SECTION("a file without the Value column is refused line by line") {
    std::vector<CaptureError> errors;
    CHECK(read_text("Sample,Time\r\n1,2 s\r\n", CaptureFormat::pulseview_csv, {}, &errors).empty());
    CHECK_FALSE(errors.empty());
  }
}

TEST_CASE("PulseView times and CSV fields") {
  CHECK(parse_pulseview_time("102.300 \xCE\xBCs") == 102'300);
  CHECK(parse_pulseview_time("102.300 \xC2\xB5s") == 102'300);
  CHECK(parse_pulseview_time("102.3 us") == 102'300);
  CHECK(parse_pulseview_time("1.023 ms") == 1'023'000);
  CHECK(parse_pulseview_time("0.000 s") == 0);
  CHECK(parse_pulseview_time("+2 s") == 2'000'000'000);
  CHECK(parse_pulseview_time("-5 ns") == -5);
  CHECK(parse_pulseview_time("2000 ps") == 2);
  CHECK(parse_pulseview_time("1:02.345") == 62'345'000'000);
  CHECK(parse_pulseview_time("1:00:02.5") == 3'602'500'000'000);
  CHECK_FALSE(parse_pulseview_time("fast"));
  CHECK_FALSE(parse_pulseview_time("3 parsecs"));
  std::vector<std::string> f;
  REQUIRE(split_pulseview_csv("\"a\",\"b \"\"q\"\"\",\"c,d\"", f));
  CHECK(f == std::vector<std::string>{"a", "b \"q\"", "c,d"});
  REQUIRE(split_pulseview_csv("x\\,y,,z\r", f));
  CHECK(f == std::vector<std::string>{"x,y", "", "z"});
  CHECK_FALSE(split_pulseview_csv("\"open", f));
}

TEST_CASE("the committed sigrok-cli outputs give the bytes make_uart_vcd.py put on the wire") {
  const std::string root = std::string(SAUL_SOURCE_DIR) + "/captures/";
  auto read_file = [](const std::string& path, SerialReadOptions options = {}) {
    auto reader = open_serial_capture_reader(path, options);
    std::vector<SerialChunk> out;
    while (reader->next() == SerialCaptureReader::Status::chunk) out.push_back(reader->chunk());
    return out;
  };
  for (const std::string name : {"interboard_uart", "pride_uart"}) {
    INFO(name);
    const auto expected = bytes_of(read_file(root + name + ".serial"));
    const auto annotated = read_file(root + name + ".sigrok.txt");
    CHECK(bytes_of(annotated) == expected);
    CHECK(guess_serial_protocol(expected) ==
          (name == "pride_uart" ? SerialProtocol::pride : SerialProtocol::interboard));
  }
  const auto pride = read_file(root + "pride_uart.sigrok.txt",
                               SerialReadOptions{SerialProtocol::pride, 1'000'000, std::nullopt});
  REQUIRE(pride.size() == 48);
  // period 2's controller_status starts at byte 2 x 12 + 6 = 30; its battery byte (index 3) had the bad parity bit
  for (std::size_t i = 0; i < pride.size(); ++i) CHECK(pride[i].errors == (i == 33 ? uart_error::kParity : 0));
  CHECK(pride[33].bytes == std::vector<std::uint8_t>{0x64});
  // the first VCU frame starts at 0.2 ms; its first data bit begins one bit (26 us) later: sample 226
  CHECK(pride[0].timestamp_ns == 226'000);
  const auto json = read_file(root + "pride_uart.sigrok.json");
  REQUIRE(json.size() == 48);
  for (std::size_t i = 0; i < json.size(); ++i) {
    CHECK(json[i].bytes == pride[i].bytes);
    CHECK(json[i].timestamp_ns == pride[i].timestamp_ns);
    CHECK(json[i].errors == pride[i].errors);
  }
}
