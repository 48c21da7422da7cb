#include "saulproto/host/plot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace saul::host {
namespace {

constexpr int kLeft = 70;
constexpr int kRight = 20;
constexpr int kTop = 40;
constexpr int kPanelHeight = 200;
constexpr int kPanelGap = 50;
constexpr int kBottom = 50;

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

std::string number(double v) {
  if (v == 0) return "0";
  const double a = std::fabs(v);
  if (a >= 1e5 || a < 1e-3) return fmt::format("{:.3g}", v);
  std::string s = fmt::format("{:.4f}", v);
  while (s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s;
}

}  // namespace

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

std::string render_svg(const PlotDocument& doc) {
  const int width = kLeft + kPlotWidth + kRight;
  const int panels = static_cast<int>(doc.panels.size());
  const int height = kTop + panels * kPanelHeight + (panels > 0 ? panels - 1 : 0) * kPanelGap + kBottom;
  std::string s = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"sans-serif\" font-size=\"12\">\n"
      "<rect width=\"{0}\" height=\"{1}\" fill=\"white\"/>\n"
      "<text x=\"{2}\" y=\"22\" font-size=\"15\">{3}</text>\n",
      width, height, kLeft, escape(doc.title));
  const double t0 = doc.t0;
  const double t1 = doc.t1 > doc.t0 ? doc.t1 : doc.t0 + 1;
  const auto time_ticks = nice_ticks(t0, t1, 8);
  for (int p = 0; p < panels; ++p) {
    const PlotPanel& panel = doc.panels[static_cast<std::size_t>(p)];
    const int top = kTop + p * (kPanelHeight + kPanelGap);
    double lo = panel.binner.min().value_or(0);
    double hi = panel.binner.max().value_or(1);
    if (hi - lo < 1e-12) {
      lo -= 1;
      hi += 1;
    } else {
      const double pad = (hi - lo) * 0.05;
      lo -= pad;
      hi += pad;
    }
    auto x_of = [&](double t) { return kLeft + (t - t0) / (t1 - t0) * kPlotWidth; };
    auto y_of = [&](double v) { return top + (hi - v) / (hi - lo) * kPanelHeight; };
    s += fmt::format("<g>\n<text x=\"{}\" y=\"{}\" font-size=\"13\">{} ({} points)</text>\n", kLeft, top - 6,
                     escape(panel.title), panel.binner.count());
    s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#444\"/>\n", kLeft, top,
                     kPlotWidth, kPanelHeight);
    for (double v : nice_ticks(lo, hi, 5)) {
      const double y = y_of(v);
      s += fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#ddd\"/>"
                       "<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\">{}</text>\n",
                       kLeft, y, kLeft + kPlotWidth, y, kLeft - 6, y + 4, number(v));
    }
    for (double t : time_ticks) {
      const double x = x_of(t);
      s += fmt::format("<line x1=\"{:.1f}\" y1=\"{}\" x2=\"{:.1f}\" y2=\"{}\" stroke=\"#eee\"/>"
                       "<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
                       x, top, x, top + kPanelHeight, x, top + kPanelHeight + 16, number(t));
    }
    const auto points = panel.binner.points();
    if (!points.empty()) {
      s += "<polyline fill=\"none\" stroke=\"#1f77b4\" stroke-width=\"1.2\" points=\"";
      for (const auto& pt : points) s += fmt::format("{:.1f},{:.1f} ", x_of(pt.t), y_of(pt.v));
      s += "\"/>\n";
    }
    s += "</g>\n";
  }
  s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n</svg>\n", kLeft + kPlotWidth / 2,
                   height - 12, escape(doc.time_label));
  return s;
}

}  // namespace saul::host
