// Loop trace stats and lines (host/report/trace_report.hpp): gaps against the divider the records show, the time
// stamp's 32-bit wrap, the CSV columns written out by hand.
#include <catch2/catch.hpp>

#include "saulproto/host/report/trace_report.hpp"

using namespace saul;
using saul::trace::LoopTrace;

TEST_CASE("trace stats: every 10th loop, one gap of 3 records, a seq that went back, and the clock's wrap") {
  host::TraceStats s;
  std::uint32_t t = 0xFFFF'FFFFU - 25'000;  // 25 ms before the 32-bit wrap
  const std::uint32_t seqs[] = {100, 110, 120, 160, 170, 5, 15};  // 160: 130, 140, 150 lost; 5: a restart
  for (std::uint32_t seq : seqs) {
    LoopTrace r{};
    r.seq = seq;
    r.time_us = t;
    s.add(r);
    t += 10'000;  // wraps at the third step
  }
  CHECK(s.records() == 7);
  CHECK(s.divider() == 10);
  CHECK(s.gaps() == 1);
  CHECK(s.missing() == 3);
  CHECK(s.backwards() == 1);
  CHECK(s.duration_s() == Approx(0.06));
  CHECK(s.rate_hz() == Approx(100.0));
  const auto j = s.json("x.trace");
  CHECK(j["period_us"]["mean"].get<double>() == Approx(10'000.0));
  CHECK(j["period_us"]["sd"].get<double>() == Approx(0.0).margin(1e-6));
}

TEST_CASE("trace CSV: the agreed columns, physical units, one row per record") {
  CHECK(host::trace_csv_header() ==
        "time_s,seq,pitch_deg,rate_dps,setpoint_deg,p_term,i_term,d_term,output,erpm_left,erpm_right,wheel_mmps,"
        "request_mmps,state,faults,excite,excite_deg\n");
  const LoopTrace r{1'000'000, 1000, -123, 456, -50, 200, -15, -30, 155, 400, 410, 180, 0, 1, 0x02, 2, 100};
  CHECK(host::trace_csv_row(r, 1.0) == "1.000000,1000,-1.23,45.6,-0.50,200,-15,-30,155,400,410,180,0,1,2,2,1.00\n");
  const auto j = host::trace_json(r, 1.0);
  CHECK(j["state"] == "BALANCE");
  CHECK(j["excite"] == "chirp");
  CHECK(j["pitch_deg"].get<double>() == Approx(-1.23));
}

TEST_CASE("trace JSON Schema (MCAP /saul/loop_trace): exactly trace_json()'s keys, each typed and described") {
  const auto schema = nlohmann::json::parse(host::trace_json_schema());
  const LoopTrace r{1'000'000, 1000, -123, 456, -50, 200, -15, -30, 155, 400, 410, 180, 0, 1, 0x02, 2, 100};
  const auto j = host::trace_json(r, 1.0);
  CHECK(schema["properties"].size() == j.size());
  CHECK(schema["required"].size() == j.size());
  CHECK(schema["additionalProperties"] == false);
  for (const auto& [key, value] : j.items()) {
    INFO(key);
    REQUIRE(schema["properties"].contains(key));
    const auto& p = schema["properties"][key];
    const std::string type = value.is_string() ? "string" : value.is_number_integer() ? "integer" : "number";
    CHECK(p["type"] == type);
    CHECK(!p["description"].get<std::string>().empty());
  }
  // The units, written out by hand.
  CHECK(schema["properties"]["pitch_deg"]["description"] == "pitch, in degrees");
  CHECK(schema["properties"]["rate_dps"]["description"] == "pitch rate, in degrees per second");
  CHECK(schema["properties"]["wheel_mmps"]["description"] == "wheel speed, in mm/s");
  CHECK(schema["properties"]["time_s"]["description"] == "time since the trace's start, in seconds");
}
