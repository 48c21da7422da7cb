// The tuning report as one self-contained HTML page, drawn with Debian's dygraphs as `saulctl plot` draws its
// pages (report/plot.hpp's load_dygraphs: the library is inlined, nothing is fetched when the page is viewed).
#pragma once

#include <string>

#include "saulproto/host/report/plot.hpp"
#include "saulproto/host/tune/analysis.hpp"
#include "saulproto/host/tune/series.hpp"

namespace saul::host::tune {

/// The text summary, then charts: the step response (estimated and measured), the closed loop's gain over
/// frequency, the spectra (log scale, the oscillation's frequency marked) and setpoint and pitch over time with the
/// excitation shaded. A chart the input cannot support says why instead. Once drawn, the page sets on <html>
/// data-tune-errors (script errors met), data-tune-charts (charts drawn) and data-tune-names (their ids).
std::string render_html(const Report& report, const Series& series, const DygraphsAssets& dygraphs);

}  // namespace saul::host::tune
