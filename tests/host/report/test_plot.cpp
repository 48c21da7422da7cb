// saulctl plot's host side (saulproto/host/report/telemetry_plot.hpp, plot.hpp): the dashboard's panel set, binning,
// state and fault markers at their exact times, the marker cap, the CSV, the self-contained HTML, --id selections.
// Frames are built with the library's encoders; every expected number is worked out by hand in the comments.
#include <catch2/catch.hpp>

#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/core/interboard.hpp"
#include "saulproto/core/saul_can.hpp"
#include "saulproto/core/vesc.hpp"
#include "saulproto/host/report/plot.hpp"
#include "saulproto/host/report/telemetry_plot.hpp"

using saul::CanFrame;
using namespace saul::host;
namespace saulcan = saul::saulcan;
namespace vesc = saul::vesc;
namespace interboard = saul::interboard;
using saulcan::RobotState;

namespace {

constexpr std::uint64_t kMs = 1'000'000ULL;
constexpr std::uint64_t kT0 = 10'000 * kMs;  // 10.000 s

CanFrame at(CanFrame f, std::uint64_t ns) {
  f.timestamp_ns = ns;
  return f;
}

CanFrame tele_a(std::uint64_t ms, std::int16_t pitch_x100, RobotState state, std::int16_t pid_out = 0,
                std::int16_t speed = 0) {
  return at(saulcan::encode(saulcan::TelemetryA{pitch_x100, pid_out, speed, state}), kT0 + ms * kMs);
}

CanFrame tele_b(std::uint64_t ms, std::uint8_t faults, std::int16_t l = 0, std::int16_t r = 0,
                std::uint16_t battery_mv = 39600) {
  return at(saulcan::encode(saulcan::TelemetryB{l, r, battery_mv, faults}), kT0 + ms * kMs);
}

CanFrame velocity(std::uint64_t ms, std::int16_t speed) {
  return at(saulcan::encode(saulcan::VelocityCmd{speed, 0}), kT0 + ms * kMs);
}

CanFrame status1(std::uint64_t ms, std::uint8_t controller, std::int32_t erpm) {
  vesc::Status1 s;
  s.controller_id = controller;
  s.erpm = erpm;
  return at(vesc::encode(s), kT0 + ms * kMs);
}

CanFrame status5(std::uint64_t ms, std::uint8_t controller, std::int16_t volts_x10) {
  vesc::Status5 s;
  s.controller_id = controller;
  s.voltage_in_x10 = volts_x10;
  return at(vesc::encode(s), kT0 + ms * kMs);
}

std::vector<std::string> titles(const TelemetryPlotter& p) {
  std::vector<std::string> out;
  for (const auto& panel : p.panels()) out.push_back(panel.title);
  return out;
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto i = text.find(what); i != std::string::npos; i = text.find(what, i + what.size())) ++n;
  return n;
}

PlotRequest dashboard_request(std::size_t max_markers = 40) {
  PlotRequest r;
  r.max_markers = max_markers;
  r.source_name = "hand.log";
  return r;
}

}  // namespace

TEST_CASE("plot: binning keeps each column's first, lowest, highest and last point") {
  // 4 columns over 0..4 s. Column 0 gets four points, column 2 one; columns 1 and 3 stay empty.
  PlotBinner b(0, 4, 4);
  b.add(0.1, 5);
  b.add(0.5, 1);
  b.add(0.9, 9);
  b.add(0.95, 3);
  b.add(2.5, 7);
  const auto pts = b.points();
  REQUIRE(pts.size() == 5);
  const double t[] = {0.1, 0.5, 0.9, 0.95, 2.5};
  const double v[] = {5, 1, 9, 3, 7};
  for (std::size_t i = 0; i < 5; ++i) {
    CHECK(pts[i].t == t[i]);
    CHECK(pts[i].v == v[i]);
  }
  // A fifth point in column 0 that is neither extreme nor last replaces nothing but the last.
  b.add(0.99, 4);
  CHECK(b.points().size() == 5);
  CHECK(b.points()[3].t == 0.99);
  CHECK(b.count() == 6);
  CHECK(b.min() == 1.0);
  CHECK(b.max() == 9.0);
}

TEST_CASE("plot: the dashboard bins 0x400 pitch in degrees on the time since the first message") {
  // pitch_x100 100, -300, 500 at +0, +100, +200 ms; 200, 0 at +300, +350 ms; 50 at +1000 ms. Four columns over
  // the 1 s range (0.25 s each): column 0 holds 1°, -3°, 5° (first, lowest, highest = last); column 1 holds 2° then
  // 0° (first = highest, lowest = last); the last point (t = 1.0) falls into column 3.
  const std::vector<CanFrame> frames{tele_a(0, 100, RobotState::balance),   tele_a(100, -300, RobotState::balance),
                                     tele_a(200, 500, RobotState::balance), tele_a(300, 200, RobotState::balance),
                                     tele_a(350, 0, RobotState::balance),   tele_a(1000, 50, RobotState::balance)};
  const TelemetryPlotter plotter(dashboard_request(), frames_plot_source(frames));
  CHECK(plotter.messages() == 6);
  CHECK(plotter.points_span_s() == Approx(1.0));
  const PlotDocument doc = plotter.document(4);
  CHECK(doc.t0 == 0);
  CHECK(doc.t1 == Approx(1.0));
  REQUIRE(doc.panels.size() == 3);  // pitch, pid_out, speed: 0x400 carries all three
  CHECK(doc.panels[0].title == "pitch [deg]");
  REQUIRE(doc.panels[0].series.size() == 1);  // the UART state series has no data and is not drawn
  CHECK(doc.panels[0].series[0].label == "0x400");
  const auto pts = doc.panels[0].series[0].binner.points();
  const std::vector<std::pair<double, double>> expected{{0, 1}, {0.1, -3}, {0.2, 5}, {0.3, 2}, {0.35, 0}, {1.0, 0.5}};
  REQUIRE(pts.size() == expected.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    CHECK(pts[i].t == Approx(expected[i].first).margin(1e-12));
    CHECK(pts[i].v == Approx(expected[i].second).margin(1e-12));
  }
  CHECK(doc.title == "hand.log: telemetry (6 messages from 10.000000)");
  CHECK(doc.time_label == "time since the first plotted message [s]");
}

TEST_CASE("plot: state and fault changes are marked at their exact times with the library's names") {
  // +0 ms OFF and faults 0 (first state seen; faults start from none, so 0 is no change), +100 OFF again,
  // +250 BALANCE, +300 faults rc_loss|orin_timeout (0x11), +400 faults orin_timeout only (rc_loss cleared),
  // +500 ESTOP, +1000 faults 0x10 again (no change). Time 0 is +0 ms, the right edge +1000 ms.
  const std::vector<CanFrame> frames{
      tele_a(0, 0, RobotState::off),     tele_b(0, 0),    tele_a(100, 0, RobotState::off),
      tele_a(250, 0, RobotState::balance), tele_b(300, 0x11), tele_b(400, 0x10),
      tele_a(500, 0, RobotState::estop), tele_b(1000, 0x10)};
  const TelemetryPlotter plotter(dashboard_request(), frames_plot_source(frames));
  const PlotDocument doc = plotter.document();
  REQUIRE(doc.markers.size() == 5);
  CHECK(doc.markers_total == 5);
  struct Expect {
    double t;
    MarkerKind kind;
    const char* label;
    const char* detail;
    const char* when;
  };
  const Expect expected[] = {
      {0.0, MarkerKind::state, "OFF", "OFF (first seen)", "10.000000"},
      {0.25, MarkerKind::state, "BALANCE", "OFF -> BALANCE", "10.250000"},
      {0.3, MarkerKind::faults, "+rc_loss +orin_timeout", "none -> rc_loss+orin_timeout", "10.300000"},
      {0.4, MarkerKind::faults, "-rc_loss", "rc_loss+orin_timeout -> orin_timeout", "10.400000"},
      {0.5, MarkerKind::state, "ESTOP", "BALANCE -> ESTOP", "10.500000"},
  };
  for (std::size_t i = 0; i < 5; ++i) {
    INFO("marker " << i);
    CHECK(doc.markers[i].t == Approx(expected[i].t).margin(1e-12));
    CHECK(doc.markers[i].kind == expected[i].kind);
    CHECK(doc.markers[i].label == expected[i].label);
    CHECK(doc.markers[i].detail == expected[i].detail);
    CHECK(doc.markers[i].when == expected[i].when);
  }
  // Drawn on every panel: x = 70 + t / 1.0 s × 880 px, so 70, 290, 334, 422, 510.
  const std::string svg = render_svg(doc);
  const std::size_t panels = doc.panels.size();
  REQUIRE(panels == 5);  // no VESC frames: ERPM is left out, battery comes from 0x401
  CHECK(count_of(svg, "class=\"marker\"") == 5 * panels);
  for (const char* x : {"x1=\"70.0\"", "x1=\"290.0\"", "x1=\"334.0\"", "x1=\"422.0\"", "x1=\"510.0\""})
    CHECK(count_of(svg, std::string("class=\"marker\" ") + x) == panels);
  CHECK(svg.find("5 state/fault changes, all marked:") != std::string::npos);
  CHECK(svg.find(">+rc_loss +orin_timeout</text>") != std::string::npos);
}

TEST_CASE("plot: the panel set follows the frames the capture has") {
  SECTION("every dashboard message: six panels, two wheels each, other VESC controllers ignored") {
    const std::vector<CanFrame> frames{tele_a(0, 0, RobotState::off), tele_b(0, 0), velocity(10, 200),
                                       status1(20, vesc::kLeftId, 1400), status1(21, vesc::kRightId, -1400),
                                       status1(22, 0x10, 99999),  // not one of the robot's controllers
                                       status5(30, vesc::kLeftId, 396), status5(31, vesc::kRightId, 395)};
    const TelemetryPlotter plotter(dashboard_request(), frames_plot_source(frames));
    CHECK(titles(plotter) == std::vector<std::string>{"pitch [deg]", "pid_out [permille]", "speed [mm/s]",
                                                      "wheel speed [rpm] (0x401)", "VESC ERPM (STATUS)",
                                                      "battery [V]"});
    CHECK(plotter.left_out().empty());
    const auto doc = plotter.document(10);
    const auto& erpm = doc.panels[4];
    REQUIRE(erpm.series.size() == 2);
    CHECK(erpm.series[0].label == "left (68)");
    CHECK(erpm.series[0].binner.max() == 1400.0);
    CHECK(erpm.series[1].label == "right (56)");
    CHECK(erpm.series[1].binner.min() == -1400.0);
    CHECK(erpm.count() == 2);  // the frame from controller 0x10 is in no series
    const auto& battery = doc.panels[5];
    REQUIRE(battery.series.size() == 3);
    CHECK(battery.series[0].binner.max() == Approx(39.6));  // 39600 mV
    CHECK(battery.series[1].binner.max() == Approx(39.6));  // 396 / 10 V
    CHECK(battery.series[2].binner.max() == Approx(39.5));
    CHECK(doc.panels[2].series.size() == 2);  // speed: reported and commanded
  }
  SECTION("only 0x401 and 0x300: pitch, pid_out and ERPM are left out and said so") {
    const std::vector<CanFrame> frames{velocity(0, 1000), tele_b(70, 0x11, 1200, -1180)};
    const TelemetryPlotter plotter(dashboard_request(), frames_plot_source(frames));
    CHECK(titles(plotter) ==
          std::vector<std::string>{"speed [mm/s]", "wheel speed [rpm] (0x401)", "battery [V]"});
    REQUIRE(plotter.left_out().size() == 3);
    CHECK(plotter.left_out()[0] == "pitch [deg]: left out, no 0x400 telemetry_a or inter-board state messages");
    CHECK(plotter.left_out()[1] == "pid_out [permille]: left out, no 0x400 telemetry_a or inter-board state messages");
    CHECK(plotter.left_out()[2] ==
          "VESC ERPM (STATUS): left out, no VESC STATUS (vesc_status_1) frames from controllers 68 and 56");
    REQUIRE(plotter.panels()[0].series.size() == 1);
    CHECK(plotter.panels()[0].series[0].label == "commanded (0x300)");
    REQUIRE(plotter.panels()[2].series.size() == 1);  // battery from 0x401 only
    const auto doc = plotter.document();
    CHECK(doc.notes == plotter.left_out());
    CHECK(render_svg(doc).find("VESC ERPM (STATUS): left out") != std::string::npos);
  }
  SECTION("nothing the dashboard draws: an error that points at --id") {
    const std::vector<CanFrame> frames{at(saulcan::encode(saulcan::ModeCmd{saulcan::Mode::off}), kT0)};
    CHECK_THROWS_AS(TelemetryPlotter(dashboard_request(), frames_plot_source(frames)), PlotEmptyError);
  }
}

TEST_CASE("plot: markers are capped, the rest counted in the picture and the page") {
  // 100 state values alternating OFF, BALANCE, ... 10 ms apart: 100 changes (the first is "first seen").
  std::vector<CanFrame> frames;
  for (std::uint64_t i = 0; i < 100; ++i)
    frames.push_back(tele_a(i * 10, 0, i % 2 == 0 ? RobotState::off : RobotState::balance));
  const TelemetryPlotter plotter(dashboard_request(10), frames_plot_source(frames));
  CHECK(plotter.changes().total() == 100);
  REQUIRE(plotter.changes().kept().size() == 10);
  CHECK(plotter.changes().kept()[9].index == 9);
  const auto doc = plotter.document();
  REQUIRE(doc.markers.size() == 10);
  CHECK(doc.markers[9].t == Approx(0.09));
  CHECK(doc.markers_total == 100);
  const std::string svg = render_svg(doc);
  CHECK(count_of(svg, "class=\"marker\"") == 10 * doc.panels.size());
  // The 10 lines are 0.01 / 0.99 s x 880 px = 8.9 px apart, less than the 12 px labels need: the labels alternate
  // between the top lane and the middle lane, 17.8 px apart in each.
  CHECK(count_of(svg, "rotate(90)") == 10 * doc.panels.size());
  CHECK(svg.find("100 state/fault changes: the first 10 are marked, 90 more are not:") != std::string::npos);
  const std::string html = render_html(doc);
  CHECK(count_of(html, "<tr class=\"state\">") == 10);
  CHECK(html.find("90 more changes are neither marked nor listed.") != std::string::npos);

  const TelemetryPlotter none(dashboard_request(0), frames_plot_source(frames));
  CHECK(none.changes().total() == 100);
  CHECK(none.document().markers.empty());
}

TEST_CASE("plot: the HTML page is self-contained and lists the changes with their times") {
  const std::vector<CanFrame> frames{tele_a(0, 0, RobotState::off), tele_b(0, 0),
                                     tele_a(500, 120, RobotState::balance), tele_b(700, 0x01)};
  PlotRequest request = dashboard_request();
  request.source_name = "run <1> & co.log";
  const TelemetryPlotter plotter(request, frames_plot_source(frames));
  const std::string html = render_html(plotter.document());
  CHECK(html.starts_with("<!DOCTYPE html>\n"));
  CHECK(html.ends_with("</html>\n"));
  // Nothing fetched: no address at all (the inline SVG needs no namespace), no scripts, no links, no sources.
  for (const char* bad : {"http", "src=", "href=", "<script", "<link", "url(", "@import"}) {
    INFO(bad);
    CHECK(html.find(bad) == std::string::npos);
  }
  CHECK(count_of(html, "<svg ") == 1);
  CHECK(html.find("<?xml") == std::string::npos);
  CHECK(html.find("<title>run &lt;1&gt; &amp; co.log: telemetry (4 messages from 10.000000)</title>") !=
        std::string::npos);
  CHECK(html.find("<tr class=\"state\"><td class=\"num\">2</td><td class=\"num\">0.500000</td>"
                  "<td class=\"num\">10.500000</td><td>state</td><td>OFF -&gt; BALANCE</td></tr>") !=
        std::string::npos);
  CHECK(html.find("<tr class=\"faults\"><td class=\"num\">3</td><td class=\"num\">0.700000</td>"
                  "<td class=\"num\">10.700000</td><td>faults</td><td>none -&gt; rc_loss</td></tr>") !=
        std::string::npos);
  // The standalone SVG keeps its declaration and namespace.
  const std::string svg = render_svg(plotter.document());
  CHECK(svg.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\""));
}

TEST_CASE("plot: the dashboard CSV has one column per series drawn, then state and faults") {
  // +0 ms 0x400 pitch -2.50°, pid 420, 300 mm/s, BALANCE; +50 ms 0x300 350 mm/s; +100 ms 0x401 1200/-1180 rpm,
  // 39.6 V, faults 0x11 = 17. No VESC frames and no UART state: those columns are not there.
  const std::vector<CanFrame> frames{tele_a(0, -250, RobotState::balance, 420, 300), velocity(50, 350),
                                     tele_b(100, 0x11, 1200, -1180, 39600)};
  const TelemetryPlotter plotter(dashboard_request(), frames_plot_source(frames));
  std::ostringstream out;
  plotter.write_csv(out);
  CHECK(out.str() ==
        "time_s,pitch_deg,pid_out,speed_mmps,speed_cmd_mmps,wheel_l_rpm,wheel_r_rpm,battery_v,state,faults\n"
        "0.000000,-2.5,420,300,,,,,1,\n"
        "0.050000,,,,350,,,,,\n"
        "0.100000,,,,,1200,-1180,39.6,,17\n");
}

TEST_CASE("plot: --id selections, by id or name, and their errors") {
  const std::vector<CanFrame> frames{velocity(0, 100), tele_a(100, 21, RobotState::balance, 16, 7),
                                     tele_a(200, -5, RobotState::balance, -4, 8)};
  SECTION("by CAN id, two fields: time 0 is the first message giving a point or a state") {
    PlotRequest r;
    r.id = "0x400";
    r.fields = {"pitch_x100", "state"};
    const TelemetryPlotter plotter(r, frames_plot_source(frames));
    CHECK_FALSE(plotter.dashboard());
    CHECK(titles(plotter) == std::vector<std::string>{"0x400: pitch_x100", "0x400: state"});
    CHECK(plotter.messages() == 2);
    CHECK(plotter.points_span_s() == Approx(0.1));
    std::ostringstream out;
    plotter.write_csv(out);
    CHECK(out.str() == "time_s,pitch_x100,state\n0.000000,21,1\n0.100000,-5,1\n");
    CHECK(plotter.document().markers.size() == 1);  // BALANCE, first seen
  }
  SECTION("by name, no fields: every numeric field of the message") {
    PlotRequest r;
    r.id = "telemetry_a";
    const TelemetryPlotter plotter(r, frames_plot_source(frames));
    CHECK(titles(plotter) == std::vector<std::string>{"telemetry_a: pitch_x100", "telemetry_a: pid_out",
                                                      "telemetry_a: speed_mmps", "telemetry_a: state"});
  }
  SECTION("by id, only the first match's message: a 29-bit VESC SET_RPM to controller 0 has the id 0x300 too") {
    vesc::SetRpm rpm;
    rpm.controller_id = 0;
    rpm.erpm = 1000;
    std::vector<CanFrame> with_vesc = frames;
    with_vesc.push_back(at(vesc::encode(rpm), kT0 + 300 * kMs));
    REQUIRE(with_vesc.back().id == 0x300);
    REQUIRE(with_vesc.back().extended);
    PlotRequest r;
    r.id = "0x300";
    const TelemetryPlotter plotter(r, frames_plot_source(with_vesc));
    CHECK(titles(plotter) == std::vector<std::string>{"0x300: speed_mmps", "0x300: steer_mrad"});
    CHECK(plotter.messages() == 1);
  }
  SECTION("errors") {
    PlotRequest r;
    r.id = "0x400";
    r.fields = {"pitch"};
    try {
      TelemetryPlotter plotter(r, frames_plot_source(frames));
      FAIL("no error");
    } catch (const PlotUsageError& e) {
      CHECK(std::string(e.what()) ==
            "'0x400' has no numeric field 'pitch': it has pitch_x100, pid_out, speed_mmps, state");
    }
    r.fields = {};
    r.id = "0x40z";
    CHECK_THROWS_AS(TelemetryPlotter(r, frames_plot_source(frames)), PlotUsageError);
    r.id = "0x401";
    r.source_name = "x.log";
    CHECK_THROWS_WITH(TelemetryPlotter(r, frames_plot_source(frames)), "no '0x401' in x.log");
    PlotRequest fields_only;
    fields_only.fields = {"pitch_x100"};
    CHECK_THROWS_AS(TelemetryPlotter(fields_only, frames_plot_source(frames)), PlotUsageError);
  }
}

TEST_CASE("plot: a capture without timestamps is drawn by message number") {
  std::vector<CanFrame> frames{tele_a(0, 0, RobotState::off), tele_a(0, 100, RobotState::off),
                               tele_a(0, 200, RobotState::balance)};
  for (auto& f : frames) f.timestamp_ns.reset();
  const TelemetryPlotter plotter(dashboard_request(), frames_plot_source(frames));
  CHECK_FALSE(plotter.timed());
  const auto doc = plotter.document();
  CHECK(doc.time_label == "message number (the capture has no timestamps)");
  CHECK(doc.t1 == 2);
  REQUIRE(doc.markers.size() == 2);
  CHECK(doc.markers[1].t == 2);
  CHECK(doc.markers[1].when.empty());
  CHECK(doc.title == "hand.log: telemetry (3 messages from an untimed capture)");
}

TEST_CASE("plot: inter-board UART messages give pitch, pid_out and the markers") {
  // A source of serial messages: STATE (pitch -12.34°, pid 300, BALANCE) at 1 ms, FAULT rc_loss|estop at 4 ms,
  // STATE FAULT (5) at 6 ms. 1 ms is time 0.
  const std::vector<std::pair<std::uint64_t, SerialMessage>> messages{
      {1 * kMs, interboard::Message{interboard::State{-1234, 300, 1}}},
      {4 * kMs, interboard::Message{interboard::Fault{0x05}}},
      {6 * kMs, interboard::Message{interboard::State{-1000, 0, 5}}}};
  const PlotSource source = [&](const PlotSink& sink) {
    for (const auto& [ns, m] : messages) {
      const std::string name = name_of(m);
      PlotMessage pm;
      pm.timestamp_ns = ns;
      pm.name = name;
      pm.serial = &m;
      sink(pm);
    }
  };
  const TelemetryPlotter plotter(dashboard_request(), source);
  CHECK(titles(plotter) == std::vector<std::string>{"pitch [deg]", "pid_out [permille]"});
  const auto doc = plotter.document();
  CHECK(doc.panels[0].series[0].label == "UART state");
  CHECK(doc.panels[0].series[0].binner.min() == Approx(-12.34));
  REQUIRE(doc.markers.size() == 3);
  CHECK(doc.markers[0].label == "BALANCE");
  CHECK(doc.markers[1].t == Approx(0.003));
  CHECK(doc.markers[1].label == "+rc_loss +estop");
  CHECK(doc.markers[2].t == Approx(0.005));
  CHECK(doc.markers[2].detail == "BALANCE -> FAULT");
}

TEST_CASE("plot: the sample UART capture through the file source") {
  // captures/interboard_uart.serial: STATE error_state 1 at 0.0011 s, FAULT flags 5 at 0.0041 s (make_uart_vcd.py).
  const TelemetryPlotter plotter(dashboard_request(),
                                 capture_plot_source(SAUL_SOURCE_DIR "/captures/interboard_uart.serial"));
  const auto doc = plotter.document();
  REQUIRE(doc.markers.size() == 2);
  CHECK(doc.markers[0].when == "0.001100");
  CHECK(doc.markers[0].detail == "BALANCE (first seen)");
  CHECK(doc.markers[1].t == Approx(0.003));
  CHECK(doc.markers[1].detail == "none -> rc_loss+estop");
  CHECK(doc.t1 == Approx(0.003));
}

TEST_CASE("plot: every dashboard series names a real field of its message") {
  const std::vector<saul::BusMessage> bus{saulcan::TelemetryA{}, saulcan::TelemetryB{}, saulcan::VelocityCmd{},
                                          vesc::Status1{}, vesc::Status5{}};
  const SerialMessage state = interboard::Message{interboard::State{}};
  for (const auto& panel : dashboard_panels())
    for (const auto& s : panel.series) {
      INFO(panel.title << ": " << s.message << "." << s.field);
      bool found = false;
      for (const auto& m : bus)
        if (s.message == saul::name_of(m)) found = numeric_field(m, s.field).has_value();
      if (s.message == name_of(state)) found = numeric_field(state, s.field).has_value();
      CHECK(found);
    }
}

TEST_CASE("plot: state and fault names come from the library") {
  CHECK(state_name(0) == "OFF");
  CHECK(state_name(4) == "TILT_CUTOFF");
  CHECK(state_name(5) == "FAULT");
  CHECK(state_name(9) == "9");
  CHECK(fault_names(0) == "none");
  CHECK(fault_names(0x11) == "rc_loss+orin_timeout");
  CHECK(fault_names(0x80) == "low_battery");
  StateChange c;
  c.kind = MarkerKind::faults;
  c.from = 0x05;
  c.to = 0x0C;  // estop stays, rc_loss cleared, tilt_cutoff set
  CHECK(change_label(c) == "+tilt_cutoff -rc_loss");
  CHECK(change_detail(c) == "rc_loss+estop -> estop+tilt_cutoff");
}

TEST_CASE("plot: marker labels in a crowd take the middle lane, then give way; long ones are shortened") {
  // A 1 s axis: A, B, C at 0, 5 and 10 ms are x = 70, 74.4 and 78.8. A takes the top lane (y = top + 4), B is 4.4 px
  // from A so it takes the middle lane (top + 100), C is within 12 px of both and gets its line only. D at 0.5 s
  // (x = 510) has 40 characters: 31 and an ellipsis fit the top lane.
  PlotDocument doc;
  doc.t0 = 0;
  doc.t1 = 1;
  doc.panels.emplace_back("p", PlotBinner(0, 1, 10));
  const std::string long_label(40, 'x');
  for (const auto& [t, label] : std::vector<std::pair<double, std::string>>{
           {0.0, "A"}, {0.005, "B"}, {0.01, "C"}, {0.5, long_label}})
    doc.markers.push_back(PlotMarker{t, MarkerKind::faults, label, label, ""});
  doc.markers_total = 4;
  const std::string svg = render_svg(doc);
  const int top = 40 + 16 + 8;  // the header, one info line (the marker count), the gap
  CHECK(count_of(svg, "class=\"marker\"") == 4);
  const std::string style = ") rotate(90)\" font-size=\"10\" fill=\"#ff7f0e\">";
  CHECK(svg.find("translate(73.0," + std::to_string(top + 4) + style + "A<") != std::string::npos);
  CHECK(svg.find("translate(77.4," + std::to_string(top + 104) + style + "B<") != std::string::npos);
  CHECK(svg.find(">C<") == std::string::npos);
  CHECK(svg.find("<title>0.01 s: faults C</title>") != std::string::npos);
  CHECK(svg.find(">" + std::string(31, 'x') + "\u2026<") != std::string::npos);
}
