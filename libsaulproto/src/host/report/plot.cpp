#include "saulproto/host/report/plot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace saul::host {
namespace {

constexpr int kLeft = 70;
constexpr int kRight = 20;
constexpr int kHeader = 40;  // the title's band; info lines and the first panel title come below it
constexpr int kInfoLine = 16;
constexpr int kPanelHeight = 200;
constexpr int kPanelGap = 50;
constexpr int kBottom = 50;
constexpr std::size_t kDotsUpTo = 20;  // points of a series drawn as dots as well as a line
constexpr double kLabelSpacing = 12;   // px between marker labels in one lane (10 px text, rotated)
constexpr std::size_t kLabelChars = 32;  // characters of a marker label that fit down a panel

std::string plural(std::uint64_t n, const char* word) { return fmt::format("{} {}{}", n, word, n == 1 ? "" : "s"); }

constexpr const char* kSeriesColours[] = {"#1f77b4", "#2ca02c", "#d62728", "#8c564b", "#17becf", "#bcbd22"};
constexpr const char* kStateColour = "#9467bd";
constexpr const char* kFaultColour = "#ff7f0e";

const char* colour_of(std::size_t series) { return kSeriesColours[series % std::size(kSeriesColours)]; }
const char* colour_of(MarkerKind kind) { return kind == MarkerKind::state ? kStateColour : kFaultColour; }

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string axis_number(double v) {
  if (v == 0) return "0";
  const double a = std::fabs(v);
  if (a >= 1e5 || a < 1e-3) return fmt::format("{:.3g}", v);
  std::string s = fmt::format("{:.4f}", v);
  while (s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s;
}

std::string marker_summary(const PlotDocument& doc) {
  const auto drawn = static_cast<std::uint64_t>(doc.markers.size());
  if (drawn >= doc.markers_total)
    return fmt::format("{} state/fault change{}, all marked", doc.markers_total, doc.markers_total == 1 ? "" : "s");
  return fmt::format("{} state/fault changes: the first {} are marked, {} more are not", doc.markers_total, drawn,
                     doc.markers_total - drawn);
}

/// The picture; `standalone` adds the XML declaration and the SVG namespace a file of its own needs (inline in
/// HTML, the parser supplies the namespace).
std::string svg_of(const PlotDocument& doc, bool standalone) {
  const int width = kLeft + kPlotWidth + kRight;
  const int panels = static_cast<int>(doc.panels.size());
  const int info_lines = static_cast<int>(doc.notes.size()) + (doc.markers_total > 0 ? 1 : 0);
  const int first_top = kHeader + info_lines * kInfoLine + 8;
  const int height = first_top + panels * kPanelHeight + (panels > 0 ? panels - 1 : 0) * kPanelGap + kBottom;
  std::string s = standalone ? "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" "
                             : "<svg style=\"max-width: 100%; height: auto\" ";
  s += fmt::format(
      "width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" font-family=\"sans-serif\" font-size=\"12\">\n"
      "<rect width=\"{0}\" height=\"{1}\" fill=\"white\"/>\n"
      "<text x=\"{2}\" y=\"22\" font-size=\"15\">{3}</text>\n",
      width, height, kLeft, escape(doc.title));
  int info_y = kHeader;
  if (doc.markers_total > 0) {
    s += fmt::format("<text x=\"{}\" y=\"{}\">{}: <tspan fill=\"{}\">| state</tspan> <tspan fill=\"{}\">| faults"
                     "</tspan></text>\n",
                     kLeft, info_y, escape(marker_summary(doc)), kStateColour, kFaultColour);
    info_y += kInfoLine;
  }
  for (const auto& note : doc.notes) {
    s += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"#555\">{}</text>\n", kLeft, info_y, escape(note));
    info_y += kInfoLine;
  }
  const double t0 = doc.t0;
  const double t1 = doc.t1 > doc.t0 ? doc.t1 : doc.t0 + 1;
  const auto time_ticks = nice_ticks(t0, t1, 8);
  auto x_of = [&](double t) { return kLeft + (t - t0) / (t1 - t0) * kPlotWidth; };
  for (int p = 0; p < panels; ++p) {
    const PlotPanel& panel = doc.panels[static_cast<std::size_t>(p)];
    const int top = first_top + p * (kPanelHeight + kPanelGap);
    std::optional<double> low, high;
    for (const auto& series : panel.series) {
      if (const auto v = series.binner.min(); v && (!low || *v < *low)) low = v;
      if (const auto v = series.binner.max(); v && (!high || *v > *high)) high = v;
    }
    double lo = low.value_or(0);
    double hi = high.value_or(1);
    if (hi - lo < 1e-12) {
      lo -= 1;
      hi += 1;
    } else {
      const double pad = (hi - lo) * 0.05;
      lo -= pad;
      hi += pad;
    }
    auto y_of = [&](double v) { return top + (hi - v) / (hi - lo) * kPanelHeight; };
    s += fmt::format("<g>\n<text x=\"{}\" y=\"{}\" font-size=\"13\">{} ({})</text>\n", kLeft, top - 6,
                     escape(panel.title), plural(panel.count(), "point"));
    // Legend, right-aligned above the panel, when there is something to tell apart: one text, so the viewer lays
    // it out (SVG cannot measure text without a script).
    if (panel.series.size() > 1 || (panel.series.size() == 1 && !panel.series[0].label.empty())) {
      s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"end\">", kLeft + kPlotWidth, top - 6);
      for (std::size_t i = 0; i < panel.series.size(); ++i)
        s += fmt::format("<tspan{} fill=\"{}\">\u25A0</tspan> {}", i == 0 ? "" : " dx=\"14\"", colour_of(i),
                         escape(panel.series[i].label));
      s += "</text>\n";
    }
    s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#444\"/>\n", kLeft, top,
                     kPlotWidth, kPanelHeight);
    for (double v : nice_ticks(lo, hi, 5)) {
      const double y = y_of(v);
      s += fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#ddd\"/>"
                       "<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\">{}</text>\n",
                       kLeft, y, kLeft + kPlotWidth, y, kLeft - 6, y + 4, axis_number(v));
    }
    for (double t : time_ticks) {
      const double x = x_of(t);
      s += fmt::format("<line x1=\"{:.1f}\" y1=\"{}\" x2=\"{:.1f}\" y2=\"{}\" stroke=\"#eee\"/>"
                       "<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
                       x, top, x, top + kPanelHeight, x, top + kPanelHeight + 16, axis_number(t));
    }
    // Every marker gets its line (its tooltip says what it is). Labels run down from the panel's top, or from its
    // middle when the top one would touch the label before it; a third label in a crowd is left out (the tooltip
    // and the HTML table still have it). Long labels are shortened to their lane.
    std::optional<double> lane_x[2];
    for (const auto& m : doc.markers) {
      const double x = x_of(m.t);
      s += fmt::format("<line class=\"marker\" x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"{3}\" "
                       "stroke-dasharray=\"4,3\"><title>{4} s: {5} {6}</title></line>",
                       x, top, top + kPanelHeight, colour_of(m.kind), axis_number(m.t), to_string(m.kind),
                       escape(m.detail));
      for (std::size_t lane = 0; lane < 2; ++lane) {
        if (lane_x[lane] && x - *lane_x[lane] < kLabelSpacing) continue;
        const std::size_t room = lane == 0 ? kLabelChars : kLabelChars / 2;
        const std::string label = m.label.size() <= room ? m.label : m.label.substr(0, room - 1) + "\u2026";
        s += fmt::format("<text transform=\"translate({:.1f},{}) rotate(90)\" font-size=\"10\" fill=\"{}\">{}</text>",
                         x + 3, top + 4 + static_cast<int>(lane) * kPanelHeight / 2, colour_of(m.kind), escape(label));
        lane_x[lane] = x;
        break;
      }
      s += "\n";
    }
    for (std::size_t i = 0; i < panel.series.size(); ++i) {
      const auto points = panel.series[i].binner.points();
      if (points.empty()) continue;
      // Later series drawn thinner, so one that lies on an earlier one leaves it visible.
      s += fmt::format("<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"{}\" points=\"", colour_of(i),
                       i == 0 ? "2.4" : i == 1 ? "1.4" : "0.8");
      for (const auto& pt : points) s += fmt::format("{:.1f},{:.1f} ", x_of(pt.t), y_of(pt.v));
      s += "\"/>\n";
      // Sparse series get a dot per point too: a lone point draws no line.
      if (points.size() <= kDotsUpTo)
        for (const auto& pt : points)
          s += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{}\" fill=\"{}\"/>", x_of(pt.t), y_of(pt.v),
                           i == 0 ? "3" : "2", colour_of(i));
      if (points.size() <= kDotsUpTo) s += "\n";
    }
    s += "</g>\n";
  }
  s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n</svg>\n", kLeft + kPlotWidth / 2,
                   height - 12, escape(doc.time_label));
  return s;
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

std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(hi > lo) || target < 1) return {lo};
  const double raw = (hi - lo) / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = magnitude;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * magnitude;
    if (step >= raw) break;
  }
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (double t = first; t <= hi + step * 1e-9; t += step) ticks.push_back(std::fabs(t) < step * 1e-9 ? 0.0 : t);
  return ticks;
}

std::string render_svg(const PlotDocument& doc) { return svg_of(doc, true); }

std::string render_html(const PlotDocument& doc) {
  std::string s = fmt::format(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{0}</title>\n<style>\n"
      "body {{ font-family: sans-serif; margin: 16px; color: #222; }}\n"
      "h1 {{ font-size: 18px; }} h2 {{ font-size: 15px; margin-top: 24px; }}\n"
      "table {{ border-collapse: collapse; }}\n"
      "th, td {{ border: 1px solid #ccc; padding: 2px 8px; text-align: left; }}\n"
      "td.num {{ text-align: right; font-variant-numeric: tabular-nums; }}\n"
      ".state {{ color: {1}; }} .faults {{ color: {2}; }} .note {{ color: #555; }}\n"
      "</style>\n</head>\n<body>\n<h1>{0}</h1>\n",
      escape(doc.title), kStateColour, kFaultColour);
  s += svg_of(doc, false);
  s += "<h2>State and fault changes</h2>\n";
  if (doc.markers_total == 0) {
    s += "<p class=\"note\">No state or fault changes in the plotted messages.</p>\n";
  } else {
    s += fmt::format("<p class=\"note\">{}</p>\n", escape(marker_summary(doc)));
    // Times in seconds, unless the axis counts messages (a capture without timestamps).
    const bool seconds = doc.time_label.find("[s]") != std::string::npos;
    s += fmt::format("<table>\n<tr><th>#</th><th>{}</th><th>timestamp</th><th>what</th><th>change</th></tr>\n",
                     seconds ? "time [s]" : "message");
    for (std::size_t i = 0; i < doc.markers.size(); ++i) {
      const auto& m = doc.markers[i];
      s += fmt::format(
          "<tr class=\"{0}\"><td class=\"num\">{1}</td><td class=\"num\">{2}</td><td class=\"num\">{3}</td>"
          "<td>{0}</td><td>{4}</td></tr>\n",
          to_string(m.kind), i + 1, seconds ? fmt::format("{:.6f}", m.t) : fmt::format("{:.0f}", m.t),
          escape(m.when), escape(m.detail));
    }
    s += "</table>\n";
    if (doc.markers_total > doc.markers.size())
      s += fmt::format("<p class=\"note\">{} more changes are neither marked nor listed.</p>\n",
                       doc.markers_total - doc.markers.size());
  }
  if (!doc.notes.empty()) {
    s += "<h2>Notes</h2>\n<ul>\n";
    for (const auto& note : doc.notes) s += fmt::format("<li>{}</li>\n", escape(note));
    s += "</ul>\n";
  }
  s += "</body>\n</html>\n";
  return s;
}

}  // namespace saul::host
