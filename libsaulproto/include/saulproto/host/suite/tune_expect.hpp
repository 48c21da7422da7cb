// Tuning figures in bench suites (docs/bench-tests.md): `expect tune overshoot<25% settling<0.6s oscillation=none`
// checks the figures host/tune's analysis finds in the loop trace of the suite's last `trace` step. Each figure has
// one unit; a value may carry it (25%, 0.6s, 600ms, 8Hz, 1.5deg) or not (then it is in that unit).
//
//   overshoot     %    peak above the final value of the pitch loop's step response
//   rise          s    10 % to 90 % of the final value
//   settling      s    last time outside +-5 % of the final value (a response that never settles fails any limit)
//   delay         s    to 50 % of the final value
//   steady_error  %    (1 - final value) x 100
//   oscillation   Hz   the oscillation's frequency, or `none` (oscillation=none: no peak 40x above its band)
//   saturation    %    share of records with the PID output at its limit
//   pitch_rms     deg  pitch about the setpoint
//   falls              BALANCE -> TILT_CUTOFF / FAULT changes
//
// The step figures are the directly measured step response when the trace has a setpoint step (`trace step ...`),
// else the one estimated by deconvolution (a chirp or prbs trace); a figure the trace cannot give fails the step
// with the analysis' reason.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/host/suite/suite.hpp"
#include "saulproto/host/tune/analysis.hpp"

namespace saul::host::suite {

struct TuneFigure {
  std::string_view name;
  std::string_view unit;  ///< "%", "s", "Hz", "deg", or "" for a count
};
inline constexpr std::array<TuneFigure, 9> kTuneFigures{{{"overshoot", "%"},
                                                         {"rise", "s"},
                                                         {"settling", "s"},
                                                         {"delay", "s"},
                                                         {"steady_error", "%"},
                                                         {"oscillation", "Hz"},
                                                         {"saturation", "%"},
                                                         {"pitch_rms", "deg"},
                                                         {"falls", ""}}};

/// One `expect tune` condition, its number converted to the figure's unit (600ms -> 0.6). Throws ParseError naming
/// the figure or unit that is wrong. (Defined with the parser, suite_parse.cpp.)
Condition parse_tune_condition(const std::string& word, const std::string& path, int line);

/// The analysis of a `trace` step's console bytes (a step's name for messages). Throws tune::SeriesError when they
/// hold no loop record.
tune::Report analyse_trace(const std::string& bytes, const std::string& name);

/// The figures of a report in one line, for the `trace` step's output.
std::string tune_figures_text(const tune::Report& report);

/// Checks the conditions against the report: empty when all hold, else why the first does not, naming the figure,
/// its measured value and the limit ("overshoot 12.4 % breaks overshoot<0.1%").
std::string check_tune(const std::vector<Condition>& conditions, const tune::Report& report);

}  // namespace saul::host::suite
