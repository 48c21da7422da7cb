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
#include "saulproto/host/report/signal_rows.hpp"
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

// Stand-ins for Debian's dygraphs files: the page must carry them inline, whatever they hold.
DygraphsAssets fake_dygraphs() { return {"/* dygraph.min.js */", "/* dygraph.min.css */", "/* synchronizer.js */"}; }

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
  // gnuplot draws each as a dashed vertical arrow on every panel, at the marker's time on the axis.
  const std::string gp = gnuplot_script(doc, "svg", "out.svg");
  const std::size_t panels = doc.panels.size();
  REQUIRE(panels == 5);  // no VESC frames: ERPM is left out, battery comes from 0x401
  CHECK(count_of(gp, "set arrow from ") == 5 * panels);
  for (const char* x : {"0,graph 0 to 0,graph 1", "0.25,graph 0 to 0.25,graph 1", "0.3,graph 0 to 0.3,graph 1",
                        "0.4,graph 0 to 0.4,graph 1", "0.5,graph 0 to 0.5,graph 1"})
    CHECK(count_of(gp, std::string("set arrow from ") + x + " nohead dt 2") == panels);
  CHECK(gp.find("\\n5 state/fault changes, all marked") != std::string::npos);
  CHECK(count_of(gp, "set label '+rc_loss +orin_timeout' at 0.3,graph 0.97 rotate by -90") == panels);
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
    CHECK(gnuplot_script(doc, "png", "").find("\\nVESC ERPM (STATUS): left out") != std::string::npos);
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
  CHECK(plotter.changes().total == 100);
  REQUIRE(plotter.changes().kept.size() == 10);
  CHECK(plotter.changes().kept[9].index == 9);
  const auto doc = plotter.document();
  REQUIRE(doc.markers.size() == 10);
  CHECK(doc.markers[9].t == Approx(0.09));
  CHECK(doc.markers_total == 100);
  const std::string gp = gnuplot_script(doc, "pdf", "out.pdf");
  CHECK(count_of(gp, "set arrow from ") == 10 * doc.panels.size());
  // The lines are 0.01 s apart on a 0.99 s axis, 1.01 % of the width: closer than the 1.2 % a label needs, so
  // every other one is labelled (0, 0.02, ... 0.08).
  CHECK(count_of(gp, "set label ") == 5 * doc.panels.size());
  CHECK(count_of(gp, "set label 'OFF' at 0.02,graph") == doc.panels.size());
  CHECK(count_of(gp, "set label 'BALANCE' at 0.01,graph") == 0);
  CHECK(gp.find("100 state/fault changes: the first 10 are marked, 90 more are not") != std::string::npos);
  const std::string html = render_html(doc, fake_dygraphs());
  CHECK(count_of(html, "<tr class=\"state\">") == 10);
  CHECK(html.find("90 more changes are neither marked nor listed.") != std::string::npos);

  const TelemetryPlotter none(dashboard_request(0), frames_plot_source(frames));
  CHECK(none.changes().total == 100);
  CHECK(none.document().markers.empty());
}

TEST_CASE("plot: the HTML page is self-contained and lists the changes with their times") {
  const std::vector<CanFrame> frames{tele_a(0, 0, RobotState::off), tele_b(0, 0),
                                     tele_a(500, 120, RobotState::balance), tele_b(700, 0x01)};
  PlotRequest request = dashboard_request();
  request.source_name = "run <1> & co.log";
  const TelemetryPlotter plotter(request, frames_plot_source(frames));
  const std::string html = render_html(plotter.document(), fake_dygraphs());
  CHECK(html.starts_with("<!DOCTYPE html>\n"));
  CHECK(html.ends_with("</html>\n"));
  // Nothing fetched: the libraries are inline (here stand-ins), no sources, links or addresses.
  for (const char* bad : {"http", "src=", "href=", "<link", "url(", "@import"}) {
    INFO(bad);
    CHECK(html.find(bad) == std::string::npos);
  }
  CHECK(html.find("<script>\n/* dygraph.min.js */\n</script>") != std::string::npos);
  CHECK(html.find("<script>\n/* synchronizer.js */\n</script>") != std::string::npos);
  CHECK(html.find("<style>\n/* dygraph.min.css */\n</style>") != std::string::npos);
  // A capture timestamp of 10.000000 s is not a date (fewer than 9 digits): the title keeps it as it is.
  CHECK(html.find("<title>run &lt;1&gt; &amp; co.log: telemetry (4 messages from 10.000000)</title>") !=
        std::string::npos);
  CHECK(count_of(html, "<div class=\"panel\" id=\"panel") == plotter.document().panels.size());
  CHECK(html.find("<tr class=\"state\"><td class=\"num\">2</td><td class=\"num\">0.500000</td>"
                  "<td class=\"num\">10.500000</td><td>state</td><td>OFF -&gt; BALANCE</td></tr>") !=
        std::string::npos);
  CHECK(html.find("<tr class=\"faults\"><td class=\"num\">3</td><td class=\"num\">0.700000</td>"
                  "<td class=\"num\">10.700000</td><td>faults</td><td>none -&gt; rc_loss</td></tr>") !=
        std::string::npos);
  // The data: pitch 0 deg at 0 s and 1.2 deg at 0.5 s, then a row without values at the right edge (0.7 s, the
  // last message), so every panel spans the whole run; no date (the title has none).
  CHECK(html.find(R"("labels":["time","0x400"],"rows":[[0.0,0.0],[0.5,1.2],[0.7,null]])") != std::string::npos);
  CHECK(html.find(R"("start_date":null,"start_tod_s":null)") != std::string::npos);
  CHECK(html.find(R"({"detail":"OFF -> BALANCE","kind":"state","label":"BALANCE","t":0.5})") != std::string::npos);
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
        "time_s,pitch,pid_out,speed_mmps,speed_cmd_mmps,wheel_l_rpm,wheel_r_rpm,battery,state,faults\n"
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
    r.fields = {"pitch_raw", "state"};
    const TelemetryPlotter plotter(r, frames_plot_source(frames));
    CHECK_FALSE(plotter.dashboard());
    CHECK(titles(plotter) == std::vector<std::string>{"0x400: pitch_raw", "0x400: state"});
    CHECK(plotter.messages() == 2);
    CHECK(plotter.points_span_s() == Approx(0.1));
    std::ostringstream out;
    plotter.write_csv(out);
    CHECK(out.str() == "time_s,pitch_raw,state\n0.000000,21,1\n0.100000,-5,1\n");
    CHECK(plotter.document().markers.size() == 1);  // BALANCE, first seen
  }
  SECTION("by name, in the unit: pitch in degrees") {
    PlotRequest r;
    r.id = "telemetry_a";
    r.fields = {"pitch"};
    const TelemetryPlotter plotter(r, frames_plot_source(frames));
    std::ostringstream out;
    plotter.write_csv(out);
    CHECK(out.str() == "time_s,pitch\n0.000000,0.21\n0.100000,-0.05\n");
  }
  SECTION("by name, no fields: every number signal of the message in its unit") {
    PlotRequest r;
    r.id = "telemetry_a";
    const TelemetryPlotter plotter(r, frames_plot_source(frames));
    CHECK(titles(plotter) == std::vector<std::string>{"telemetry_a: pitch", "telemetry_a: pid_out",
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
    r.fields = {"pitch_x100"};
    try {
      TelemetryPlotter plotter(r, frames_plot_source(frames));
      FAIL("no error");
    } catch (const PlotUsageError& e) {
      CHECK(std::string(e.what()) ==
            "'0x400' (telemetry_a) has no signal 'pitch_x100'; its signals: pitch, pitch_raw, pid_out, speed_mmps, "
            "state");
    }
    r.fields = {};
    r.id = "0x40z";
    CHECK_THROWS_AS(TelemetryPlotter(r, frames_plot_source(frames)), PlotUsageError);
    r.id = "0x401";
    r.source_name = "x.log";
    CHECK_THROWS_WITH(TelemetryPlotter(r, frames_plot_source(frames)), "no '0x401' in x.log");
    PlotRequest fields_only;
    fields_only.fields = {"pitch"};
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

TEST_CASE("plot: every dashboard series names a real signal of its message") {
  const std::vector<saul::BusMessage> bus{saulcan::TelemetryA{}, saulcan::TelemetryB{}, saulcan::VelocityCmd{},
                                          vesc::Status1{}, vesc::Status5{}};
  const SerialMessage state = interboard::Message{interboard::State{}};
  for (const auto& panel : dashboard_panels())
    for (const auto& s : panel.series) {
      INFO(panel.title << ": " << s.message << "." << s.field);
      bool found = false;
      for (const auto& m : bus)
        if (s.message == saul::name_of(m)) found = signal_value(signal_values(m), s.field).has_value();
      if (s.message == name_of(state)) found = signal_value(signal_values(state), s.field).has_value();
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

TEST_CASE("plot: binning that keeps spikes") {
  PlotBinner binner(0, 10, 5);  // 2 s per column
  for (int i = 0; i < 1000; ++i) binner.add(i * 0.01, 1.0);
  binner.add(4.5, 99.0);  // one spike in the third column
  binner.add(11, 2.0);    // past the end: the last column
  CHECK(binner.count() == 1002);
  CHECK(binner.max() == 99.0);
  const auto points = binner.points();
  CHECK(points.size() <= 5 * 4);
  bool spike = false;
  for (const auto& p : points) spike = spike || (p.v == 99.0 && p.t == 4.5);
  CHECK(spike);
  for (std::size_t i = 1; i < points.size(); ++i) CHECK(points[i - 1].t <= points[i].t);
}

TEST_CASE("plot: capture timestamps in titles become dates") {
  // 1763800000 s after 1970-01-01 is 2025-11-22 08:26:40 UTC (20414 days, then 30400 s = 8 h 26 min 40 s).
  CHECK(start_time_in_title("run.log: telemetry (3 messages from 1763800000.500900)") ==
        Approx(1763800000.5009).epsilon(1e-15));
  CHECK_FALSE(start_time_in_title("run.log: telemetry (3 messages from an untimed capture)"));
  CHECK_FALSE(start_time_in_title("run.log: 0x400 (3 messages from 10.000000)"));  // not a date
  CHECK(human_time(1763800000.5009) == "2025-11-22 08:26:40.501 UTC");
  CHECK(human_time(1763800000.9996) == "2025-11-22 08:26:41.000 UTC");  // rounds into the next second
  CHECK(human_title("run.log: telemetry (3 messages from 1763800000.500900)") ==
        "run.log: telemetry (3 messages from 2025-11-22 08:26:40.501 UTC)");
}

TEST_CASE("plot: the gnuplot script carries the data, the terminal and every label quoted") {
  PlotDocument doc;
  doc.title = "it's \"run\".log: telemetry (2 messages from 1763800000.000000)";
  doc.t0 = 0;
  doc.t1 = 2;
  PlotBinner a(0, 2, 10), b(0, 2, 10);
  a.add(0, 1.5);
  a.add(2, -0.25);
  b.add(1, 7);
  PlotPanel panel;
  panel.title = "speed [mm/s]";
  panel.series.push_back(PlotSeries{"reported", a});
  panel.series.push_back(PlotSeries{"o'clock", b});
  doc.panels.push_back(panel);
  doc.markers.push_back(PlotMarker{1, MarkerKind::state, "BALANCE", "OFF -> BALANCE", ""});
  doc.markers_total = 1;
  doc.notes = {"battery [V]: left out"};
  const std::string svg = gnuplot_script(doc, "svg", "/tmp/a'b.svg");
  CHECK(svg.starts_with("# saulctl plot: it's \"run\".log: telemetry (2 messages from 2025-11-22 08:26:40.000 "
                        "UTC)\nset terminal svg size 1200,350 dynamic"));
  CHECK(svg.find("\nset output '/tmp/a''b.svg'\n") != std::string::npos);
  // One datablock for the panel, the two series two blank lines apart (gnuplot's "index").
  CHECK(svg.find("$panel0 << EOD\n0.000000 1.5\n2.000000 -0.25\n\n\n1.000000 7\nEOD\n") != std::string::npos);
  CHECK(svg.find("set multiplot layout 1,1 title \"it's \\\"run\\\".log: telemetry (2 messages from 2025-11-22 "
                 "08:26:40.000 UTC)\\n1 state/fault change, all marked\\nbattery [V]: left out\"") != std::string::npos);
  CHECK(svg.find("set xlabel 'time since 08:26:40.000 UTC [s]'") != std::string::npos);
  CHECK(svg.find("set arrow from 1,graph 0 to 1,graph 1 nohead dt 2 lw 1 lc rgb '#7b3fb5'") != std::string::npos);
  // Told apart by colour, dash pattern and width; sparse series with their points.
  CHECK(svg.find("plot $panel0 index 0 using 1:2 with linespoints pt 7 ps 0.6 lw 2 dt 1 lc rgb '#1f77b4' title "
                 "'reported', \\\n     $panel0 index 1 using 1:2 with linespoints pt 7 ps 0.6 lw 1.5 dt 2 lc rgb "
                 "'#d62728' title 'o''clock'\n") != std::string::npos);
  CHECK(svg.ends_with("unset multiplot\n"));
  CHECK(gnuplot_script(doc, "png", "").find("set terminal pngcairo size 1600,410 ") != std::string::npos);
  CHECK(gnuplot_script(doc, "png", "").find("set output") == std::string::npos);  // standard output
  CHECK(gnuplot_script(doc, "pdf", "x.pdf").find("set terminal pdfcairo size 11.7in,3.30in ") != std::string::npos);
}
