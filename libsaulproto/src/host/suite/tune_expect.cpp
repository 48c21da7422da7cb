#include "saulproto/host/suite/tune_expect.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <optional>
#include <span>

#include "saulproto/host/tune/series.hpp"

namespace saul::host::suite {
namespace {

/// A figure's value, or why the trace cannot give it.
struct Measured {
  std::optional<double> value;
  bool none = false;  ///< oscillation: none found (value empty, no `why`)
  std::string why;    ///< why there is no value
  std::string note;   ///< where the value comes from ("measured at 1 setpoint step(s)")
};

/// The step figures: measured at the setpoint's steps when the trace has some, else estimated by deconvolution.
std::optional<tune::StepFigures> step_of(const tune::Report& r, Measured& m) {
  if (r.direct_step && r.direct_step->steps > 0) {
    m.note = fmt::format("step response measured at {} setpoint step(s)", r.direct_step->steps);
    return r.direct_step->figures;
  }
  if (r.step) {
    m.note = fmt::format("step response estimated over {} window(s)", r.step->windows_used);
    return r.step->figures;
  }
  m.why = fmt::format("no step response: measured: {}; estimated: {}", r.direct_step_reason, r.step_reason);
  return std::nullopt;
}

Measured measure(std::string_view name, const tune::Report& r) {
  Measured m;
  if (name == "oscillation") {
    if (r.oscillation) {
      m.value = r.oscillation->frequency_hz;
      m.note = fmt::format("in {}, {:.0f}x its band's median", r.oscillation->signal, r.oscillation->ratio_to_median);
    } else if (r.spectra.empty()) {
      m.why = "no spectra: " + r.spectra_reason;
    } else {
      m.none = true;
    }
  } else if (name == "saturation") {
    m.value = r.saturation_pct;
    if (!m.value) m.why = "the trace has no PID output";
  } else if (name == "pitch_rms") {
    m.value = r.pitch_rms_deg;
  } else if (name == "falls") {
    m.value = static_cast<double>(r.falls);
  } else if (const auto f = step_of(r, m)) {
    if (name == "overshoot") m.value = f->overshoot_pct;
    if (name == "rise") m.value = f->rise_time_s;
    if (name == "delay") m.value = f->delay_s;
    if (name == "steady_error") m.value = f->steady_state_error_pct;
    if (name == "settling") {
      m.value = f->settling_time_s;
      if (!m.value) m.why = "the step response never settles within its 5 % band";
    }
  }
  return m;
}

std::string value_text(const Measured& m, const TuneFigure& f) {
  if (m.none) return "none";
  if (!m.value) return "-";
  return fmt::format("{:.3g}{}{}", *m.value, f.unit.empty() ? "" : " ", f.unit);
}

const char* op_text(Condition::Op op) {
  switch (op) {
    case Condition::Op::eq: return "=";
    case Condition::Op::ne: return "!=";
    case Condition::Op::lt: return "<";
    case Condition::Op::le: return "<=";
    case Condition::Op::gt: return ">";
    case Condition::Op::ge: return ">=";
  }
  return "?";
}

}  // namespace

tune::Report analyse_trace(const std::string& bytes, const std::string& name) {
  const auto span = std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  return tune::analyse(tune::read_trace_bytes_series(span, name));
}

std::string tune_figures_text(const tune::Report& report) {
  std::string out = fmt::format("{} records at {:.0f} Hz:", report.records, report.sample_rate_hz);
  for (const auto& f : kTuneFigures) out += fmt::format(" {} {}", f.name, value_text(measure(f.name, report), f));
  const Measured step = measure("overshoot", report);
  return out + " (" + (step.note.empty() ? step.why : step.note) + ")";
}

std::string check_tune(const std::vector<Condition>& conditions, const tune::Report& report) {
  for (const auto& c : conditions) {
    const auto* f = std::find_if(kTuneFigures.begin(), kTuneFigures.end(), [&](const auto& t) { return t.name == c.field; });
    if (f == kTuneFigures.end()) return "no tuning figure '" + c.field + "'";
    const Measured m = measure(f->name, report);
    const std::string limit = fmt::format("{}{}{}{}", c.field, op_text(c.op), c.text, c.number ? f->unit : "");
    if (!m.value && !m.none) return fmt::format("{} cannot be checked ({}): {}", f->name, limit, m.why);
    if (m.none && c.number) return fmt::format("{}: none found, so {} does not hold", f->name, limit);
    const FieldValue v{m.value, m.none ? "none" : fmt::format("{}", m.value.value_or(0))};
    if (!holds(c, v))
      return fmt::format("{} {} breaks {}{}", f->name, value_text(m, *f), limit, m.note.empty() ? "" : " (" + m.note + ")");
  }
  return {};
}

}  // namespace saul::host::suite
