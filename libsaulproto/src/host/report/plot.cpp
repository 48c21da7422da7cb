#include "saulproto/host/report/plot.hpp"

#include "saulproto/host/report/format.hpp"  // json_line
#include "../util.hpp"

#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <stdexcept>

extern char** environ;

namespace saul::host {
namespace {

// Series are told apart by colour, dash pattern and width together, so two that lie on each other (commanded
// and reported speed, left and right wheel) both stay visible, in print too.
constexpr const char* kSeriesColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#17becf"};
constexpr const char* kStateColour = "#7b3fb5";
constexpr const char* kFaultColour = "#ff7f0e";
constexpr std::size_t kSparse = 20;  // a series with at most this many points is drawn with its points

const char* colour_of(std::size_t series) { return kSeriesColours[series % std::size(kSeriesColours)]; }
const char* colour_of(MarkerKind kind) { return kind == MarkerKind::state ? kStateColour : kFaultColour; }

std::string marker_summary(const PlotDocument& doc) {
  const auto drawn = static_cast<std::uint64_t>(doc.markers.size());
  if (drawn >= doc.markers_total)
    return fmt::format("{} state/fault change{}, all marked", doc.markers_total, doc.markers_total == 1 ? "" : "s");
  return fmt::format("{} state/fault changes: the first {} are marked, {} more are not", doc.markers_total, drawn,
                     doc.markers_total - drawn);
}

bool seconds_axis(const PlotDocument& doc) { return doc.time_label.find("[s]") != std::string::npos; }

// The axis title: the time of day of time 0 when known ("time since 08:26:40.500 UTC [s]").
std::string time_axis_label(const PlotDocument& doc) {
  const auto start = start_time_in_title(doc.title);
  if (!start || !seconds_axis(doc)) return doc.time_label;
  const std::string when = human_time(*start);
  return fmt::format("time since {} [s]", when.substr(when.find(' ') + 1));
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw std::runtime_error(fmt::format("{}: cannot be read: the interactive page needs Debian's libjs-dygraphs "
                                      "(apt install libjs-dygraphs, or scripts/setup.sh), or write .svg/.png/.pdf",
                                      path));
  std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  // A source map comment would make a browser's developer tools look for a file the page does not carry.
  for (auto at = text.find("//# sourceMappingURL="); at != std::string::npos; at = text.find("//# sourceMappingURL="))
    text.erase(at, text.find('\n', at) == std::string::npos ? std::string::npos : text.find('\n', at) - at);
  for (auto at = text.find("/*# sourceMappingURL="); at != std::string::npos; at = text.find("/*# sourceMappingURL=")) {
    const auto end = text.find("*/", at);
    text.erase(at, end == std::string::npos ? std::string::npos : end + 2 - at);
  }
  return text;
}

// Inline <script>: "</script" would end the element early. In JSON "<\/" is "</" (in a string, the only place it
// can be); in the libraries' code only the full tag is replaced (a bare "</" can be part of a regular expression).
std::string script_safe(std::string text, bool json = false) {
  const std::string tag = json ? "</" : "</script";
  for (auto at = text.find(tag); at != std::string::npos; at = text.find(tag, at + tag.size() + 1))
    text.replace(at, 2, "<\\/");
  return text;
}

// The page's data: per panel the series labels and rows [t, v0, v1, ...] (null where a series has no point at
// that time), in time order; the markers; time 0 in milliseconds since 1970 (null: an axis of numbers).
nlohmann::json page_data(const PlotDocument& doc) {
  using nlohmann::json;
  json data{{"start_date", nullptr}, {"start_tod_s", nullptr}};  // null: an axis of numbers
  const auto start = seconds_axis(doc) ? start_time_in_title(doc.title) : std::nullopt;
  // Time 0 as a date and seconds since that day's midnight (UTC): the axis stays in seconds since time 0, which
  // keeps microseconds (a JavaScript Date holds whole milliseconds), and is labelled with the time of day.
  if (start) {
    const double day = std::floor(*start / 86400.0);
    data["start_date"] = human_time(day * 86400.0).substr(0, 10);
    data["start_tod_s"] = *start - day * 86400.0;
  }
  data["time_label"] = time_axis_label(doc);
  data["panels"] = json::array();
  for (const auto& panel : doc.panels) {
    json p;
    p["title"] = fmt::format("{} ({} point{})", panel.title, panel.count(), panel.count() == 1 ? "" : "s");
    json labels = json::array({"time"});
    std::vector<std::pair<double, std::pair<std::size_t, double>>> points;  // t, (series, value)
    bool sparse = true;
    for (std::size_t i = 0; i < panel.series.size(); ++i) {
      const auto& series = panel.series[i];
      std::string label = series.label.empty() ? panel.title : series.label;
      labels.push_back(label);
      const auto pts = series.binner.points();
      sparse = sparse && pts.size() <= kSparse;
      for (const auto& pt : pts) points.push_back({pt.t, {i, pt.v}});
    }
    std::stable_sort(points.begin(), points.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    json rows = json::array();
    // A row at t: series `at` has the value v, the others null (all of them without `at`).
    auto add_row = [&](double t, std::size_t at = SIZE_MAX, double v = 0) {
      json row = json::array({t});
      for (std::size_t i = 0; i < panel.series.size(); ++i) row.push_back(i == at ? json(v) : json(nullptr));
      rows.push_back(std::move(row));
    };
    // Rows without values at both ends: every panel spans the whole run, so they line up before any zoom.
    if (points.empty() || points.front().first > doc.t0) add_row(doc.t0);
    for (const auto& [t, sv] : points) add_row(std::round(t * 1e6) / 1e6, sv.first, sv.second);
    if (points.empty() || points.back().first < doc.t1) add_row(doc.t1);
    p["labels"] = std::move(labels);
    p["rows"] = std::move(rows);
    p["sparse"] = sparse;
    data["panels"].push_back(std::move(p));
  }
  data["markers"] = json::array();
  for (const auto& m : doc.markers)
    data["markers"].push_back({{"t", m.t}, {"kind", to_string(m.kind)}, {"label", m.label}, {"detail", m.detail}});
  return data;
}

// Counts script errors from the first line of the page on, for whoever checks the page (tests/cli/plot_browser.sh).
constexpr const char* kErrorWatch =
    "(function () {\n  var n = 0, root = document.documentElement;\n  root.setAttribute('data-plot-errors', '0');\n"
    "  window.addEventListener('error', function (e) {\n    root.setAttribute('data-plot-errors', String(++n));\n"
    "    root.setAttribute('data-plot-error-text', String(e.message));\n  });\n})();";

// The page's own script: builds one chart per panel, synchronises them, draws the markers under the data and the
// sample points once zoomed in far enough to tell them apart.
constexpr const char* kPageScript = R"JS(
(function () {
  var P = JSON.parse(document.getElementById('plot-data').textContent);
  var colours = COLOURS, markerColours = {state: STATE_COLOUR, faults: FAULT_COLOUR};
  var patterns = [null, [8, 4], [2, 3], [10, 3, 2, 3], [5, 5], [1, 4]], widths = [2.2, 1.7, 1.4, 1.2, 1.1, 1.0];
  var dated = P.start_tod_s !== null;
  function pad(n, w) { var s = String(n); while (s.length < w) s = '0' + s; return s; }
  // The time of day of axis position t: "08:26:40.5" (digits as the visible window needs), a day mark past midnight.
  function tod(t, digits) {
    var s = P.start_tod_s + t, days = Math.floor(s / 86400), scale = Math.pow(10, digits);
    s -= days * 86400;
    var whole = Math.floor(s), frac = Math.round((s - whole) * scale);
    if (frac >= scale) { whole += 1; frac -= scale; }
    var text = pad(Math.floor(whole / 3600) % 24, 2) + ':' + pad(Math.floor(whole / 60) % 60, 2) + ':' + pad(whole % 60, 2);
    if (digits > 0) text += '.' + pad(frac, digits);
    return (days > 0 ? '+' + days + 'd ' : '') + text;
  }
  // Times of day in UTC on the axis, the full date in the legend. The ticks fall on round times of day (08:26:40.2,
  // not time 0 + 0.2 s = 08:26:40.201), one step of 1-2-5 (or 15 s, 30 s, minutes, hours) for the whole axis, and
  // as far apart as the longest label needs: labels of 12 characters 70 px apart ran into each other at 1400 px.
  var steps = [];
  for (var e = -6; e < 1; ++e) [1, 2, 5].forEach(function (m) { steps.push(m * Math.pow(10, e)); });
  steps.push(10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200, 10800, 21600, 43200, 86400);
  function decimals(step) { var d = 0; while (d < 6 && Math.abs(step * Math.pow(10, d) - Math.round(step * Math.pow(10, d))) > 1e-9) ++d; return d; }
  var xaxis = !dated ? {} : {
    axisLabelWidth: 110,
    ticker: function (min, max, pixels) {
      var s0 = P.start_tod_s, span = Math.max(max - min, 1e-9);
      for (var i = 0; i < steps.length; ++i) {
        var d = decimals(steps[i]), width = 7.5 * (8 + (d ? d + 1 : 0)) + 24;  // px of "08:26:40.123" and a gap
        if (span / steps[i] * width <= pixels || i === steps.length - 1) break;
      }
      var step = steps[i], ticks = [];
      for (var k = Math.ceil((s0 + min) / step - 1e-9); k * step - s0 <= max + 1e-9; ++k)
        ticks.push({v: k * step - s0, label: tod(k * step - s0, d)});
      return ticks;
    },
    valueFormatter: function (t) { return P.start_date + ' ' + tod(t, 6) + ' UTC (+' + t.toFixed(6) + ' s)'; }
  };
  function markers(ctx, area, g) {
    var lastLabel = -1e9;
    ctx.save();
    ctx.font = '11px sans-serif';
    ctx.lineWidth = 1;
    P.markers.forEach(function (m) {
      var px = g.toDomXCoord(m.t);
      if (px < area.x - 1 || px > area.x + area.w + 1) return;
      ctx.strokeStyle = ctx.fillStyle = markerColours[m.kind];
      ctx.setLineDash([4, 3]);
      ctx.beginPath(); ctx.moveTo(px, area.y); ctx.lineTo(px, area.y + area.h); ctx.stroke();
      if (px - lastLabel < 13) return;  // a label per 13 px; the table and the legend have every one
      ctx.save(); ctx.translate(px + 3, area.y + 4); ctx.rotate(Math.PI / 2); ctx.fillText(m.label, 0, 0); ctx.restore();
      lastLabel = px;
    });
    ctx.restore();
  }
  function lower(xs, v) { var lo = 0, hi = xs.length; while (lo < hi) { var mid = (lo + hi) >> 1; if (xs[mid] < v) lo = mid + 1; else hi = mid; } return lo; }
  var graphs = [];
  P.panels.forEach(function (panel, i) {
    var xs = panel.rows.map(function (r) { return r[0]; });
    var rows = panel.rows;
    var series = {};
    panel.labels.slice(1).forEach(function (name, k) {
      series[name] = {color: colours[k % colours.length], strokePattern: patterns[k % patterns.length],
                      strokeWidth: widths[k % widths.length]};
    });
    // Sample points once a pixel column holds few enough of them to be told apart.
    function dots(g) {
      var r = g.xAxisRange(), n = lower(xs, r[1] + 1e-9) - lower(xs, r[0]);
      var want = panel.sparse || n * 6 <= g.getArea().w;
      if (want !== g.getOption('drawPoints')) g.updateOptions({drawPoints: want});
    }
    var last = i === P.panels.length - 1;
    graphs.push(new Dygraph(document.getElementById('panel' + i), rows, {
      labels: panel.labels, title: panel.title, series: series, connectSeparatedPoints: true,
      drawPoints: panel.sparse, pointSize: 2.5, highlightCircleSize: 4, animatedZooms: false,
      labelsDiv: document.getElementById('legend' + i), labelsSeparateLines: false, legend: 'always',
      xlabel: last ? P.time_label : undefined, showRangeSelector: last, rangeSelectorHeight: 32,
      axes: {x: xaxis}, underlayCallback: markers, drawCallback: dots
    }));
  });
  if (graphs.length > 1 && Dygraph.synchronize) Dygraph.synchronize(graphs, {zoom: true, selection: true, range: false});
  var root = document.documentElement;
  // page.html#t=12.5,13 opens zoomed into that window (seconds since time 0), every panel with it.
  var zoom = /^#t=([-0-9.e]+),([-0-9.e]+)$/.exec(location.hash);
  if (zoom && graphs.length) graphs[0].updateOptions({dateWindow: [+zoom[1], +zoom[2]]});
  // What is shown, for a test or a script: each panel's window in seconds since time 0, panels with points.
  root.setAttribute('data-plot-windows', JSON.stringify(graphs.map(function (g) {
    return g.xAxisRange().map(function (v) { return Math.round(v * 1e6) / 1e6; });
  })));
  root.setAttribute('data-plot-points', String(graphs.filter(function (g) { return g.getOption('drawPoints'); }).length));
  root.setAttribute('data-plot-panels', String(graphs.length));
})();
)JS";

std::string page_script() {
  std::string js = kPageScript;
  auto put = [&js](const std::string& key, const std::string& value) {
    for (auto at = js.find(key); at != std::string::npos; at = js.find(key, at + value.size())) js.replace(at, key.size(), value);
  };
  nlohmann::json colours = nlohmann::json::array();
  for (const char* c : kSeriesColours) colours.push_back(c);
  put("COLOURS", colours.dump());
  put("STATE_COLOUR", nlohmann::json(kStateColour).dump());
  put("FAULT_COLOUR", nlohmann::json(kFaultColour).dump());
  return js;
}

// gnuplot strings: single-quoted ('' for a quote), double-quoted (c_literal) where a line break is needed.
std::string gp_single(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

}  // namespace

std::uint64_t PlotPanel::count() const {
  std::uint64_t n = 0;
  for (const auto& s : series) n += s.binner.count();
  return n;
}

const char* to_string(MarkerKind kind) noexcept { return kind == MarkerKind::state ? "state" : "faults"; }

PlotBinner::PlotBinner(double t0, double t1, std::size_t columns)
    : t0_(t0), t1_(t1 > t0 ? t1 : t0 + 1), columns_(columns == 0 ? 1 : columns) {}

void PlotBinner::add(double t, double v) {
  if (!std::isfinite(t) || !std::isfinite(v)) return;
  const double x = (t - t0_) / (t1_ - t0_) * static_cast<double>(columns_.size());
  std::size_t i = x <= 0 ? 0 : static_cast<std::size_t>(x);
  if (i >= columns_.size()) i = columns_.size() - 1;
  Column& c = columns_[i];
  const Point p{t, v};
  if (!c.used) {
    c = Column{true, p, p, p, p};
  } else {
    c.last = p;
    if (v < c.low.v) c.low = p;
    if (v > c.high.v) c.high = p;
  }
  ++count_;
  if (!min_ || v < *min_) min_ = v;
  if (!max_ || v > *max_) max_ = v;
}

std::vector<PlotBinner::Point> PlotBinner::points() const {
  std::vector<Point> out;
  for (const Column& c : columns_) {
    if (!c.used) continue;
    Point four[4] = {c.first, c.low, c.high, c.last};
    std::sort(std::begin(four), std::end(four), [](const Point& a, const Point& b) { return a.t < b.t; });
    for (const Point& p : four)
      if (out.empty() || out.back().t != p.t || out.back().v != p.v) out.push_back(p);
  }
  return out;
}

namespace {
// The first "<9+ digits>.<6 digits>" in a title (a capture's epoch start time), as [begin, end) offsets.
// Scanned by hand rather than with <regex>: GCC 12 at -O1 with sanitizers warns inside libstdc++'s regex.
std::optional<std::pair<size_t, size_t>> find_epoch_stamp(const std::string& s) {
  auto digit = [&](size_t i) { return i < s.size() && s[i] >= '0' && s[i] <= '9'; };
  for (size_t i = 0; i < s.size();) {
    if (!digit(i)) {
      ++i;
      continue;
    }
    size_t j = i;
    while (digit(j)) ++j;
    // Leftmost match: any suffix of a long digit run that is >= 9 digits also qualifies, so the run start wins.
    if (j - i >= 9 && j < s.size() && s[j] == '.') {
      size_t k = j + 1;
      while (k < j + 7 && digit(k)) ++k;
      if (k == j + 7) return std::make_pair(i, k);
    }
    i = j;
  }
  return std::nullopt;
}
}  // namespace

std::optional<double> start_time_in_title(const std::string& title) {
  const auto stamp = find_epoch_stamp(title);
  if (!stamp) return std::nullopt;
  const size_t dot = title.find('.', stamp->first);
  return std::stod(title.substr(stamp->first, dot - stamp->first)) + std::stod(title.substr(dot + 1, 6)) / 1e6;
}

std::string human_time(double epoch_s) {
  auto whole = static_cast<std::time_t>(std::floor(epoch_s));
  auto ms = static_cast<int>(std::lround((epoch_s - std::floor(epoch_s)) * 1000));
  if (ms == 1000) {
    ++whole;
    ms = 0;
  }
  std::tm tm{};
  gmtime_r(&whole, &tm);
  return fmt::format("{:04}-{:02}-{:02} {:02}:{:02}:{:02}.{:03} UTC", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
                     tm.tm_hour, tm.tm_min, tm.tm_sec, ms);
}

std::string human_title(const std::string& title) {
  const auto stamp = find_epoch_stamp(title);
  if (!stamp) return title;
  return title.substr(0, stamp->first) + human_time(*start_time_in_title(title)) + title.substr(stamp->second);
}

DygraphsAssets load_dygraphs(const std::string& dir) {
  return {read_text(dir + "/dygraph.min.js"), read_text(dir + "/dygraph.min.css"),
          read_text(dir + "/extras/synchronizer.js")};
}

std::string render_html(const PlotDocument& doc, const DygraphsAssets& dygraphs) {
  const std::string title = human_title(doc.title);
  std::string s = fmt::format(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{0}</title>\n"
      "<!-- dygraphs (MIT licence), from Debian's libjs-dygraphs, inlined: nothing is fetched -->\n"
      "<style>\n{1}\n</style>\n<style>\n"
      "body {{ font-family: sans-serif; margin: 8px 12px; color: #222; }}\n"
      "h1 {{ font-size: 18px; margin: 4px 0; }} h2 {{ font-size: 15px; margin-top: 24px; }}\n"
      ".panel {{ width: 100%; height: 250px; }} .legend {{ font-size: 12px; min-height: 16px; margin: 10px 0 2px; }}\n"
      ".dygraph-title {{ font-size: 14px; font-weight: normal; text-align: left; padding-left: 60px; }}\n"
      "table {{ border-collapse: collapse; }} th, td {{ border: 1px solid #ccc; padding: 2px 8px; text-align: left; }}\n"
      "td.num {{ text-align: right; font-variant-numeric: tabular-nums; }}\n"
      ".state {{ color: {2}; }} .faults {{ color: {3}; }} .note {{ color: #555; }}\n"
      "</style>\n<script>\n{6}\n</script>\n<script>\n{4}\n</script>\n<script>\n{5}\n</script>\n</head>\n<body>\n<h1>{0}</h1>\n",
      detail::markup_escape(title), dygraphs.style, kStateColour, kFaultColour, script_safe(dygraphs.script),
      script_safe(dygraphs.synchronizer), kErrorWatch);
  s += "<p class=\"note\">Drag across a chart to zoom in (every panel follows), shift-drag to pan, double-click to "
       "zoom out; the strip under the last panel moves the window. Sample points appear once zoomed in.";
  if (doc.markers_total > 0)
    s += fmt::format(" {}: <span class=\"state\">- - state</span>, <span class=\"faults\">- - faults</span>.",
                     detail::markup_escape(marker_summary(doc)));
  s += "</p>\n";
  for (std::size_t i = 0; i < doc.panels.size(); ++i)
    s += fmt::format("<div class=\"legend\" id=\"legend{0}\"></div><div class=\"panel\" id=\"panel{0}\"></div>\n", i);
  s += "<h2>State and fault changes</h2>\n";
  if (doc.markers_total == 0) {
    s += "<p class=\"note\">No state or fault changes in the plotted messages.</p>\n";
  } else {
    s += fmt::format("<p class=\"note\">{}</p>\n", detail::markup_escape(marker_summary(doc)));
    const bool seconds = seconds_axis(doc);
    s += fmt::format("<table>\n<tr><th>#</th><th>{}</th><th>timestamp</th><th>what</th><th>change</th></tr>\n",
                     seconds ? "time [s]" : "message");
    for (std::size_t i = 0; i < doc.markers.size(); ++i) {
      const auto& m = doc.markers[i];
      const auto start = start_time_in_title(m.when);
      s += fmt::format(
          "<tr class=\"{0}\"><td class=\"num\">{1}</td><td class=\"num\">{2}</td><td class=\"num\">{3}</td>"
          "<td>{0}</td><td>{4}</td></tr>\n",
          to_string(m.kind), i + 1, seconds ? fmt::format("{:.6f}", m.t) : fmt::format("{:.0f}", m.t),
          detail::markup_escape(start ? human_time(*start) : m.when), detail::markup_escape(m.detail));
    }
    s += "</table>\n";
    if (doc.markers_total > doc.markers.size())
      s += fmt::format("<p class=\"note\">{} more changes are neither marked nor listed.</p>\n",
                       doc.markers_total - doc.markers.size());
  }
  if (!doc.notes.empty()) {
    s += "<h2>Notes</h2>\n<ul>\n";
    for (const auto& note : doc.notes) s += fmt::format("<li>{}</li>\n", detail::markup_escape(note));
    s += "</ul>\n";
  }
  s += "<script type=\"application/json\" id=\"plot-data\">" + script_safe(json_line(page_data(doc)), true) + "</script>\n";
  s += "<script>" + page_script() + "</script>\n</body>\n</html>\n";
  return s;
}

std::string gnuplot_script(const PlotDocument& doc, const std::string& format, const std::string& output) {
  const std::size_t n = doc.panels.size();
  std::string s = "# saulctl plot: " + human_title(doc.title) + "\n";
  if (format == "png")
    s += fmt::format("set terminal pngcairo size 1600,{} font 'sans,10' background rgb 'white'\n", 110 + 300 * n);
  else if (format == "pdf")
    s += fmt::format("set terminal pdfcairo size 11.7in,{:.2f}in font 'sans,8'\n", 0.9 + 2.4 * static_cast<double>(n));
  else
    s += fmt::format("set terminal svg size 1200,{} dynamic font 'sans,11' background rgb 'white'\n", 90 + 260 * n);
  if (!output.empty()) s += "set output " + gp_single(output) + "\n";
  s += "set encoding utf8\nset termoption noenhanced\n";
  // The data, one datablock per panel, one index (two blank lines apart) per series.
  for (std::size_t p = 0; p < n; ++p) {
    s += fmt::format("$panel{} << EOD\n", p);
    const auto& series = doc.panels[p].series;
    for (std::size_t i = 0; i < series.size(); ++i) {
      if (i > 0) s += "\n\n";
      const auto points = series[i].binner.points();
      if (points.empty()) s += "NaN NaN\n";  // an index gnuplot can still address
      for (const auto& pt : points) s += fmt::format("{:.6f} {}\n", pt.t, pt.v);
    }
    s += "EOD\n";
  }
  std::string heading = human_title(doc.title);
  if (doc.markers_total > 0) heading += "\n" + marker_summary(doc);
  for (const auto& note : doc.notes) heading += "\n" + note;
  const double t1 = doc.t1 > doc.t0 ? doc.t1 : doc.t0 + 1;
  s += fmt::format("set multiplot layout {},1 title {} font ',12'\n", std::max<std::size_t>(n, 1), c_literal(heading));
  s += fmt::format("set xrange [{}:{}]\nset offsets 0, 0, graph 0.06, graph 0.06\nset grid lc rgb '#dddddd'\nset key top right horizontal opaque box lc rgb "
                   "'#cccccc'\nset lmargin 10\nset rmargin 3\n",
                   doc.t0, t1);
  for (std::size_t p = 0; p < n; ++p) {
    const auto& panel = doc.panels[p];
    s += fmt::format("set title {} left\nunset arrow\nunset label\n",
                     gp_single(fmt::format("{} ({} point{})", panel.title, panel.count(), panel.count() == 1 ? "" : "s")));
    s += p + 1 == n ? "set xlabel " + gp_single(time_axis_label(doc)) + "\n" : "unset xlabel\n";
    double last_label = -1e300;
    for (const auto& m : doc.markers) {
      s += fmt::format("set arrow from {0},graph 0 to {0},graph 1 nohead dt 2 lw 1 lc rgb '{1}'\n", m.t, colour_of(m.kind));
      if ((m.t - last_label) / (t1 - doc.t0) < 0.012) continue;  // labels closer than ~1% of the width would overlap
      s += fmt::format("set label {} at {},graph 0.97 rotate by -90 font ',8' tc rgb '{}' offset 0.4,0\n",
                       gp_single(m.label), m.t, colour_of(m.kind));
      last_label = m.t;
    }
    s += "plot ";
    for (std::size_t i = 0; i < panel.series.size(); ++i) {
      const auto& series = panel.series[i];
      const bool sparse = series.binner.points().size() <= kSparse;
      s += fmt::format("{}$panel{} index {} using 1:2 with {} lw {} dt {} lc rgb '{}' title {}", i ? ", \\\n     " : "",
                       p, i, sparse ? "linespoints pt 7 ps 0.6" : "lines", i == 0 ? "2" : i == 1 ? "1.5" : "1.2",
                       i % 5 + 1, colour_of(i), series.label.empty() ? "''" : gp_single(series.label));
    }
    s += "\n";
  }
  s += "unset multiplot\n";
  return s;
}

void render_static(const PlotDocument& doc, const std::string& format, const std::string& output) {
  char path[] = "/tmp/saulctl-plot-XXXXXX.gp";
  const int fd = ::mkstemps(path, 3);
  if (fd < 0) throw std::runtime_error("cannot write gnuplot's script to /tmp: check that /tmp is writable");
  const std::string script = gnuplot_script(doc, format, output);
  bool written = ::write(fd, script.data(), script.size()) == static_cast<ssize_t>(script.size());
  written = ::close(fd) == 0 && written;
  if (!written) {
    ::unlink(path);
    throw std::runtime_error("cannot write gnuplot's script to /tmp: is it full?");
  }
  char program[] = "gnuplot";
  char* argv[] = {program, path, nullptr};
  pid_t pid = 0;
  const int spawned = ::posix_spawnp(&pid, program, nullptr, nullptr, argv, environ);
  int status = 0;
  if (spawned == 0) ::waitpid(pid, &status, 0);
  ::unlink(path);
  if (spawned != 0)
    throw std::runtime_error(fmt::format("gnuplot cannot be run ({}): SVG, PNG and PDF are drawn by gnuplot; install it "
                                      "(apt install gnuplot-nox, or scripts/setup.sh), or write .html or .csv",
                                      std::strerror(spawned)));
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error(fmt::format("gnuplot failed ({}): see its message above; write .html or .csv meanwhile",
                                      WIFEXITED(status) ? fmt::format("exit {}", WEXITSTATUS(status)) : "killed"));
}

}  // namespace saul::host
