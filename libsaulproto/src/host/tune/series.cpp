// Reading the loop's series: a CSV of named columns, or the telemetry of a CAN capture. Each bad row is told with
// its line and left out; the rest is kept.
#include "saulproto/host/tune/series.hpp"

#include <fmt/format.h>  // fmt::join

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <string_view>

#include "../util.hpp"
#include "saulproto/core/saul_can.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/trace_file.hpp"
#include "saulproto/host/report/trace_report.hpp"

namespace saul::host::tune {

void Series::problem(std::string message) {
  ++problems_total;
  if (problems.size() < kMaxProblems) problems.push_back(std::move(message));
}

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '"')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r' || s.back() == '"')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_commas(std::string_view line) {
  std::vector<std::string_view> cells;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == ',') {
      cells.push_back(trim(line.substr(start, i - start)));
      start = i + 1;
    }
  }
  return cells;
}

std::optional<double> parse_number(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || s.empty() || !std::isfinite(v)) return std::nullopt;
  return v;
}

/// A state as a number (the RobotState value) or a name ("BALANCE", "tilt_cutoff").
std::optional<std::uint8_t> parse_state(std::string_view s) {
  if (const auto v = parse_number(s)) {
    if (*v >= 0 && *v <= 255 && *v == std::floor(*v)) return static_cast<std::uint8_t>(*v);
    return std::nullopt;
  }
  for (std::uint8_t k = 0; k <= 5; ++k) {
    const std::string_view name = saulcan::to_string(static_cast<saulcan::RobotState>(k));
    if (name.size() != s.size()) continue;
    bool same = true;
    for (std::size_t i = 0; i < s.size(); ++i) same = same && host::detail::ascii_lower(s[i]) == host::detail::ascii_lower(name[i]);
    if (same) return k;
  }
  return std::nullopt;
}

/// "kp=30 ki=2 kd=1.5" anywhere in a comment line.
void read_gains(std::string_view comment, Gains& gains) {
  const std::array<std::pair<std::string_view, std::optional<double> Gains::*>, 3> keys{
      {{"kp=", &Gains::kp}, {"ki=", &Gains::ki}, {"kd=", &Gains::kd}}};
  for (const auto& [key, member] : keys) {
    const auto at = comment.find(key);
    if (at == std::string_view::npos) continue;
    std::string_view rest = comment.substr(at + key.size());
    rest = rest.substr(0, rest.find_first_of(" ,;\t\r"));
    if (const auto v = parse_number(rest)) gains.*member = *v;
  }
}

enum Column : std::uint8_t { kTime, kSetpoint, kPitch, kRate, kP, kI, kD, kOutput, kSeq, kExcite, kState, kColumns };
constexpr std::array<std::string_view, kColumns> kColumnNames{"time_s", "setpoint_deg", "pitch_deg", "rate_dps",
                                                              "p_term", "i_term",       "d_term",    "output",
                                                              "seq",    "excite", "state"};
constexpr std::size_t kNeeded = 3;  // time_s, setpoint_deg, pitch_deg

}  // namespace

Series read_csv_series(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw SeriesError(fmt::format("{}: cannot open the file: check the name and that it is readable", path));
  Series s;
  s.name = path;
  std::array<std::optional<std::size_t>, kColumns> index{};
  std::size_t header_cells = 0;
  bool header = false;
  std::string text;
  std::uint64_t number = 0;
  std::array<std::vector<double>*, kSeq + 1> numeric{&s.time_s, &s.setpoint_deg, &s.pitch_deg, &s.rate_dps,
                                                        &s.p_term, &s.i_term,       &s.d_term,    &s.output,
                                                        &s.seq};
  while (std::getline(in, text)) {
    ++number;
    const std::string_view line = trim(text);
    if (line.empty()) continue;
    if (line.front() == '#') {
      read_gains(line, s.gains);
      continue;
    }
    const auto cells = split_commas(line);
    if (!header) {
      header = true;
      header_cells = cells.size();
      for (std::size_t c = 0; c < cells.size(); ++c)
        for (std::size_t k = 0; k < kColumns; ++k)
          if (cells[c] == kColumnNames[k] && !index[k]) index[k] = c;
      std::vector<std::string_view> missing;
      for (std::size_t k = 0; k < kNeeded; ++k)
        if (!index[k]) missing.push_back(kColumnNames[k]);
      if (!missing.empty())
        throw SeriesError(fmt::format("{}:{}: the header has no column {} (it has: {}); a tuning CSV needs time_s, "
                                      "setpoint_deg and pitch_deg",
                                      path, number, fmt::join(missing, ", "), fmt::join(cells, ", ")));
      continue;
    }
    if (s.size() >= kMaxRecords) {
      s.truncated = true;
      s.problem(fmt::format("{}:{}: more than {} rows: the rest of the file is left out", path, number, kMaxRecords));
      break;
    }
    if (cells.size() != header_cells) {
      s.problem(fmt::format("{}:{}: {} values for {} columns (row left out)", path, number, cells.size(),
                            header_cells));
      continue;
    }
    std::array<double, kSeq + 1> row{};
    std::uint8_t excite = 0;
    std::uint8_t state = 0;
    std::string bad;
    for (std::size_t k = 0; k < kColumns && bad.empty(); ++k) {
      if (!index[k]) continue;
      const std::string_view cell = cells[*index[k]];
      if (k == kState) {
        if (const auto v = parse_state(cell)) state = *v;
        else bad = fmt::format("state '{}' is not a number nor a state name", cell);
      } else if (k == kExcite) {
        const auto v = parse_number(cell);
        if (v) excite = *v != 0 ? 1 : 0;
        else if (cell == "true" || cell == "false") excite = cell == "true" ? 1 : 0;
        else bad = fmt::format("excite '{}' is not a number", cell);
      } else if (const auto v = parse_number(cell)) {
        row[k] = *v;
      } else {
        bad = fmt::format("{} '{}' is not a number", kColumnNames[k], cell);
      }
    }
    if (bad.empty() && !s.time_s.empty() && row[kTime] <= s.time_s.back()) {
      const std::size_t n = s.size();
      if (n >= 2 && row[kTime] > s.time_s[n - 2]) {
        // The row before stands alone ahead of both neighbours: that one is wrong, not this and all that follow.
        s.problem(fmt::format("{}:{}: time_s {} jumps ahead of the rows around it (row left out)", path, s.line.back(),
                              s.time_s.back()));
        for (auto* column : numeric)
          if (!column->empty()) column->pop_back();
        if (!s.excite.empty()) s.excite.pop_back();
        if (!s.state.empty()) s.state.pop_back();
        s.line.pop_back();
      } else {
        bad = fmt::format("time_s {} does not move forward from {} (line {})", row[kTime], s.time_s.back(),
                          s.line.back());
      }
    }
    if (!bad.empty()) {
      s.problem(fmt::format("{}:{}: {} (row left out)", path, number, bad));
      continue;
    }
    for (std::size_t k = 0; k <= kSeq; ++k)
      if (index[k]) numeric[k]->push_back(row[k]);
    if (index[kExcite]) s.excite.push_back(excite);
    if (index[kState]) s.state.push_back(state);
    s.line.push_back(number);
  }
  if (in.bad()) throw SeriesError(fmt::format("{}: a read error after line {}", path, number));
  if (!header) throw SeriesError(fmt::format("{}: no header line: a tuning CSV starts with column names "
                                             "(time_s,setpoint_deg,pitch_deg,...)", path));
  return s;
}

Series read_capture_series(const std::string& path) {
  std::unique_ptr<CaptureReader> reader;
  try {
    reader = open_capture_reader(path);
  } catch (const CaptureOpenError& e) {
    throw SeriesError(fmt::format("{} (a tuning input is a CSV with time_s,setpoint_deg,pitch_deg or a CAN capture)",
                                  e.what()));
  }
  Series s;
  s.name = path;
  s.source = SeriesSource::telemetry;
  std::uint64_t frames = 0;  // records: frames and corrupt ones
  auto corrupt = [&](const CaptureError& e) {
    if (s.truncated) return;
    ++frames;
    s.problem(format_capture_error(path, e));
  };
  auto frame = [&](const CanFrame& f) {
    if (s.truncated) return;
    ++frames;
    if (f.id != saulcan::kTelemetryAId || f.extended || f.error || f.remote) return;
    const auto t = saulcan::decode_telemetry_a(f);
    if (!t) {
      s.problem(fmt::format("{}: frame {}: a 0x400 frame that does not decode (frame skipped)", path, frames));
      return;
    }
    if (!f.timestamp_ns) {
      s.problem(fmt::format("{}: frame {}: no timestamp (frame skipped)", path, frames));
      return;
    }
    const double time = static_cast<double>(*f.timestamp_ns) * 1e-9;
    if (!s.time_s.empty() && time <= s.time_s.back()) {
      s.problem(fmt::format("{}: frame {}: time does not move forward (frame skipped)", path, frames));
      return;
    }
    if (s.size() >= kMaxRecords) {
      s.truncated = true;
      s.problem(fmt::format("{}: more than {} telemetry frames: the rest is left out", path, kMaxRecords));
      return;
    }
    s.time_s.push_back(time);
    s.pitch_deg.push_back(t->pitch_x100 / 100.0);
    s.output.push_back(t->pid_out);
    s.state.push_back(static_cast<std::uint8_t>(t->state));
    s.line.push_back(frames);
  };
  FrameBatch batch;
  while (!s.truncated && reader->next_batch(batch))
    batch.walk([&](std::size_t i) { frame(batch.frames[i]); }, corrupt);
  if (s.size() == 0)
    throw SeriesError(fmt::format("{}: no telemetry (0x400) frame in {} frames: nothing to analyse", path, frames));
  return s;
}

namespace {

/// The sink that turns loop trace records into a series' rows (shared by the file and the in-memory reader).
TraceSink trace_rows(Series& s, TraceClock& clock) {
  TraceSink sink;
  sink.record = [&s, &clock](const trace::LoopTrace& r, std::uint64_t offset) {
    if (s.truncated) return;
    const double time = clock.seconds(r.time_us);
    if (!s.time_s.empty() && time <= s.time_s.back()) {
      s.problem(fmt::format("{}: record at byte {}: time does not move forward (record left out)", s.name, offset));
      return;
    }
    if (s.size() >= kMaxRecords) {
      s.truncated = true;
      s.problem(fmt::format("{}: more than {} records: the rest is left out", s.name, kMaxRecords));
      return;
    }
    s.time_s.push_back(time);
    s.setpoint_deg.push_back(r.setpoint_x100 / 100.0);
    s.pitch_deg.push_back(r.pitch_x100 / 100.0);
    s.rate_dps.push_back(r.rate_x10 / 10.0);
    s.p_term.push_back(r.p_term);
    s.i_term.push_back(r.i_term);
    s.d_term.push_back(r.d_term);
    s.output.push_back(r.output);
    s.seq.push_back(r.seq);
    s.excite.push_back(r.excite != 0 ? 1 : 0);
    s.state.push_back(r.state);
    s.line.push_back(offset);
  };
  // The gains from BALANCE's own `status` reply ("report=status ... kp=100 ki=500 kd=3 ..."), which tune record asks
  // for before switching the trace on (docs/captures.md): the last one in the file wins.
  sink.line = [&s](std::string_view text) { read_gains(text, s.gains); };
  sink.corrupt = [&s](Reason reason, std::uint64_t offset) {
    s.problem(fmt::format("{}: byte {}: a corrupt or cut record ({}): skipped, the rest is read", s.name, offset,
                          to_string(reason)));
  };
  return sink;
}

}  // namespace

Series read_trace_series(const std::string& path) {
  Series s;
  s.name = path;
  s.source = SeriesSource::loop_trace;
  TraceClock clock;  // time_us wraps after 71.6 min: unwrapped into seconds since 0
  try {
    read_trace_file(path, trace_rows(s, clock));
  } catch (const std::runtime_error& e) {
    throw SeriesError(e.what());
  }
  if (s.size() == 0) throw SeriesError(fmt::format("{}: a trace file without any loop record: nothing to analyse", path));
  return s;
}

Series read_trace_bytes_series(std::span<const std::uint8_t> bytes, const std::string& name) {
  Series s;
  s.name = name;
  s.source = SeriesSource::loop_trace;
  TraceClock clock;
  read_trace_bytes(bytes, trace_rows(s, clock));
  if (s.size() == 0) throw SeriesError(fmt::format("{}: no loop record in the trace: nothing to analyse", name));
  return s;
}

Series read_series(const std::string& path) {
  if (is_trace_file(path)) return read_trace_series(path);
  std::ifstream in(path);
  if (!in) throw SeriesError(fmt::format("{}: cannot open the file: check the name and that it is readable", path));
  // A tuning CSV: a header naming one of its columns, or any .csv but the CAN logs of python-can and SavvyCAN
  // (whose headers start "timestamp," and "Time Stamp,"), so a CSV missing columns is told which.
  std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  for (char& c : ext) c = host::detail::ascii_lower(c);
  std::string line;
  for (int k = 0; k < 64 && std::getline(in, line); ++k) {
    const auto t = trim(line);
    if (t.empty() || t.front() == '#') continue;
    for (const auto name : kColumnNames)
      if (t.find(name) != std::string_view::npos) return read_csv_series(path);
    if (ext == ".csv" && !t.starts_with("timestamp,") && !t.starts_with("Time Stamp,")) return read_csv_series(path);
    return read_capture_series(path);
  }
  return ext == ".csv" ? read_csv_series(path) : read_capture_series(path);
}

}  // namespace saul::host::tune
