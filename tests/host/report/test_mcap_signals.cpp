// The decoded channels of an MCAP conversion (report/mcap_signals.hpp): their ids are the same in every file, so
// that threads converting blocks of a file apart (McapCaptureWriter::copy) give each message kind the id the file's
// one list would. Ids, topics and schema names written out by hand from the signal tables' order.
#include <catch2/catch.hpp>

#include <sstream>
#include <string>
#include <vector>

#include "saulproto/core/signals.hpp"
#include "saulproto/host/capture/mcap.hpp"
#include "saulproto/host/report/mcap_signals.hpp"
#include "host/test_frame.hpp"

using saul::CanFrame;
using namespace saul::host;

namespace {

using saul_test::frame;

}  // namespace

TEST_CASE("mcap signals: a message kind's channel id is its place in the signal tables, in every file") {
  namespace sig = saul::signals;
  // telemetry_a is the robot table's 5th message: id 5; a VESC's status_1 the VESC table's 7th: 256 x 7 + controller.
  CHECK(mcap_channel_id(*sig::find_can(0x400, false), 0) == 5);
  CHECK(mcap_channel_id(*sig::find_can(0x938, true), 56) == 256 * 7 + 56);
  CHECK(mcap_channel_id(*sig::find_can(0x944, true), 68) == 256 * 7 + 68);

  // Written through the writer: telemetry_a (0x400) and status_1 from VESC 56 (0x938: protocols.md's example),
  // the second file with the VESC's frame first. Each channel has its id whatever the order it first came in.
  const CanFrame telemetry = frame(0x400, false, {0xD2, 0x04, 0x78, 0x00, 0x90, 0x01, 0x01}, 1'000);
  const CanFrame status = frame(0x938, true, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA}, 2'000);
  for (const bool vesc_first : {false, true}) {
    std::ostringstream out;
    McapWriterOptions o;
    o.compression = McapCompression::none;
    {
      McapCaptureWriter w(out, o, [] { return std::make_unique<McapSignalChannels>(); });
      w.write(vesc_first ? status : telemetry, "can0");
      w.write(vesc_first ? telemetry : status, "can0");
      w.close();
    }
    const std::string file = out.str();
    std::istringstream in(file);
    McapRecordReader r(in, file.size());
    std::vector<std::string> seen;  // "id topic schema" of every decoded message
    while (r.next() == McapRecordReader::Status::message) {
      const auto id = r.message().channel_id;
      if (id == kMcapFramesChannel) continue;
      const auto* channel = r.channel(id);
      REQUIRE(channel != nullptr);
      const auto* schema = r.schema(channel->schema_id);
      REQUIRE(schema != nullptr);
      seen.push_back(std::to_string(id) + " " + channel->topic + " " + schema->name + " " +
                     std::to_string(channel->schema_id));
    }
    // Schemas: 2 + the place in the robot's table (telemetry_a: 6), then the VESC's after the robot's 7 (status_1: 15).
    const std::string a = "5 /saul/telemetry_a saul.telemetry_a 6", s = "1848 /vesc/56/status_1 vesc.status_1 15";
    CHECK(seen == (vesc_first ? std::vector<std::string>{s, a} : std::vector<std::string>{a, s}));
  }
}
