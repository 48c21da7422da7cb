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

TEST_CASE("mcap signals: each frame's message, then its decoded one without what the topic says (type, controller)") {
  // Values worked out by hand from the frames: telemetry_a pitch 0x04D2 = 1234 x 1/100 deg, pid_out 0x78, speed
  // 0x190, state 1 = BALANCE; status_1 of VESC 56: erpm 0xFFFFFB50 = -1200, current 0x23 = 35 x 1/10 A, duty
  // 0xFA = 250 x 1/1000. No "type" (the topic and schema say it) and no "controller_id" (the topic's /vesc/56/).
  const CanFrame telemetry = frame(0x400, false, {0xD2, 0x04, 0x78, 0x00, 0x90, 0x01, 0x01}, 1'000);
  const CanFrame status = frame(0x938, true, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA}, 2'000);
  CanFrame remote = frame(0x400, false, {}, 5'000);
  remote.remote = true;
  remote.dlc = 7;
  std::ostringstream out;
  McapWriterOptions o;
  o.compression = McapCompression::none;
  {
    McapCaptureWriter w(out, o, [] { return std::make_unique<McapSignalChannels>(); });
    w.write(telemetry, "can0");
    w.write(status, "can0");
    // The same contents again (the cache's): their own time and interface.
    CanFrame again = status;
    again.timestamp_ns = 3'000;
    w.write(again, "can1");
    again = telemetry;
    again.timestamp_ns = 4'000;
    w.write(again, "can0");
    w.write(remote, "can0");  // on /can/frames only
    w.close();
  }
  const std::string file = out.str();
  std::istringstream in(file);
  McapRecordReader r(in, file.size());
  std::vector<std::string> seen;  // "time topic data"
  while (r.next() == McapRecordReader::Status::message) {
    const auto& m = r.message();
    seen.push_back(std::to_string(m.log_time) + " " + r.channel(m.channel_id)->topic + " " +
                   std::string(m.data.begin(), m.data.end()));
  }
  const std::string a = R"({"pid_out":120,"pitch":12.34,"pitch_raw":1234,"speed_mmps":400,"state":"BALANCE"})";
  const std::string s = R"({"current":3.5,"duty":0.25,"erpm":-1200})";
  const std::string fa = R"({"id":1024,"extended":false,"remote":false,"error":false,"dlc":7,"data":"D2047800900101","interface":)";
  const std::string fs = R"({"id":2360,"extended":true,"remote":false,"error":false,"dlc":8,"data":"FFFFFB50002300FA","interface":)";
  CHECK(seen == std::vector<std::string>{
                    "1000 /can/frames " + fa + R"("can0"})",
                    "1000 /saul/telemetry_a " + a,
                    "2000 /can/frames " + fs + R"("can0"})",
                    "2000 /vesc/56/status_1 " + s,
                    "3000 /can/frames " + fs + R"("can1"})",
                    "3000 /vesc/56/status_1 " + s,
                    "4000 /can/frames " + fa + R"("can0"})",
                    "4000 /saul/telemetry_a " + a,
                    R"(5000 /can/frames {"id":1024,"extended":false,"remote":true,"error":false,"dlc":7,"data":"","interface":"can0"})",
                });
}
