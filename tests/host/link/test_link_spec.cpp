// parse_link_spec (link_spec.hpp): the link forms of docs/cli.md and their rates, read by core/quantity.hpp as
// every rate is (500000, 500k, 1M). Expected values written out by hand.
#include <catch2/catch.hpp>

#include <stdexcept>
#include <string>

#include "saulproto/host/link/link_spec.hpp"

using saul::host::LinkSpec;
using saul::host::parse_link_spec;

TEST_CASE("parse_link_spec: SocketCAN, slcan and serial forms with their rates") {
  CHECK(parse_link_spec("can0").kind == LinkSpec::Kind::socketcan);
  CHECK(parse_link_spec("socketcan:vcan1").device == "vcan1");
  const LinkSpec slcan = parse_link_spec("slcan:/dev/ttyACM0");
  CHECK(slcan.kind == LinkSpec::Kind::slcan);
  CHECK(slcan.device == "/dev/ttyACM0");
  CHECK(slcan.bitrate == 500'000u);  // the robot's bus
  CHECK(parse_link_spec("slcan:/dev/ttyACM0@250000").bitrate == 250'000u);
  CHECK(parse_link_spec("slcan:/dev/ttyACM0@250k").bitrate == 250'000u);
  CHECK(parse_link_spec("slcan:/dev/ttyACM0@1M").bitrate == 1'000'000u);
  const LinkSpec serial = parse_link_spec("serial:/dev/ttyUSB0@460800:8E1");
  CHECK(serial.kind == LinkSpec::Kind::serial);
  CHECK(serial.device == "/dev/ttyUSB0");
  CHECK(serial.serial.baud == 460'800u);
  CHECK(parse_link_spec("serial:/dev/ttyUSB1@420k").serial.baud == 420'000u);
  CHECK(parse_link_spec("serial:/dev/ttyUSB1@420k").text() == "serial:/dev/ttyUSB1@420000:8N1");
}

TEST_CASE("parse_link_spec refuses a bad rate or form with the accepted forms") {
  for (const char* bad : {"slcan:/dev/ttyACM0@0", "slcan:/dev/ttyACM0@fast", "slcan:/dev/ttyACM0@-5",
                          "slcan:/dev/ttyACM0@30M", "serial:/dev/ttyUSB0@", "serial:/dev/ttyUSB0@9600x:8N1"}) {
    INFO(bad);
    CHECK_THROWS_WITH(parse_link_spec(bad), Catch::Matchers::Contains("bad rate") &&
                                                Catch::Matchers::Contains("slcan:/dev/ttyACM0[@500000]"));
  }
  CHECK_THROWS_AS(parse_link_spec(""), std::invalid_argument);
  CHECK_THROWS_AS(parse_link_spec("serial:/dev/ttyUSB0"), std::invalid_argument);  // a serial link needs its baud
  CHECK_THROWS_AS(parse_link_spec("can:/dev/x"), std::invalid_argument);
  CHECK_THROWS_AS(parse_link_spec("slcan:@500000"), std::invalid_argument);  // no device
}
