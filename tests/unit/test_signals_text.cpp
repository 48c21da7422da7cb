// Which signals saulctl's text shows as physical values with units (signals::text_in_unit), and with how many
// decimals (signals::text_decimals): the list below is written by hand from docs/protocol.md (the scaled wire
// integers: 1/100 deg, mV, 0.1 V, 1e-7 deg, RC ticks), so a description that changes its scale or unit shows here.
#include <catch2/catch.hpp>

#include <set>
#include <tuple>
#include <string>

#include "saulproto/core/signals.hpp"

using namespace saul::signals;

TEST_CASE("text_in_unit picks exactly the scaled wire integers, with the decimals of their resolution") {
  // message, signal -> decimals (-1: whole units rounded down)
  const std::set<std::tuple<std::string, std::string, int>> expected{
      {"config_cmd", "tilt_limit", 2},   {"telemetry_a", "pitch", 2},     {"telemetry_b", "battery", 3},
      {"state", "pitch", 2},             {"battery_sensor", "voltage", 1}, {"battery_sensor", "current", 1},
      {"gps", "latitude", 7},            {"gps", "longitude", 7},         {"gps", "groundspeed", 1},
      {"gps", "heading", 2},             {"attitude", "pitch", 4},        {"attitude", "roll", 4},
      {"attitude", "yaw", 4},
  };
  std::set<std::tuple<std::string, std::string, int>> found;
  int channels = 0;
  for (const auto protocol : kProtocols)
    for (const auto& m : messages(protocol))
      for (const auto& s : m.signals) {
        if (!text_in_unit(s)) continue;
        if (std::string(m.name) == "rc_channels") {
          CHECK(text_decimals(s) == -1);  // 1024/1639 us: no decimal fraction
          CHECK(std::string(s.unit) == "us");
          ++channels;
          continue;
        }
        found.emplace(m.name, s.name, text_decimals(s));
      }
  CHECK(found == expected);
  CHECK(channels == 16);
}

TEST_CASE("every signal's output name, and a scaled wire integer's name + \"_raw\", is unique in its message") {
  // one name per signal (docs/cli.md): JSON keys, DBC signals and dissector fields are these names
  for (const auto protocol : kProtocols)
    for (const auto& m : messages(protocol)) {
      std::set<std::string> names{"type"};
      for (const auto& s : m.signals) {
        INFO(m.name << "." << s.name);
        CHECK(names.insert(s.name).second);
        if (text_in_unit(s)) CHECK(names.insert(std::string(s.name) + "_raw").second);
      }
    }
}

TEST_CASE("text_decimals of plain scales") {
  SignalDesc s;
  CHECK(text_decimals(s) == 0);
  CHECK(text_decimals(s.scaled(1, 100)) == 2);
  CHECK(text_decimals(s.scaled(5, 10)) == 1);  // 0.5 steps
  CHECK(text_decimals(s.scaled(1, 4)) == 2);   // 0.25 steps
  CHECK(text_decimals(s.scaled(1, 3)) == -1);
  CHECK_FALSE(text_in_unit(s.scaled(1, 100)));  // no unit: stays the wire integer
  CHECK(text_in_unit(s.scaled(1, 100).in("deg")));
  CHECK_FALSE(text_in_unit(s.scaled(1, 100).in("deg").shown(Text::physical)));  // already physical in JSON and text
}
