// saulctl sniff: live decode of everything on a CAN link or a serial byte link.
#include <fmt/core.h>

#include <array>
#include <map>
#include <memory>

#include "commands.hpp"
#include "grammar.hpp"
#include "live.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/host/report/bus_stats.hpp"
#include "saulproto/host/report/fast_emit.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/frame_text.hpp"
#include "tui.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;

struct SniffOptions {
  std::string link;
  std::vector<std::string> filters;
  std::uint64_t count = 0;
  std::string duration;
  std::string time = "abs";
  std::string protocol = "interboard";
  bool json = false;
  bool listen_only = false;
  bool top = false;
};

// The filters go in at open (SocketCAN: in the kernel), so not one frame of another id is printed. Paced: every
// frame is printed, so a burst waits in the adapter rather than being dropped here.
std::unique_ptr<saul::host::CanLink> open_filtered(const SniffOptions& opt, const saul::host::LinkSpec& spec) {
  return saul::host::open_can_link(
      spec, {.listen_only = opt.listen_only, .filters = id_filters(opt.filters), .paced = true});
}

int sniff_can(const SniffOptions& opt, const saul::host::LinkSpec& spec) {
  auto link = open_filtered(opt, spec);
  const auto start = steady_clock::now();
  saul::host::TimeColumn column(time_mode(opt.time));
  std::uint64_t shown = 0;
  auto state = link->stats().state;
  if (!opt.json) {
    const std::string shared = link->sharing();
    fmt::print(stderr, "sniff: listening on {} (timestamps: {}{}); Ctrl-C to stop\n", link->name(),
               saul::host::to_string(link->timestamp_source()), shared.empty() ? "" : "; " + shared);
  }
  // decode's lines (FrameEmitter), error frames with what they report, written once the link has nothing more
  // queued (or the buffer is large): a burst of frames costs one write, a lone frame still shows at once.
  saul::host::FrameEmitter emit(opt.json ? saul::host::DecodeFormat::jsonl : saul::host::DecodeFormat::text,
                                time_mode(opt.time));
  emit.show_error_detail();
  saul::host::DecodeCounts counts;
  fmt::memory_buffer out;
  auto flush = [&out] {
    std::fwrite(out.data(), 1, out.size(), stdout);
    std::fflush(stdout);
    out.clear();
  };
  // The controller state is looked at when the link is idle, at every error frame (SocketCAN reports its changes
  // with them), every 64 frames and at the end: it takes the link's locks.
  auto check_state = [&] {
    const auto now_state = link->stats().state;
    if (now_state == state) return;
    // Controller state changes are always shown, loudly, with the time they were seen.
    flush();
    fmt::print(stderr, "sniff: {} controller state {} -> {}\n", column(saul::host::realtime_ns()),
               saul::host::to_string(state), saul::host::to_string(now_state));
    state = now_state;
  };
  const int status = report_errors([&] {
    receive_until(opt.duration, start, opt.count, shown, [&](milliseconds wait) {
      auto f = link->receive(out.size() != 0 ? milliseconds(0) : wait);
      if (!f) {
        if (out.size() != 0) flush();
        check_state();
        return;
      }
      if (f->error || shown % 64 == 0) check_state();
      if (!f->timestamp_ns) f->timestamp_ns = saul::host::realtime_ns();
      column.note(*f->timestamp_ns);  // a state change's time in --time rel/delta counts from the frames
      emit.add(*f, link->name(), out, counts);
      ++shown;
      if (out.size() >= (1 << 16)) flush();
    });
    check_state();  // a change the last frames brought (-n reached) is still shown
  });
  flush();
  const auto s = link->stats();
  fmt::print(stderr, "sniff: {} frames shown; link rx {} tx {} dropped {} error frames {} bus-off {} state {}{}\n", shown,
             s.rx_frames, s.tx_frames, s.rx_dropped, s.error_frames, s.bus_off_events, saul::host::to_string(s.state),
             s.filtered_late ? fmt::format("; {} frames of other ids came past the kernel filter and were dropped",
                                           s.filtered_late)
                             : "");
  return status;
}

// --top: one row per id, a full-screen view on a terminal (tui.hpp, redrawn ten times a second); the table printed
// once at the end in any case.
struct TopRow {
  std::array<std::uint8_t, 8> data{};
  std::array<std::uint8_t, 8> previous{};
  std::uint8_t dlc = 0;
  std::uint64_t frames = 0;  ///< changes are marked from the second frame on
  [[nodiscard]] bool changed(std::size_t i) const { return frames > 1 && data[i] != previous[i]; }
};

double whole_run_load(const saul::host::BusStats& stats) {
  double load = 0;
  for (const auto& [name, l] : stats.interfaces()) load = stats.load_percent(l, saul::host::StuffBits::worst_case);
  return load;
}

std::string top_table(const saul::host::BusStats& stats, const std::map<saul::host::BusStats::IdKey, TopRow>& rows,
                      const std::string& link_name, double recent_load) {
  std::string out;
  const double load = whole_run_load(stats);
  out += fmt::format("{}: {} frames, {} error frames, bus load {:.1f} % (whole run), {:.1f} % (last interval), "
                     "stuff bits worst case at {} bit/s\n",
                     link_name, stats.frames(), stats.error_frames(), load, recent_load, stats.options().bitrate);
  out += fmt::format("{:>8}  {:<18} {:>8} {:>8} {:>10} {:>10}  {}\n", "ID", "TYPE", "COUNT", "RATE/Hz", "PERIOD/ms",
                     "JITTER/ms", "LAST DATA (* changed)");
  for (const auto& [key, st] : stats.ids()) {
    const auto it = rows.find(key);
    std::string data;
    if (it != rows.end()) {
      const TopRow& r = it->second;
      for (std::size_t i = 0; i < r.dlc && i < 8; ++i) {
        if (!data.empty()) data += ' ';
        data += fmt::format("{:02X}{}", r.data[i], r.changed(i) ? "*" : "");
      }
    }
    const auto& c = st.cadence;
    out += fmt::format("{:>8}  {:<18} {:>8} {:>8.1f} {:>10.2f} {:>10.2f}  {}\n",
                       key.first ? fmt::format("{:08X}", key.second) : fmt::format("{:03X}", key.second), st.type,
                       c.count, c.rate_hz(), c.mean_gap_ns() / 1e6, c.jitter_ns() / 1e6, data);
  }
  return out;
}

// The full-screen --top: the same table, columns narrowed to the terminal (80 columns: no jitter, a shorter type),
// changed bytes in reverse video, error frames and a bad bus state in red, and the view's keys.
void draw_top(tui::Screen& s, const saul::host::BusStats& stats,
              const std::map<saul::host::BusStats::IdKey, TopRow>& rows, const saul::host::CanLink& link,
              double recent_load, const ViewCommands& keys, const std::string& lost) {
  using tui::Style;
  s.begin();
  const int w = s.width();
  const int h = s.height();
  const bool wide = w >= 100;
  const auto st = link.stats();
  int c = s.put(0, 0, "sniff --top  ", Style::title);
  c = s.put(0, c, link.name());
  if (const auto how = link.sharing(); !how.empty()) s.put(0, c, "  (" + how + ")", Style::dim);
  c = s.put(1, 0, fmt::format("{} frames  ", stats.frames()));
  c = s.put(1, c, fmt::format("{} error frames", stats.error_frames()), stats.error_frames() ? Style::bad : Style::normal);
  c = s.put(1, c, fmt::format("  load {:.1f} % now, {:.1f} % whole run  bus ", recent_load, whole_run_load(stats)));
  s.put(1, c, saul::host::to_string(st.state), bus_style(st.state));
  if (!lost.empty()) s.put(2, 0, "LINK LOST: " + lost, Style::bad);
  const int type_w = wide ? 18 : 14;
  s.put(3, 0, wide ? fmt::format("{:>8} {:<18} {:>8} {:>8} {:>9} {:>9}  {}", "ID", "TYPE", "COUNT", "RATE/Hz",
                                 "PERIOD/ms", "JITTER/ms", "LAST DATA")
                   : fmt::format("{:>8} {:<14} {:>7} {:>7} {:>9}  {}", "ID", "TYPE", "COUNT", "RATE/Hz", "PERIOD/ms",
                                 "LAST DATA"),
        Style::dim);
  int row = 4;
  const int last_row = h - 3;
  std::size_t left = stats.ids().size();
  for (const auto& [key, ist] : stats.ids()) {
    if (row > last_row || (row == last_row && left > 1)) {
      s.put(row, 0, fmt::format("... {} more ids (a taller terminal shows them)", left), Style::dim);
      break;
    }
    --left;
    const auto& cad = ist.cadence;
    const std::string id = key.first ? fmt::format("{:08X}", key.second) : fmt::format("{:>8}", fmt::format("{:03X}", key.second));
    std::string type = ist.type.substr(0, static_cast<std::size_t>(type_w));
    const bool error = ist.type.find("error") != std::string::npos;
    c = s.put(row, 0, wide ? fmt::format("{:>8} {:<18} {:>8} {:>8.1f} {:>9.2f} {:>9.2f}  ", id, type, cad.count,
                                         cad.rate_hz(), cad.mean_gap_ns() / 1e6, cad.jitter_ns() / 1e6)
                           : fmt::format("{:>8} {:<14} {:>7} {:>7.1f} {:>9.2f}  ", id, type, cad.count, cad.rate_hz(),
                                         cad.mean_gap_ns() / 1e6),
              error ? Style::bad : Style::normal);
    if (const auto it = rows.find(key); it != rows.end()) {
      const TopRow& r = it->second;
      for (std::size_t i = 0; i < r.dlc && i < 8; ++i) {
        c = s.put(row, c, fmt::format("{:02X}", r.data[i]), r.changed(i) ? Style::inverse : Style::normal);
        c = s.put(row, c, " ");
      }
    }
    ++row;
  }
  if (const auto status = keys.status(); !status.empty()) s.put(h - 2, 0, status, keys.status_style());
  s.put(h - 1, 0, ViewCommands::help(), Style::inverse);
  s.show();
}

int sniff_top(const SniffOptions& opt, const saul::host::LinkSpec& spec) {
  auto link = open_filtered(opt, spec);
  LiveView view(*link, false);
  saul::host::BusStatsOptions bo;
  bo.bitrate = spec.kind == saul::host::LinkSpec::Kind::slcan ? spec.bitrate : 500'000;
  saul::host::BusStats stats(bo);
  std::map<saul::host::BusStats::IdKey, TopRow> rows;
  auto interval_start = steady_clock::now();
  auto next_draw = interval_start;
  std::uint64_t interval_bits = 0;
  double recent_load = 0;
  std::uint64_t shown = 0;
  const auto frame = [&](const saul::CanFrame& received) {
    saul::CanFrame f = received;
    if (!f.timestamp_ns) f.timestamp_ns = saul::host::realtime_ns();
    stats.add(f, link->name());
    ++shown;
    if (!f.error) {
      interval_bits += saul::host::can_frame_bits(f, saul::host::StuffBits::worst_case);
      TopRow& r = rows[{f.extended, f.id}];
      ++r.frames;
      r.previous = r.data;
      r.data = f.data;
      r.dlc = f.remote ? 0 : f.dlc;
    }
    return opt.count == 0 || shown < opt.count;
  };
  const auto tick = [&](steady_clock::time_point now) {
    if (now < next_draw) return;
    // The load of the last half second or more (0 before the first).
    if (const double secs = duration<double>(now - interval_start).count(); secs >= 0.5) {
      recent_load = 100.0 * static_cast<double>(interval_bits) / (secs * static_cast<double>(bo.bitrate));
      interval_bits = 0;
      interval_start = now;
    }
    next_draw = now + milliseconds(view.screen ? 100 : 500);
    if (view.screen) draw_top(*view.screen, stats, rows, *link, recent_load, *view.keys, view.lost);
  };
  const int status = view.run(link, opt.duration, frame, tick);
  view.screen.reset();
  if (view.keys && !view.keys->summary().empty()) fmt::print("sniff: {}\n", view.keys->summary());  // there was a view
  view.keys.reset();
  if (!view.lost.empty()) say("link lost: {}", view.lost);
  // The table once more, in plain text: what a terminal keeps after the view, or all a pipe gets.
  fmt::print("{}", top_table(stats, rows, link->name(), recent_load));
  std::fflush(stdout);
  return status;
}

int sniff_serial(const SniffOptions& opt, const saul::host::LinkSpec& spec) {
  auto port = saul::host::open_serial_link(spec);
  const auto start = steady_clock::now();
  saul::host::TimeColumn column(time_mode(opt.time));
  saul::interboard::StreamDecoder decoder;
  std::uint64_t shown = 0;
  if (!opt.json)
    fmt::print(stderr, "sniff: {} bytes on {} ({} {}); Ctrl-C to stop\n", opt.protocol, port->path(),
               spec.serial.baud, saul::host::to_string(spec.serial));
  const int status = report_errors([&] {
    std::array<std::uint8_t, 4096> buf{};
    receive_until(opt.duration, start, opt.count, shown, [&](milliseconds wait) {
      const std::size_t n = port->read(buf, wait);
      const std::string t = column(saul::host::realtime_ns());
      for (std::size_t i = 0; i < n && (opt.count == 0 || shown < opt.count); ++i) {
        const auto m = decoder.push(buf[i]);
        if (!m) continue;
        ++shown;
        if (opt.json) {
          nlohmann::json j{{"time", saul::host::TimeColumn::bare(t)}, {"link", spec.text()},
                           {"message", saul::host::to_json(*m)}};
          fmt::print("{}\n", saul::host::json_line(j));
        } else {
          fmt::print("{} {} {}\n", t, port->path(), saul::host::describe(*m));
        }
      }
      std::fflush(stdout);
    });
  });
  const auto& c = decoder.counters();
  fmt::print(stderr, "sniff: {} frames; crc errors {}, length errors {}, unknown types {}, bytes skipped {}\n",
             c.frames, c.crc_errors, c.length_errors, c.unknown_types, c.bytes_skipped);
  return status;
}

int run_sniff(const SniffOptions& opt) {
  const auto spec = resolve_link(opt.link);
  if (opt.top) {
    if (!spec.is_can()) throw CLI::ValidationError("--top", "--top is for CAN links (can0, slcan:...)");
    return sniff_top(opt, spec);
  }
  return spec.is_can() ? sniff_can(opt, spec) : sniff_serial(opt, spec);
}

}  // namespace

void add_sniff_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<SniffOptions>(app, run, "sniff", "Live decode of a CAN bus or a serial link", run_sniff);
  add_link_option_and_positional(cmd, o->link);
  add_id_option(cmd, o->filters, "only these ids");
  cmd->add_option("-n,--count", o->count, "stop after this many frames");
  add_duration_option(cmd, o->duration, "stop after this long");
  cmd->add_option("-t,--time", o->time, "abs | rel | delta")->check(CLI::IsMember({"abs", "rel", "delta"}))->capture_default_str();
  cmd->add_option("--protocol", o->protocol, "what a serial link carries")
      ->check(CLI::IsMember({"interboard"}))
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "JSON Lines, one object per frame");
  cmd->add_flag("--top", o->top,
                "per-id table: count, rate, period, jitter, last data (changed bytes marked), bus load and state; a "
                "full-screen view on a terminal (keys: e or space = ESTOP, o = mode off, q = quit), printed once at "
                "the end in any case");
  cmd->add_flag("--listen-only", o->listen_only, "slcan: open the adapter silent (no ACKs on the bus)");
  cmd->footer(
      "\nOne line per frame, the same format as 'saulctl decode'. Controller state changes (error-warning, "
      "error-passive, bus-off) and drop counts are printed on stderr.\n"
      "\nExamples:\n  saulctl sniff --link can0                     (or: saulctl sniff can0)\n"
      "  saulctl sniff --link slcan:/dev/ttyACM0 --id 400,401 --count 20\n"
      "  saulctl sniff --link can0 --id 00000900:0000FF00   all VESC STATUS frames\n"
      "  saulctl sniff --link serial:/dev/ttyUSB0@460800 --protocol interboard\n"
      "  saulctl sniff --link can0 --top --duration 10s   per-id table with rates, jitter and bus load\n");
}

}  // namespace saulctl
