#include "saulproto/host/report/trace_report.hpp"

#include <fmt/core.h>

#include <cmath>
#include <string_view>

#include "saulproto/core/saul_can.hpp"
#include "saulproto/host/capture/trace_file.hpp"

namespace saul::host {

double TraceClock::seconds(std::uint32_t time_us) {
  if (started_ && time_us < last_ && last_ - time_us > 0x8000'0000U) high_ += std::uint64_t{1} << 32;  // a wrap
  started_ = true;
  last_ = time_us;
  return static_cast<double>(high_ + time_us) * 1e-6;
}

namespace {

/// One CSV column: its name (with the unit) and the value of a record in that unit, with its decimals.
struct Column {
  const char* name;
  int decimals;
  double (*value)(const trace::LoopTrace&);
  const char* meaning;  ///< what it is, with its unit (the MCAP schema's description)
};

// time_s is not in the table: it comes from the unwrapped clock.
constexpr Column kColumns[] = {
    {"seq", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.seq); },
     "record sequence number (counts loop iterations)"},
    {"pitch_deg", 2, [](const trace::LoopTrace& r) { return r.pitch_x100 / 100.0; },
     "pitch, in degrees"},
    {"rate_dps", 1, [](const trace::LoopTrace& r) { return r.rate_x10 / 10.0; },
     "pitch rate, in degrees per second"},
    {"setpoint_deg", 2, [](const trace::LoopTrace& r) { return r.setpoint_x100 / 100.0; },
     "pitch setpoint, in degrees"},
    {"p_term", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.p_term); },
     "PID proportional term, in permille of the output range"},
    {"i_term", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.i_term); },
     "PID integral term, in permille of the output range"},
    {"d_term", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.d_term); },
     "PID derivative term, in permille of the output range"},
    {"output", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.output); },
     "PID output after saturation, in permille of the output range"},
    {"erpm_left", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.erpm_left); },
     "left motor speed commanded, in electrical RPM"},
    {"erpm_right", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.erpm_right); },
     "right motor speed commanded, in electrical RPM"},
    {"wheel_mmps", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.wheel_mmps); },
     "wheel speed, in mm/s"},
    {"request_mmps", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.request_mmps); },
     "requested speed, in mm/s"},
    {"state", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.state); },
     "robot state (its name)"},
    {"faults", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.faults); },
     "the 0x401 fault bits (a bit mask, no unit)"},
    {"excite", 0, [](const trace::LoopTrace& r) { return static_cast<double>(r.excite); },
     "excitation kind (its name)"},
    {"excite_deg", 2, [](const trace::LoopTrace& r) { return r.excite_x100 / 100.0; },
     "excitation added to the setpoint, in degrees"},
};

std::string state_name(std::uint8_t state) {
  return state <= static_cast<std::uint8_t>(saulcan::RobotState::fault)
             ? saulcan::to_string(static_cast<saulcan::RobotState>(state))
             : fmt::format("state_{}", state);
}
std::string excite_name(std::uint8_t excite) {
  return excite <= static_cast<std::uint8_t>(trace::Excite::prbs) ? trace::to_string(static_cast<trace::Excite>(excite))
                                                                   : fmt::format("excite_{}", excite);
}

}  // namespace

std::string trace_csv_header() {
  std::string line = "time_s";
  for (const Column& c : kColumns) line += fmt::format(",{}", c.name);
  return line + "\n";
}

std::string trace_csv_row(const trace::LoopTrace& r, double time_s) {
  std::string line = fmt::format("{:.6f}", time_s);
  for (const Column& c : kColumns) line += fmt::format(",{:.{}f}", c.value(r), c.decimals);
  return line + "\n";
}

nlohmann::json trace_json(const trace::LoopTrace& r, double time_s) {
  nlohmann::json j;
  j["time_s"] = std::round(time_s * 1e6) / 1e6;
  for (const Column& c : kColumns) {
    const double v = c.value(r);
    if (c.decimals == 0) {
      j[c.name] = static_cast<std::int64_t>(v);
    } else {
      const double scale = std::pow(10.0, c.decimals);
      j[c.name] = std::round(v * scale) / scale;
    }
  }
  j["state"] = state_name(r.state);
  j["excite"] = excite_name(r.excite);
  return j;
}

std::string trace_json_schema() {
  nlohmann::json props = {
      {"time_s", {{"type", "number"}, {"description", "time since the trace's start, in seconds"}}}};
  nlohmann::json required = nlohmann::json::array({"time_s"});
  for (const Column& c : kColumns) {
    const bool named = std::string_view(c.name) == "state" || std::string_view(c.name) == "excite";  // as trace_json()
    props[c.name] = {{"type", named ? "string" : c.decimals == 0 ? "integer" : "number"}, {"description", c.meaning}};
    required.push_back(c.name);
  }
  const nlohmann::json schema = {{"title", "loop_trace"},
                                 {"description", "one balance-loop iteration, as saulctl decode --json shows it"},
                                 {"type", "object"},
                                 {"properties", props},
                                 {"required", required},
                                 {"additionalProperties", false}};
  return schema.dump();
}

std::string trace_text(const trace::LoopTrace& r, double time_s) {
  return fmt::format(
      "{:12.6f}  seq {:<8} pitch {:7.2f} deg  rate {:7.1f} deg/s  setpoint {:6.2f} deg  P {:5} I {:5} D {:5}  out {:5}"
      "  erpm {}/{}  wheel {} mm/s  request {} mm/s  {}  faults 0x{:02X}  excite {} {:+.2f} deg",
      time_s, r.seq, r.pitch_x100 / 100.0, r.rate_x10 / 10.0, r.setpoint_x100 / 100.0, r.p_term, r.i_term, r.d_term,
      r.output, r.erpm_left, r.erpm_right, r.wheel_mmps, r.request_mmps, state_name(r.state), r.faults,
      excite_name(r.excite), r.excite_x100 / 100.0);
}

void TraceStats::add(const trace::LoopTrace& r) {
  const double t = clock_.seconds(r.time_us);
  if (records_ == 0) {
    first_s_ = t;
  } else {
    const auto step = static_cast<std::uint32_t>(r.seq - last_seq_);
    if (step == 0 || step > 0x8000'0000U) {
      ++backwards_;
    } else if (steps_.size() < kMaxSteps || steps_.count(step) != 0) {
      ++steps_[step];
    } else {
      ++irregular_;
    }
    const double period = (t - last_s_) * 1e6;  // µs
    ++periods_;
    if (periods_ == 1) min_ = max_ = period;
    min_ = std::min(min_, period);
    max_ = std::max(max_, period);
    const double delta = period - mean_;
    mean_ += delta / static_cast<double>(periods_);
    m2_ += delta * (period - mean_);
  }
  last_s_ = t;
  last_seq_ = r.seq;
  ++records_;
  if (r.excite != 0) ++excited_;
  ++states_[r.state];
}

std::uint32_t TraceStats::divider() const { return steps_.empty() ? 1 : steps_.begin()->first; }

std::uint64_t TraceStats::gaps() const {
  std::uint64_t n = irregular_;
  for (const auto& [step, count] : steps_)
    if (step != divider()) n += count;
  return n;
}

std::uint64_t TraceStats::missing() const {
  std::uint64_t n = 0;
  const std::uint32_t d = divider();
  for (const auto& [step, count] : steps_)
    if (step > d) n += count * (step / d - 1 + (step % d != 0 ? 1 : 0));
  return n;
}

std::string TraceStats::text(const std::string& file) const {
  const double sd = periods_ > 1 ? std::sqrt(m2_ / static_cast<double>(periods_ - 1)) : 0.0;
  std::string out = fmt::format("{}: loop trace, {} records over {:.3f} s ({:.1f} Hz, every {} loop{})\n", file,
                                records_, duration_s(), rate_hz(), divider(), divider() == 1 ? "" : "s");
  out += fmt::format("gaps: {} ({} records missing), seq steps back: {}\n", gaps(), missing(), backwards_);
  out += fmt::format("loop period: mean {:.1f} us, min {:.1f} us, max {:.1f} us, jitter (sd) {:.2f} us\n", mean_, min_,
                     max_, sd);
  std::string states;
  for (const auto& [state, count] : states_) states += fmt::format(" {} {}", state_name(state), count);
  out += fmt::format("states:{}; records with an excitation: {}\n", states.empty() ? " none" : states, excited_);
  const auto& c = counters_;
  out += fmt::format("corrupt: {} (crc {}, length {}, type {}, cut at the end {}), bytes skipped {}, text lines {}\n",
                     c.crc_errors + c.length_errors + c.unknown_types + c.truncated, c.crc_errors, c.length_errors,
                     c.unknown_types, c.truncated, c.bytes_skipped, c.lines);
  return out;
}

nlohmann::json TraceStats::json(const std::string& file) const {
  const double sd = periods_ > 1 ? std::sqrt(m2_ / static_cast<double>(periods_ - 1)) : 0.0;
  nlohmann::json j{{"file", file},
                   {"format", "loop_trace"},
                   {"records", records_},
                   {"duration_s", duration_s()},
                   {"rate_hz", rate_hz()},
                   {"divider", divider()},
                   {"gaps", gaps()},
                   {"missing", missing()},
                   {"seq_backwards", backwards_},
                   {"period_us", {{"mean", mean_}, {"min", min_}, {"max", max_}, {"sd", sd}}},
                   {"excited_records", excited_}};
  for (const auto& [state, count] : states_) j["states"][state_name(state)] = count;
  const auto& c = counters_;
  j["corrupt"] = {{"crc_errors", c.crc_errors}, {"length_errors", c.length_errors},
                  {"unknown_types", c.unknown_types}, {"truncated", c.truncated},
                  {"bytes_skipped", c.bytes_skipped}};
  j["text_lines"] = c.lines;
  return j;
}

PlotDocument trace_plot_document(const std::string& path, std::size_t columns) {
  TraceStats stats;
  double first = 0;
  {
    TraceSink sink;
    sink.record = [&](const trace::LoopTrace& r, std::uint64_t) {
      if (stats.records() == 0) first = TraceClock().seconds(r.time_us);
      stats.add(r);
    };
    stats.finish(read_trace_file(path, sink));
  }
  PlotDocument doc;
  doc.title = fmt::format("{}: loop trace, {} records at {:.1f} Hz", path, stats.records(), stats.rate_hz());
  doc.t0 = 0;
  doc.t1 = stats.duration_s() > 0 ? stats.duration_s() : 1;
  const auto binner = [&] { return PlotBinner(doc.t0, doc.t1, columns); };
  // panel, series: (label, value in the panel's unit)
  struct Line {
    std::size_t panel;
    const char* label;
    double (*value)(const trace::LoopTrace&);
  };
  static constexpr Line kLines[] = {
      {0, "pitch", [](const trace::LoopTrace& r) { return r.pitch_x100 / 100.0; }},
      {0, "setpoint", [](const trace::LoopTrace& r) { return r.setpoint_x100 / 100.0; }},
      {0, "excitation", [](const trace::LoopTrace& r) { return r.excite_x100 / 100.0; }},
      {1, "rate", [](const trace::LoopTrace& r) { return r.rate_x10 / 10.0; }},
      {2, "P", [](const trace::LoopTrace& r) { return static_cast<double>(r.p_term); }},
      {2, "I", [](const trace::LoopTrace& r) { return static_cast<double>(r.i_term); }},
      {2, "D", [](const trace::LoopTrace& r) { return static_cast<double>(r.d_term); }},
      {2, "output", [](const trace::LoopTrace& r) { return static_cast<double>(r.output); }},
      {3, "wheel", [](const trace::LoopTrace& r) { return static_cast<double>(r.wheel_mmps); }},
      {3, "request", [](const trace::LoopTrace& r) { return static_cast<double>(r.request_mmps); }},
  };
  for (const char* title : {"pitch [deg]", "pitch rate [deg/s]", "PID [permille]", "wheel speed [mm/s]"}) {
    doc.panels.emplace_back();
    doc.panels.back().title = title;
  }
  for (const Line& line : kLines) doc.panels[line.panel].series.push_back(PlotSeries{line.label, binner()});
  TraceClock clock;
  int last_state = -1;
  TraceSink sink;
  sink.record = [&](const trace::LoopTrace& r, std::uint64_t) {
    const double t = clock.seconds(r.time_us) - first;
    std::size_t index[4] = {0, 0, 0, 0};
    for (const Line& line : kLines) doc.panels[line.panel].series[index[line.panel]++].binner.add(t, line.value(r));
    if (r.state != last_state) {
      const std::string name = state_name(r.state);
      if (doc.markers.size() < 100)
        doc.markers.push_back({t, MarkerKind::state, name, last_state < 0 ? name : state_name(static_cast<std::uint8_t>(last_state)) + " -> " + name, ""});
      ++doc.markers_total;
      last_state = r.state;
    }
  };
  (void)read_trace_file(path, sink);
  return doc;
}

void TraceTap::push(std::span<const std::uint8_t> bytes) { decoder_.push(bytes, *this); }

void TraceTap::finish() {
  decoder_.finish(*this);
  stats_.finish(decoder_.counters());
}

void TraceTap::line(std::string_view text, bool) {
  if (text.starts_with("error:") && refusal_.empty()) refusal_ = std::string(text);
  if (text.starts_with("trace dump end:")) dump_ended_ = true;
}

}  // namespace saul::host
