#include "saulproto/host/tune/report_html.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>

#include "saulproto/host/tune/report.hpp"

namespace saul::host::tune {
namespace {

using nlohmann::json;

/// Points of the time-series chart at most: every sample of a 10 s trace, one in 75 of a 10-minute one.
constexpr std::size_t kSeriesPoints = 8000;

/// An inline <script> ends at the first "</script": in JSON (only ever inside a string) "<\/" is the same text.
std::string inline_safe(std::string text, const std::string& tag) {
  for (auto at = text.find(tag); at != std::string::npos; at = text.find(tag, at + 3)) text.replace(at, 2, "<\\/");
  return text;
}

json page_data(const Report& r, const Series& s) {
  json d;
  d["title"] = "saulctl tune report: " + r.name;
  d["summary"] = to_text(r);
  if (r.step) {
    json rows = json::array();
    for (std::size_t k = 0; k < r.step->response.size(); ++k) {
      const bool measured = r.direct_step && k < r.direct_step->response.size();
      rows.push_back({static_cast<double>(k) * r.step->dt_s, r.step->response[k],
                      measured ? json(r.direct_step->response[k]) : json(nullptr)});
    }
    d["step"] = rows;
    json gain = json::array();
    for (std::size_t k = 0; k < r.step->gain.size(); ++k) gain.push_back({r.step->gain_hz[k], r.step->gain[k]});
    d["gain"] = gain;
  } else {
    d["step"] = nullptr;
    d["step_reason"] = r.step_reason;
  }
  if (!r.spectra.empty()) {
    json labels = {"Hz"};
    for (const auto& sp : r.spectra) labels.push_back(sp.signal);
    json rows = json::array();
    const auto& f = r.spectra.front().freq_hz;
    for (std::size_t k = 1; k < f.size() && f[k] <= 100.0; ++k) {
      json row = {f[k]};
      for (const auto& sp : r.spectra) row.push_back(sp.psd[k] > 0 ? json(sp.psd[k]) : json(nullptr));
      rows.push_back(row);
    }
    d["spectra"] = {{"labels", labels}, {"rows", rows}};
    d["oscillation_hz"] = r.oscillation ? json(r.oscillation->frequency_hz) : json(nullptr);
  } else {
    d["spectra"] = nullptr;
    d["spectra_reason"] = r.spectra_reason;
  }
  const std::size_t stride = std::max<std::size_t>(1, (s.size() + kSeriesPoints - 1) / kSeriesPoints);
  const bool has_setpoint = !s.setpoint_deg.empty();
  json rows = json::array();
  for (std::size_t i = 0; i < s.size(); i += stride) {
    json row = {s.time_s[i] - s.time_s.front(), s.pitch_deg[i]};
    if (has_setpoint) row.push_back(s.setpoint_deg[i]);
    rows.push_back(row);
  }
  d["series"] = {{"labels", has_setpoint ? json{"t", "pitch", "setpoint"} : json{"t", "pitch"}}, {"rows", rows}};
  json excite = json::array();
  for (std::size_t i = 0; i < s.excite.size(); ++i) {
    if (s.excite[i] == 0 || (i > 0 && s.excite[i - 1] != 0)) continue;
    std::size_t j = i;
    while (j + 1 < s.excite.size() && s.excite[j + 1] != 0) ++j;
    excite.push_back({s.time_s[i] - s.time_s.front(), s.time_s[j] - s.time_s.front()});
  }
  d["excite"] = excite;
  return d;
}

// Counts script errors from the first line on, for whoever checks the page (tests/cli/tune_browser.sh).
constexpr const char* kErrorWatch = R"JS((function () {
  var n = 0, root = document.documentElement;
  root.setAttribute('data-tune-errors', '0');
  window.addEventListener('error', function (e) {
    root.setAttribute('data-tune-errors', String(++n));
    root.setAttribute('data-tune-error-text', String(e.message));
  });
})();)JS";

constexpr const char* kPageScript = R"JS((function () {
  var d = JSON.parse(document.getElementById('tune-data').textContent);
  var root = document.documentElement, drawn = [];
  document.getElementById('title').textContent = d.title;
  document.title = d.title;
  document.getElementById('summary').textContent = d.summary;
  function chart(id, rows, opts, reason) {
    var div = document.getElementById(id);
    if (!rows) { div.className = 'reason'; div.textContent = 'Not drawn: ' + reason; return; }
    opts.legend = 'always';
    opts.axes = { y: { axisLabelWidth: 70 } };
    new Dygraph(div, rows, opts);
    drawn.push(id);
  }
  chart('step', d.step, { labels: ['t [s]', 'estimated', 'measured at steps'], xlabel: 'time after the setpoint step [s]',
    ylabel: 'pitch / setpoint step', connectSeparatedPoints: false,
    underlayCallback: function (ctx, area, g) {  // the +-5 % band around 1
      ctx.fillStyle = 'rgba(0,128,0,0.08)';
      var y0 = g.toDomYCoord(1.05), y1 = g.toDomYCoord(0.95);
      ctx.fillRect(area.x, y0, area.w, y1 - y0);
    } }, d.step_reason);
  chart('gain', d.gain, { labels: ['f [Hz]', '|H|'], xlabel: 'frequency [Hz]', ylabel: 'pitch / setpoint',
    logscale: true }, d.step_reason);
  chart('spectra', d.spectra && d.spectra.rows, d.spectra && { labels: d.spectra.labels, xlabel: 'frequency [Hz]',
    ylabel: 'power density [unit^2/Hz]', logscale: true,
    underlayCallback: function (ctx, area, g) {  // the oscillation, if any
      if (d.oscillation_hz === null) return;
      var x = g.toDomXCoord(d.oscillation_hz);
      ctx.fillStyle = 'rgba(214,39,40,0.6)';
      ctx.fillRect(x - 1, area.y, 2, area.h);
    } }, d.spectra_reason);
  chart('series', d.series.rows, { labels: d.series.labels, xlabel: 'time [s]', ylabel: 'degrees',
    underlayCallback: function (ctx, area, g) {  // the excitation, shaded
      ctx.fillStyle = 'rgba(255,165,0,0.18)';
      d.excite.forEach(function (e) {
        var x0 = g.toDomXCoord(e[0]), x1 = g.toDomXCoord(e[1]);
        ctx.fillRect(x0, area.y, Math.max(1, x1 - x0), area.h);
      });
    } }, '');
  root.setAttribute('data-tune-charts', String(drawn.length));
  root.setAttribute('data-tune-names', drawn.join(','));
})();)JS";

}  // namespace

std::string render_html(const Report& report, const Series& series, const DygraphsAssets& dygraphs) {
  std::string s = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>saulctl tune</title>\n";
  s += "<!-- dygraphs (MIT licence), from Debian's libjs-dygraphs, inlined: nothing is fetched -->\n";
  s += "<style>\n" + dygraphs.style + "\n</style>\n<style>\n"
       "body { font-family: sans-serif; margin: 8px 12px; color: #222; }\n"
       "h1 { font-size: 18px; } h2 { font-size: 15px; margin-top: 24px; }\n"
       ".chart { width: 100%; height: 300px; } .reason { color: #a33; } pre { font-size: 12px; }\n"
       "</style>\n";
  s += "<script>\n" + std::string(kErrorWatch) + "\n</script>\n";
  s += "<script>\n" + inline_safe(dygraphs.script, "</script") + "\n</script>\n</head>\n<body>\n";
  s += "<h1 id=\"title\"></h1>\n<pre id=\"summary\"></pre>\n"
       "<h2>Step response (setpoint &rarr; pitch); green: within 5 % of the setpoint</h2><div id=\"step\" class=\"chart\"></div>\n"
       "<h2>Closed-loop gain |H| (a peak above 1: the loop amplifies setpoint changes there)</h2>"
       "<div id=\"gain\" class=\"chart\"></div>\n"
       "<h2>Spectra (Welch); red line: the oscillation</h2><div id=\"spectra\" class=\"chart\"></div>\n"
       "<h2>Setpoint and pitch; orange: the excitation</h2><div id=\"series\" class=\"chart\"></div>\n";
  s += "<script type=\"application/json\" id=\"tune-data\">" + inline_safe(page_data(report, series).dump(), "</") +
       "</script>\n";
  s += "<script>\n" + std::string(kPageScript) + "\n</script>\n</body>\n</html>\n";
  return s;
}

}  // namespace saul::host::tune
