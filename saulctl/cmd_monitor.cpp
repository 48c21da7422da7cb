// saulctl monitor: the robot's telemetry at a glance. On a terminal a full-screen view (tui.hpp) that fits 80x24,
// marks what is stale, says when the link is lost and takes keys (e = ESTOP); otherwise plain lines, or one JSON
// line per telemetry update.
#include <fmt/core.h>

#include <array>
#include <deque>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/vesc.hpp"
#include "saulproto/host/report/bus_stats.hpp"
#include "saulproto/host/report/format.hpp"
#include "tui.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;
namespace sc = saul::saulcan;
using tui::Style;

struct MonitorOptions {
  std::string link;
  std::string duration;
  bool json = false;
  bool listen_only = false;
};

/// One periodic frame kind: when it came, how often (over the last second), and whether it is stale (older than
/// three periods: the nominal one, or the one seen when it comes faster).
class Stream {
 public:
  explicit Stream(milliseconds nominal) : nominal_(nominal) {}
  void seen(steady_clock::time_point t) {
    last_ = t;
    times_.push_back(t);
    ++count_;
  }
  double rate(steady_clock::time_point now) {
    while (!times_.empty() && now - times_.front() > seconds(1)) times_.pop_front();
    return static_cast<double>(times_.size());
  }
  [[nodiscard]] bool stale(steady_clock::time_point now) const { return last_ && now - *last_ > 3 * period(); }
  [[nodiscard]] std::string age(steady_clock::time_point now) const {
    if (!last_) return "never";
    const auto ms = duration_cast<milliseconds>(now - *last_).count();
    return ms < 10'000 ? fmt::format("{} ms ago", ms) : fmt::format("{} s ago", ms / 1000);
  }
  [[nodiscard]] std::uint64_t count() const { return count_; }

 private:
  [[nodiscard]] milliseconds period() const {
    if (times_.size() >= 3) {
      const auto seen_period = duration_cast<milliseconds>((times_.back() - times_.front()) / (times_.size() - 1));
      if (seen_period < nominal_ && seen_period.count() > 0) return seen_period;
    }
    return nominal_;
  }
  milliseconds nominal_;
  std::optional<steady_clock::time_point> last_;
  std::deque<steady_clock::time_point> times_;
  std::uint64_t count_ = 0;
};

std::string fault_names(std::uint8_t faults) {
  if (faults == 0) return "none";
  std::string s;
  for (unsigned b = 0; b < 8; ++b)
    if (faults & (1U << b)) s += (s.empty() ? "" : ",") + std::string(sc::fault::bit_name(b));
  return s;
}

Style state_style(sc::RobotState s) {
  using S = sc::RobotState;
  if (s == S::balance || s == S::manual) return Style::good;
  return s == S::estop || s == S::tilt_cutoff || s == S::fault ? Style::bad : Style::normal;
}

/// One VESC's status frames (STATUS_1, _4, _5).
struct Vesc {
  Vesc(std::uint8_t controller, const char* which) : id(controller), side(which) {}
  std::uint8_t id;
  const char* side;
  std::optional<saul::vesc::Status1> s1;
  std::optional<saul::vesc::Status4> s4;
  std::optional<saul::vesc::Status5> s5;
  Stream stream{milliseconds(100)};
};

/// Everything the views show, fed frame by frame.
struct Telemetry {
  std::optional<sc::TelemetryA> a;
  std::optional<sc::TelemetryB> b;
  std::optional<sc::VelocityCmd> vel;
  Stream sa{milliseconds(100)}, sb{milliseconds(100)}, svel{milliseconds(50)};  // 10 Hz, 10 Hz, 20 Hz
  std::array<Vesc, 2> vesc{Vesc{saul::vesc::kLeftId, "L"}, Vesc{saul::vesc::kRightId, "R"}};
  std::string last_error;
  std::deque<std::pair<steady_clock::time_point, unsigned>> bits;  ///< the last second's frames, for the load
  std::optional<steady_clock::time_point> last_frame;
  std::uint64_t frames = 0;

  /// True when telemetry A or B changed.
  bool add(const saul::CanFrame& f, steady_clock::time_point t) {
    ++frames;
    last_frame = t;
    bits.emplace_back(t, saul::host::can_frame_bits(f, saul::host::StuffBits::worst_case));
    if (f.error) {
      last_error = saul::host::describe_error_frame(f);
      return false;
    }
    if (auto m = sc::decode_telemetry_a(f)) {
      a = *m;
      sa.seen(t);
      return true;
    }
    if (auto m = sc::decode_telemetry_b(f)) {
      b = *m;
      sb.seen(t);
      return true;
    }
    if (auto m = sc::decode_velocity_cmd(f)) {
      vel = *m;
      svel.seen(t);
      return false;
    }
    for (auto& v : vesc) {
      if (auto m = saul::vesc::decode_status_1(f); m && m->controller_id == v.id) {
        v.s1 = *m;
        v.stream.seen(t);
      } else if (auto m4 = saul::vesc::decode_status_4(f); m4 && m4->controller_id == v.id) {
        v.s4 = *m4;
      } else if (auto m5 = saul::vesc::decode_status_5(f); m5 && m5->controller_id == v.id) {
        v.s5 = *m5;
      }
    }
    return false;
  }

  double load_percent(steady_clock::time_point now, std::uint32_t bitrate) {
    while (!bits.empty() && now - bits.front().first > seconds(1)) bits.pop_front();
    std::uint64_t sum = 0;
    for (const auto& [t, n] : bits) sum += n;
    return 100.0 * static_cast<double>(sum) / static_cast<double>(bitrate);
  }
};

double unix_seconds() { return static_cast<double>(saul::host::realtime_ns()) / 1e9; }

nlohmann::json json_line(Telemetry& tm, steady_clock::time_point t) {
  return nlohmann::json{{"time", unix_seconds()},
                        {"state", sc::to_string(tm.a->state)},
                        {"pitch", tm.a->pitch_x100 / 100.0},
                        {"pid_out", tm.a->pid_out},
                        {"speed_mmps", tm.a->speed_mmps},
                        {"vesc_l_rpm", tm.b->vesc_l_rpm},
                        {"vesc_r_rpm", tm.b->vesc_r_rpm},
                        {"battery", tm.b->battery_mv / 1000.0},
                        {"fault", fault_names(tm.b->faults)},
                        {"rate_400_hz", tm.sa.rate(t)},
                        {"rate_401_hz", tm.sb.rate(t)}};
}

/// The full-screen view: fits 80x24 (rows 0..15 and the last two lines), uses what more there is.
constexpr int kRateColumn = 50;  ///< where the streams' rate and age go, right of the values
void draw(tui::Screen& s, Telemetry& tm, const saul::host::CanLink& link, const ViewCommands& keys,
          const std::string& lost, std::uint32_t bitrate, steady_clock::time_point now) {
  s.begin();
  const int w = s.width();
  const int h = s.height();
  const auto st = link.stats();
  int c = s.put(0, 0, "SAUL-TEE monitor  ", Style::title);
  c = s.put(0, c, link.name());
  if (const auto how = link.sharing(); !how.empty()) s.put(0, c, "  (" + how + ")", Style::dim);

  c = s.put(1, 0, "bus ", Style::dim);
  c = s.put(1, c, saul::host::to_string(st.state), bus_style(st.state));
  c = s.put(1, c, fmt::format("  load {:4.1f} %", tm.load_percent(now, bitrate)));
  c = s.put(1, c, fmt::format("  rx {} tx {}", st.rx_frames, st.tx_frames), Style::dim);
  c = s.put(1, c, fmt::format("  dropped {}", st.rx_dropped), st.rx_dropped ? Style::warn : Style::dim);
  s.put(1, c, fmt::format("  error frames {}", st.error_frames), st.error_frames ? Style::warn : Style::dim);
  if (!lost.empty()) {
    s.put(2, 0, "LINK LOST: " + lost, Style::bad);
  } else if (tm.last_frame && now - *tm.last_frame > seconds(1)) {
    s.put(2, 0, fmt::format("no frame for {} s: is the robot powered and on the bus?",
                            duration_cast<seconds>(now - *tm.last_frame).count()),
          Style::warn);
  } else if (!tm.last_frame) {
    s.put(2, 0, "no frame yet", Style::warn);
  }

  // Telemetry A: the state first, big and coloured.
  const bool a_stale = tm.sa.stale(now);
  c = s.put(4, 0, "STATE  ", Style::dim);
  if (tm.a) {
    c = s.put(4, c, fmt::format("{:<12}", sc::to_string(tm.a->state)), state_style(tm.a->state));
    s.put(4, kRateColumn, fmt::format("0x400 {:3.0f} Hz {}{}", tm.sa.rate(now), tm.sa.age(now), a_stale ? " STALE" : ""),
          a_stale ? Style::warn : Style::dim);
    s.put(5, 0, fmt::format("pitch {:+7.2f} deg   pid_out {:+5}   speed {:+6} mm/s", tm.a->pitch_x100 / 100.0,
                            tm.a->pid_out, tm.a->speed_mmps),
          a_stale ? Style::dim : Style::normal);
  } else {
    s.put(4, c, "no telemetry A (0x400) yet", Style::warn);
  }
  const bool b_stale = tm.sb.stale(now);
  if (tm.b) {
    s.put(6, 0, fmt::format("wheels L {:+6} R {:+6} rpm   battery {:5.2f} V", tm.b->vesc_l_rpm, tm.b->vesc_r_rpm,
                            tm.b->battery_mv / 1000.0),
          b_stale ? Style::dim : Style::normal);
    s.put(6, kRateColumn, fmt::format("0x401 {:3.0f} Hz {}{}", tm.sb.rate(now), tm.sb.age(now), b_stale ? " STALE" : ""),
          b_stale ? Style::warn : Style::dim);
    c = s.put(7, 0, "faults ", Style::dim);
    if (tm.b->faults == 0) s.put(7, c, "none", Style::good);
    for (unsigned bit = 0; bit < 8; ++bit)
      if (tm.b->faults & (1U << bit)) c = s.put(7, c, std::string(sc::fault::bit_name(bit)) + " ", Style::bad);
  } else {
    s.put(6, 0, "wheels: no telemetry B (0x401) yet", Style::warn);
  }

  // The VESCs' own status frames.
  s.put(9, 0, "VESC        ERPM  current   duty  FET C  motor C   V in  age", Style::dim);
  for (std::size_t i = 0; i < tm.vesc.size(); ++i) {
    auto& v = tm.vesc[i];
    const int row = 10 + static_cast<int>(i);
    c = s.put(row, 0, fmt::format("{} {:3}", v.side, v.id));
    if (!v.s1) {
      s.put(row, c, "  no status frames", Style::dim);
      continue;
    }
    const bool stale = v.stream.stale(now);
    c = s.put(row, c, fmt::format(" {:+8} {:+7.1f}A {:+6.2f}", v.s1->erpm, v.s1->current(), v.s1->duty()),
              stale ? Style::dim : Style::normal);
    c = s.put(row, c, v.s4 ? fmt::format(" {:6.1f} {:8.1f}", v.s4->temp_fet(), v.s4->temp_motor()) : "      -        -",
              stale ? Style::dim : Style::normal);
    c = s.put(row, c, v.s5 ? fmt::format(" {:6.1f}", v.s5->voltage_in()) : "      -", stale ? Style::dim : Style::normal);
    s.put(row, c, "  " + v.stream.age(now) + (stale ? " STALE" : ""), stale ? Style::warn : Style::dim);
  }

  c = s.put(13, 0, "orin   ", Style::dim);
  if (tm.vel) {
    const bool stale = tm.svel.stale(now);
    s.put(13, c, fmt::format("velocity {:+5} mm/s  steer {:+5} mrad   {:3.0f} Hz {}{}", tm.vel->speed_mmps,
                             tm.vel->steer_mrad, tm.svel.rate(now), tm.svel.age(now), stale ? " STALE" : ""),
          stale ? Style::warn : Style::normal);
  } else {
    s.put(13, c, "no velocity commands (0x300)", Style::dim);
  }
  if (!tm.last_error.empty()) s.put(15, 0, "last bus error: " + tm.last_error, Style::warn);

  if (const auto status = keys.status(); !status.empty()) s.put(h - 2, 0, status, keys.status_style());
  s.put(h - 1, 0, ViewCommands::help(), Style::inverse);
  if (w > 60) s.put(h - 1, w - 20, fmt::format("{:>19}", fmt::format("{} frames", tm.frames)), Style::dim);
  s.show();
}

std::string plain_line(Telemetry& tm, const saul::host::CanLink& link, steady_clock::time_point now) {
  std::string line = fmt::format("{:.3f} {}", unix_seconds(), saul::host::to_string(link.stats().state));
  if (tm.a)
    line += fmt::format(" state={} pitch={:+.2f} pid_out={} speed={} 400={:.0f}Hz{}", sc::to_string(tm.a->state),
                        tm.a->pitch_x100 / 100.0, tm.a->pid_out, tm.a->speed_mmps, tm.sa.rate(now),
                        tm.sa.stale(now) ? "(stale)" : "");
  if (tm.b)
    line += fmt::format(" rpm={}/{} battery={:.2f}V faults={} 401={:.0f}Hz{}", tm.b->vesc_l_rpm, tm.b->vesc_r_rpm,
                        tm.b->battery_mv / 1000.0, fault_names(tm.b->faults), tm.sb.rate(now),
                        tm.sb.stale(now) ? "(stale)" : "");
  if (!tm.a && !tm.b) line += " no telemetry yet";
  return line;
}

int run_monitor(const MonitorOptions& opt) {
  const auto spec = resolve_link(opt.link);
  std::unique_ptr<saul::host::CanLink> link = saul::host::open_can_link(spec, {.listen_only = opt.listen_only});
  const std::uint32_t bitrate = spec.kind == saul::host::LinkSpec::Kind::slcan ? spec.bitrate : 500'000;
  LiveView view(*link, opt.json);
  Telemetry tm;
  const auto start = steady_clock::now();
  auto next_draw = start;
  auto next_plain = start;
  std::optional<sc::RobotState> printed_state;
  const auto frame = [&](const saul::CanFrame& f) {
    const auto t = steady_clock::now();
    if (tm.add(f, t) && opt.json && tm.a && tm.b) {
      fmt::print("{}\n", json_line(tm, t).dump());
      std::fflush(stdout);
    }
    return true;
  };
  const auto tick = [&](steady_clock::time_point t) {
    if (view.screen) {
      if (t >= next_draw) {
        draw(*view.screen, tm, *link, *view.keys, view.lost, bitrate, t);
        next_draw = t + milliseconds(100);
      }
    } else if (!opt.json) {
      // Plain lines: one a second, and at once when the state changes.
      const bool changed = tm.a && (!printed_state || *printed_state != tm.a->state);
      if (t >= next_plain || changed) {
        fmt::print("{}\n", plain_line(tm, *link, t));
        std::fflush(stdout);
        next_plain = t + seconds(1);
        if (tm.a) printed_state = tm.a->state;
      }
    }
  };
  const int status = view.run(link, opt.duration, frame, tick,
                              [&] { return saul::host::open_can_link(spec, {.listen_only = opt.listen_only}); });
  view.screen.reset();  // back to the normal terminal before the summary
  if (view.keys) {  // there was a view
    const auto st = link->stats();
    const double secs = duration<double>(steady_clock::now() - start).count();
    fmt::print("monitor: {:.1f} s on {}, {} frames, last state {}\n", secs, link->name(), tm.frames,
               tm.a ? sc::to_string(tm.a->state) : "-");
    fmt::print("monitor: 0x400 {} frames, 0x401 {}; link rx {} tx {} dropped {}\n", tm.sa.count(), tm.sb.count(),
               st.rx_frames, st.tx_frames, st.rx_dropped);
    if (const auto k = view.keys->summary(); !k.empty()) fmt::print("monitor: {}\n", k);
    if (!view.lost.empty()) say("link lost: {}", view.lost);
  }
  return status;
}

}  // namespace

void add_monitor_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<MonitorOptions>(
      app, run, "monitor", "Live telemetry view: state, pitch, speeds, battery, faults, VESCs, rates", run_monitor);
  add_link_option(cmd, o->link);
  add_duration_option(cmd, o->duration, "stop after this long; default: until Ctrl-C or q");
  cmd->add_flag("--json", o->json, "one JSON line per telemetry update (with a Unix time) instead of the view");
  cmd->add_flag("--listen-only", o->listen_only, "slcan: open the adapter silent");
  cmd->footer(
      "\nOn a terminal: a full-screen view; a stream older than three periods is marked STALE, a lost link is said\n"
      "so. Keys: e or space = ESTOP (always, at once), o = mode off, q = quit; a summary on exit. Not on a terminal:\n"
      "one plain line a second (and on every state change).\n"
      "\nExamples:\n  saulctl monitor --link can0\n"
      "  saulctl monitor --json --duration 10s --link slcan:/dev/ttyACM0 > run.jsonl\n");
}

}  // namespace saulctl
