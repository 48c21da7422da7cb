// The tuning report as text, JSON and a side-by-side table.
#include "saulproto/host/tune/report.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace saul::host::tune {
namespace {

using nlohmann::json;

json optional_number(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

/// Numbers rounded to what they can mean (JSON readers need no 17 digits of an estimate).
double round_to(double v, int digits) {
  const double scale = std::pow(10.0, digits);
  return std::round(v * scale) / scale;
}

json figures_json(const StepFigures& f) {
  return {{"rise_time_s", round_to(f.rise_time_s, 4)},
          {"overshoot_pct", round_to(f.overshoot_pct, 2)},
          {"settling_time_s", f.settling_time_s ? json(round_to(*f.settling_time_s, 4)) : json(nullptr)},
          {"steady_state_error_pct", round_to(f.steady_state_error_pct, 2)},
          {"delay_s", round_to(f.delay_s, 4)},
          {"final_value", round_to(f.final_value, 4)}};
}

json gains_json(const Gains& g) {
  if (!g.known()) return nullptr;
  return {{"kp", optional_number(g.kp)}, {"ki", optional_number(g.ki)}, {"kd", optional_number(g.kd)}};
}

std::string gains_text(const Gains& g) {
  if (!g.known()) return "gains not given";
  const auto one = [](const std::optional<double>& v) { return v ? fmt::format("{:g}", *v) : std::string("?"); };
  return fmt::format("gains kp={} ki={} kd={}", one(g.kp), one(g.ki), one(g.kd));
}

/// "ok" or "CHECK (why)".
std::string verdict(bool healthy, const std::string& why) { return healthy ? "ok" : "CHECK: " + why; }

/// The settling time in s, or "unsettled": still outside the 5 % band in the response's last fifth (null in JSON).
std::string settling_text(const StepFigures& f, std::string_view unit = "") {
  return f.settling_time_s ? fmt::format("{:.3f}{}", *f.settling_time_s, unit) : std::string("unsettled");
}

/// The steady error's line, by its sign (docs/tuning.md, "The steady error"). Short of the setpoint (positive): the
/// I term does not make up what the P term leaves (a type-0 loop, Ki too small or 0). Past it (negative): on this
/// robot the PID's output is a wheel speed, so holding a lean (the robot accelerating at g tan(pitch)) needs an
/// output that ramps; only the I term ramps, and it does so with a steady error = ramp / Ki. Pitch then ends past the
/// setpoint by c / (Ki - c) (c: the ramp per degree, 86 permille/s at 2 m/s full scale), which the speed loop takes
/// up in normal driving; it is judged by the loop's low-frequency gain (final value), not as a missing I term.
void steady_text(std::string& out, const StepFigures& f, const Health& h) {
  const double e = f.steady_state_error_pct;
  if (e >= -h.steady_error_pct) {
    out += fmt::format("  steady error  {:>8.1f} %   setpoint change pitch never makes up            {}\n", e,
                       verdict(e <= h.steady_error_pct,
                               "pitch stops short of the setpoint: the I term does not make it up (more Ki)"));
    return;
  }
  out += fmt::format("  steady error  {:>8.1f} %   pitch ends past the setpoint (x{:.2f})              {}\n", e,
                     f.final_value,
                     verdict(f.final_value <= h.lean_gain,
                             fmt::format("more than x{:g}: the I term barely follows the robot's acceleration "
                                         "(more Ki)",
                                         h.lean_gain)));
  out += "                             a held lean accelerates the robot: the output (a wheel speed) must ramp, and\n"
         "                             the I term follows that ramp with an error of ramp / Ki; the speed loop takes\n"
         "                             it up in normal driving\n";
}

void step_text(std::string& out, const StepFigures& f, const Health& h) {
  const bool settles = f.settling_time_s && *f.settling_time_s <= h.settling_s;
  out += fmt::format("  rise time     {:>8.3f} s   10 % to 90 % of the final value: how fast pitch follows the setpoint\n",
                     f.rise_time_s);
  out += fmt::format("  overshoot     {:>8.1f} %   how far past the setpoint pitch swings          {}\n",
                     f.overshoot_pct,
                     verdict(f.overshoot_pct <= h.overshoot_pct,
                             fmt::format("above {:g} %: the loop rings (less Kp, more Kd)", h.overshoot_pct)));
  out += fmt::format("  settling    {:>10}   until pitch stays within 5 % of the final value  {}\n",
                     settling_text(f, " s"),
                     verdict(settles, fmt::format("slower than {:g} s: the robot sways after a push", h.settling_s)));
  steady_text(out, f, h);
  out += fmt::format("  delay         {:>8.3f} s   to half of the final value\n", f.delay_s);
}

}  // namespace

json to_json(const Report& r) {
  json j;
  j["file"] = r.name;
  j["source"] = r.source == SeriesSource::telemetry ? "telemetry" : "loop_trace";
  j["gains"] = gains_json(r.gains);
  j["records"] = r.records;
  j["duration_s"] = round_to(r.duration_s, 6);
  j["sample_rate_hz"] = round_to(r.sample_rate_hz, 3);
  j["gaps"] = r.gaps_total;
  j["gap_list"] = json::array();
  for (const auto& g : r.gaps)
    j["gap_list"].push_back({{"at_s", round_to(g.at_s, 6)}, {"duration_s", round_to(g.duration_s, 6)},
                             {"line", g.line}, {"missed", g.missed}});
  j["missed_iterations"] = r.missed_iterations;
  j["seq_missing"] = r.seq_missing ? json(*r.seq_missing) : json(nullptr);
  j["loop_divider"] = r.loop_divider;
  j["loop_period_us"] = {{"p50", round_to(r.period_p50_us, 1)}, {"p99", round_to(r.period_p99_us, 1)},
                         {"max", round_to(r.period_max_us, 1)}};
  j["balancing_records"] = r.balancing_records;
  j["pitch_rms_deg"] = round_to(r.pitch_rms_deg, 4);
  j["pitch_offset_deg"] = round_to(r.pitch_offset_deg, 4);
  j["pitch_drift_deg_per_min"] = round_to(r.pitch_drift_deg_per_min, 4);
  j["saturation_pct"] = r.saturation_pct ? json(round_to(*r.saturation_pct, 3)) : json(nullptr);
  j["falls"] = r.falls;
  j["excite_pct"] = round_to(r.excite_pct, 3);
  if (r.windups) {
    json list = json::array();
    for (const auto& w : *r.windups)
      list.push_back({{"start_s", round_to(w.start_s, 4)}, {"duration_s", round_to(w.duration_s, 4)},
                      {"i_term_peak", round_to(w.i_term_peak, 1)}});
    j["windup"] = {{"periods", r.windups->size()}, {"list", list}};
  } else {
    j["windup"] = nullptr;
  }
  if (r.step) {
    const auto& s = *r.step;
    json step = figures_json(s.figures);
    step["windows_used"] = s.windows_used;
    step["windows_total"] = s.windows_total;
    step["windows_quiet"] = s.windows_quiet;
    step["resonance_hz"] = s.resonance_hz ? json(round_to(*s.resonance_hz, 3)) : json(nullptr);
    step["resonance_gain"] = round_to(s.resonance_gain, 3);
    step["dt_s"] = s.dt_s;
    step["response"] = s.response;
    j["step"] = step;
  } else {
    j["step"] = nullptr;
    j["step_reason"] = r.step_reason;
  }
  if (r.direct_step) {
    json step = figures_json(r.direct_step->figures);
    step["steps"] = r.direct_step->steps;
    step["dt_s"] = r.direct_step->dt_s;
    step["response"] = r.direct_step->response;
    j["step_direct"] = step;
  } else {
    j["step_direct"] = nullptr;
    j["step_direct_reason"] = r.direct_step_reason;
  }
  j["spectra"] = json::array();
  for (const auto& sp : r.spectra) {
    json one = {{"signal", sp.signal},
                {"resolution_hz", sp.resolution_hz},
                {"segments", sp.segments},
                {"peak_hz", sp.peak_hz ? json(round_to(*sp.peak_hz, 3)) : json(nullptr)},
                {"peak_ratio", round_to(sp.peak_ratio, 2)}};
    // The density up to 100 Hz (the band), for plots and the independent checks.
    const auto upto = static_cast<std::size_t>(
        std::upper_bound(sp.freq_hz.begin(), sp.freq_hz.end(), 100.0 + 1e-9) - sp.freq_hz.begin());
    one["psd"] = std::vector<double>(sp.psd.begin(), sp.psd.begin() + static_cast<std::ptrdiff_t>(upto));
    j["spectra"].push_back(one);
  }
  if (r.spectra.empty()) j["spectra_reason"] = r.spectra_reason;
  if (r.oscillation)
    j["oscillation"] = {{"signal", r.oscillation->signal},
                        {"frequency_hz", round_to(r.oscillation->frequency_hz, 3)},
                        {"ratio_to_median", round_to(r.oscillation->ratio_to_median, 1)}};
  else
    j["oscillation"] = nullptr;
  if (!r.spectra.empty() && !r.oscillation) j["oscillation_reason"] = "no peak 40x above the median of its octave";
  else if (r.spectra.empty()) j["oscillation_reason"] = r.spectra_reason;
  j["problems"] = r.problems;
  j["problems_total"] = r.problems_total;
  return j;
}

std::string to_text(const Report& r, const Health& h) {
  std::string out;
  const bool telemetry = r.source == SeriesSource::telemetry;
  out += fmt::format("{}: {} records over {:.3f} s at {:.4g} Hz ({}{}), {}\n", r.name, r.records, r.duration_s,
                     r.sample_rate_hz, telemetry ? "CAN telemetry 0x400" : "loop trace",
                     r.loop_divider > 1 ? fmt::format(", a record every {} iterations", r.loop_divider) : "",
                     gains_text(r.gains));
  out += fmt::format("loop period   p50 {:.0f} us, p99 {:.0f} us, max {:.0f} us; {} gaps, {} iterations missed  {}\n",
                     r.period_p50_us, r.period_p99_us, r.period_max_us, r.gaps_total, r.missed_iterations,
                     telemetry ? std::string("(telemetry: the bus's timing, not the loop's)")
                               : verdict(r.gaps_total == 0 && r.period_p99_us <= h.period_p99_us,
                                         "the loop runs late or the trace lost records"));
  if (r.seq_missing)
    out += fmt::format("loop counter  {} {} missing by seq{}\n", *r.seq_missing,
                       r.loop_divider > 1 ? "records" : "iterations",
                       *r.seq_missing < r.missed_iterations ? ": the rest of the missed ones, the loop ran late" : "");
  for (std::size_t k = 0; k < std::min<std::size_t>(r.gaps.size(), 5); ++k)
    out += fmt::format("  gap at {:.3f} s (line {}): {:.1f} ms, {} missing\n", r.gaps[k].at_s, r.gaps[k].line,
                       r.gaps[k].duration_s * 1e3, r.gaps[k].missed);
  out += fmt::format("pitch         RMS {:.3f} deg, offset {:+.3f} deg, drift {:+.3f} deg/min, {} ({} records "
                     "balancing)\n",
                     r.pitch_rms_deg, r.pitch_offset_deg, r.pitch_drift_deg_per_min,
                     telemetry ? "about level" : "about the setpoint", r.balancing_records);
  if (r.saturation_pct)
    out += fmt::format("saturation    {:.2f} % of the records with the output at +-1000 permille  {}\n",
                       *r.saturation_pct,
                       verdict(*r.saturation_pct <= h.saturation_pct, "the motors are at their limit: the loop "
                                                                      "cannot do what it asks"));
  else
    out += "saturation    unknown (no output column)\n";
  if (r.falls > 0) out += fmt::format("falls         {} (TILT_CUTOFF)  CHECK\n", r.falls);
  if (r.windups)
    out += fmt::format("I-term wind-up {} period(s) of the I term pushing a saturated output  {}\n", r.windups->size(),
                       verdict(r.windups->empty(), "the I term builds up while the motors cannot follow"));
  if (r.excite_pct > 0) out += fmt::format("excitation    {:.1f} % of the records\n", r.excite_pct);
  if (r.step) {
    out += fmt::format("step response (setpoint -> pitch) estimated from {} of {} windows ({} with too little input)\n",
                       r.step->windows_used, r.step->windows_total, r.step->windows_quiet);
    step_text(out, r.step->figures, h);
    if (r.step->resonance_hz)
      out += fmt::format("  resonance     {:>8.2f} Hz  the loop amplifies setpoint changes x{:.2f} there\n",
                         *r.step->resonance_hz, r.step->resonance_gain);
  } else {
    out += fmt::format("step response: none: {}\n", r.step_reason);
  }
  if (r.direct_step) {
    out += fmt::format("step response measured at {} setpoint step(s)\n", r.direct_step->steps);
    step_text(out, r.direct_step->figures, h);
  } else if (r.step) {
    out += fmt::format("step response measured: none: {}\n", r.direct_step_reason);
  }
  if (r.spectra.empty()) {
    out += fmt::format("spectra: none: {}\n", r.spectra_reason);
  } else {
    for (const auto& sp : r.spectra)
      out += fmt::format("spectrum {:<9} {} segments, {:.2f} Hz bins; strongest peak {}\n", sp.signal, sp.segments,
                         sp.resolution_hz,
                         sp.peak_hz ? fmt::format("{:.2f} Hz at {:.1f}x its octave's median", *sp.peak_hz, sp.peak_ratio)
                                    : std::string("none"));
    if (r.oscillation)
      out += fmt::format("oscillation   {:.2f} Hz in {} ({:.0f}x the median around it)  CHECK: a limit cycle "
                         "(above ~8 Hz: Kd too high or noise in the rate; below: Kp too high)\n",
                         r.oscillation->frequency_hz, r.oscillation->signal, r.oscillation->ratio_to_median);
    else
      out += "oscillation   none (no peak 40x above the median of its octave, 1-100 Hz)  ok\n";
  }
  if (r.problems_total > 0) {
    out += fmt::format("{} input problem(s):\n", r.problems_total);
    for (const auto& p : r.problems) out += "  " + p + "\n";
    if (r.problems_total > r.problems.size())
      out += fmt::format("  ... and {} more\n", r.problems_total - r.problems.size());
  }
  return out;
}

json compare_json(const std::vector<Report>& reports) {
  json all = json::array();
  for (const auto& r : reports) all.push_back(to_json(r));
  return all;
}

std::string compare_text(const std::vector<Report>& reports) {
  struct Row {
    const char* label;
    std::function<std::string(const Report&)> cell;
  };
  const auto opt = [](const std::optional<double>& v, int digits) {
    return v ? fmt::format("{:.{}f}", *v, digits) : std::string("-");
  };
  const auto step = [](const Report& r) -> const StepFigures* { return r.step ? &r.step->figures : nullptr; };
  const std::vector<Row> rows = {
      {"kp", [&](const Report& r) { return opt(r.gains.kp, 3); }},
      {"ki", [&](const Report& r) { return opt(r.gains.ki, 3); }},
      {"kd", [&](const Report& r) { return opt(r.gains.kd, 3); }},
      {"records", [](const Report& r) { return fmt::format("{}", r.records); }},
      {"sample rate [Hz]", [](const Report& r) { return fmt::format("{:.4g}", r.sample_rate_hz); }},
      {"gaps", [](const Report& r) { return fmt::format("{}", r.gaps_total); }},
      {"loop period p99 [us]", [](const Report& r) { return fmt::format("{:.0f}", r.period_p99_us); }},
      {"pitch RMS [deg]", [](const Report& r) { return fmt::format("{:.3f}", r.pitch_rms_deg); }},
      {"saturation [%]", [&](const Report& r) { return opt(r.saturation_pct, 2); }},
      {"step windows used", [](const Report& r) { return r.step ? fmt::format("{}", r.step->windows_used) : "-"; }},
      {"rise time [s]", [&](const Report& r) { return step(r) ? fmt::format("{:.3f}", step(r)->rise_time_s) : "-"; }},
      {"overshoot [%]", [&](const Report& r) { return step(r) ? fmt::format("{:.1f}", step(r)->overshoot_pct) : "-"; }},
      {"settling [s]", [&](const Report& r) { return step(r) ? settling_text(*step(r)) : "-"; }},
      {"steady error [%]",
       [&](const Report& r) { return step(r) ? fmt::format("{:.1f}", step(r)->steady_state_error_pct) : "-"; }},
      {"delay [s]", [&](const Report& r) { return step(r) ? fmt::format("{:.3f}", step(r)->delay_s) : "-"; }},
      {"oscillation [Hz]",
       [](const Report& r) {
         return r.oscillation ? fmt::format("{:.2f}", r.oscillation->frequency_hz) : std::string("none");
       }},
  };
  std::vector<std::vector<std::string>> table;
  std::vector<std::size_t> width(reports.size() + 1, 0);
  table.push_back({""});
  for (const auto& r : reports) table[0].push_back(r.name.substr(r.name.find_last_of('/') + 1));
  for (const auto& row : rows) {
    table.push_back({row.label});
    for (const auto& r : reports) table.back().push_back(row.cell(r));
  }
  for (const auto& line : table)
    for (std::size_t c = 0; c < line.size(); ++c) width[c] = std::max(width[c], line[c].size());
  std::string out;
  for (const auto& line : table) {
    out += fmt::format("{:<{}}", line[0], width[0]);
    for (std::size_t c = 1; c < line.size(); ++c) out += fmt::format("  {:>{}}", line[c], width[c]);
    out += "\n";
  }
  for (const auto& r : reports)
    if (!r.step) out += fmt::format("{}: no step response: {}\n", r.name, r.step_reason);
  return out;
}

}  // namespace saul::host::tune
