// Serial captures as MCAP (report/mcap_serial.hpp): the decoded channels hold exactly what decode's path gives
// (SerialCaptureDecoder run apart over the same chunks, each message as json_line(to_json())), one for one, on the
// topic of its link and protocol, at its chunk's time to the nanosecond; every chunk is on /serial/bytes; each
// message has exactly the members its channel's JSON Schema lists. The bytes: the inter-board and Pride captures of
// captures/, the inter-board one again as a second link, and CRSF test frames T1, T3 and a 0x32 command frame (which
// does not decode) from the public reference (protocols.md 2.6), at times with nanoseconds.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/mcap.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/mcap_serial.hpp"
#include "saulproto/host/report/serial_decode.hpp"

using namespace saul;
using namespace saul::host;

namespace {

std::vector<SerialChunk> chunks_of(const std::string& capture, const std::string& rename = "") {
  std::ifstream in(std::string(SAUL_SOURCE_DIR) + "/captures/" + capture);
  SerialLogReader reader(in);
  std::vector<SerialChunk> out;
  while (reader.next() != SerialCaptureReader::Status::end) {
    out.push_back(reader.chunk());
    if (!rename.empty()) out.back().link = rename;
  }
  return out;
}

std::vector<std::uint8_t> bytes_of(const std::string& hex) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    out.push_back(static_cast<std::uint8_t>(std::stoul(hex.substr(i, 2), nullptr, 16)));
  return out;
}

std::vector<SerialChunk> all_chunks() {
  std::vector<SerialChunk> chunks = chunks_of("interboard_uart.serial");
  for (const auto& c : chunks_of("pride_uart.serial")) chunks.push_back(c);
  for (const auto& c : chunks_of("interboard_uart.serial", "serial:/dev/ttyUSB2@460800:8N1")) chunks.push_back(c);
  const std::string crsf = "serial:/dev/ttyACM0@420000:8N1";
  chunks.push_back({1'763'800'000'000'100'123ULL, crsf, SerialProtocol::crsf,
                    bytes_of("C81816E0031FF8C0073EF0810F7CE0031FF8C0073EF0810F7CAD"), 0});
  chunks.push_back({1'763'800'000'002'150'007ULL, crsf, SerialProtocol::crsf,
                    bytes_of("C80C143C3E640900040337620895C80C32C8EC0A7001001E84802272"), 0});
  return chunks;
}

struct Expected {
  std::uint64_t time = 0;
  std::string link;
  SerialProtocol protocol = SerialProtocol::raw;
  std::string json;
  bool error = false;
  SerialMessage message;
};

std::vector<Expected> reference(const std::vector<SerialChunk>& chunks) {
  std::vector<Expected> out;
  SerialCaptureDecoder d;
  const SerialCaptureDecoder::Callback on = [&](const SerialChunk& c, SerialProtocol p, const SerialMessage& m) {
    out.push_back({c.timestamp_ns.value_or(0), c.link, p, json_line(to_json(m)), is_decode_error(m), m});
  };
  for (const auto& c : chunks) d.add(c, on);
  d.finish(on);
  return out;
}

std::string write(const std::vector<SerialChunk>& chunks, McapCompression compression, std::uint64_t chunk_bytes) {
  std::ostringstream out;
  McapWriterOptions o;
  o.compression = compression;
  o.chunk_bytes = chunk_bytes;
  McapWriter w(out, o);
  McapSerialChannels channels(w, std::nullopt);
  for (const auto& c : chunks) channels.add(c);
  channels.finish();
  w.close();
  return out.str();
}

}  // namespace

TEST_CASE("mcap serial: each decoded message on its link's channel, = decode's JSON, at its chunk's time in ns") {
  const auto chunks = all_chunks();
  const auto want = reference(chunks);
  REQUIRE(want.size() == 6 + 8 + 6 + 3);  // the captures' decode goldens, and the three CRSF frames
  for (auto compression : {McapCompression::none, McapCompression::zstd}) {
    for (std::uint64_t chunk_bytes : {std::uint64_t{200}, std::uint64_t{1} << 20}) {
      const std::string file = write(chunks, compression, chunk_bytes);
      std::istringstream in(file);
      McapRecordReader reader(in, file.size());
      std::size_t next = 0, bytes_messages = 0;
      std::map<std::string, std::size_t> per_topic;
      for (;;) {
        const auto st = reader.next();
        if (st == McapRecordReader::Status::end) break;
        REQUIRE(st == McapRecordReader::Status::message);
        const auto& m = reader.message();
        const auto* channel = reader.channel(m.channel_id);
        REQUIRE(channel != nullptr);
        const std::string data(m.data.begin(), m.data.end());
        ++per_topic[channel->topic];
        if (channel->topic == kMcapSerialBytesTopic) {  // the chunk, as captured
          const SerialChunk& c = chunks.at(bytes_messages++);
          const auto j = nlohmann::json::parse(data);
          CHECK(j.at("link") == c.link);
          CHECK(bytes_of(j.at("data").get<std::string>()) == c.bytes);
          CHECK(m.log_time == c.timestamp_ns.value_or(0));
          continue;
        }
        REQUIRE(next < want.size());
        const Expected& e = want[next++];
        CHECK(data == e.json);
        CHECK(m.log_time == e.time);
        const std::size_t nth = e.link == "serial:/dev/ttyUSB2@460800:8N1" ? 2 : 1;
        CHECK(channel->topic == mcap_serial_topic(e.protocol, nth, e.error ? "undecoded" : name_of(e.message)));
        CHECK(reader.schema(channel->schema_id)->encoding == "jsonschema");
      }
      CHECK(next == want.size());
      CHECK(bytes_messages == chunks.size());
      CHECK(per_topic.contains("/serial/interboard_2/state"));
      CHECK(per_topic.contains("/serial/pride/controller_status"));
      CHECK(per_topic.at("/serial/crsf/undecoded") == 1);
      CHECK(per_topic.at("/serial/crsf/rc_channels") == 1);
    }
  }
}

TEST_CASE("mcap serial: a message's members are exactly its schema's properties, the required ones among them") {
  for (const auto& e : reference(all_chunks())) {
    const auto message = nlohmann::json::parse(e.json);
    const auto schema = nlohmann::json::parse(mcap_serial_json_schema(e.message));
    std::set<std::string> members, properties;
    for (const auto& [k, v] : message.items()) members.insert(k);
    for (const auto& [k, v] : schema.at("properties").items()) {
      properties.insert(k);
      CHECK(v.contains("description"));
    }
    INFO(e.json);
    CHECK(members == properties);
    for (const auto& r : schema.at("required")) CHECK(members.contains(r.get<std::string>()));
    CHECK(schema.at("additionalProperties") == false);
  }
}

TEST_CASE("mcap serial: a link's baud rate and format from its name") {
  CHECK(link_line_settings("serial:/dev/ttyUSB0@460800:8N1").baud == 460800U);
  CHECK(link_line_settings("serial:/dev/ttyUSB0@460800:8N1").format == "8N1");
  CHECK(link_line_settings("serial:/dev/ttyUSB1@38400").baud == 38400U);
  CHECK(link_line_settings("serial:/dev/ttyUSB1@38400").format.empty());
  CHECK_FALSE(link_line_settings("uart-1:RX").baud);
  CHECK_FALSE(link_line_settings("x@y").baud);
}
