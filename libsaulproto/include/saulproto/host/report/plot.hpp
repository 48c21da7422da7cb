// A small SVG line plot, written by hand (no plotting library): `saulctl plot`. Panels of one or more series, all
// on the same time axis, with vertical markers (the robot's state and fault changes) across every panel. Points
// are binned into one column per pixel keeping each column's first, lowest, highest and last value, so memory is
// constant in the number of points and spikes survive however long the capture. The same picture also comes
// wrapped in one self-contained HTML page with a table of the markers (render_html).
//
// What to draw from a capture (the default dashboard, --id/--field selections, the markers) is decided in
// telemetry_plot.hpp; this file only draws.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace saul::host {

/// Column binning of (time, value) points over a known time range.
class PlotBinner {
 public:
  PlotBinner(double t0, double t1, std::size_t columns);
  void add(double t, double value);
  struct Point {
    double t;
    double v;
  };
  /// Up to four points per non-empty column (first, min, max, last in time order).
  [[nodiscard]] std::vector<Point> points() const;
  [[nodiscard]] std::uint64_t count() const { return count_; }
  [[nodiscard]] std::optional<double> min() const { return min_; }
  [[nodiscard]] std::optional<double> max() const { return max_; }

 private:
  struct Column {
    bool used = false;
    Point first{}, last{}, low{}, high{};
  };
  double t0_, t1_;
  std::vector<Column> columns_;
  std::uint64_t count_ = 0;
  std::optional<double> min_, max_;
};

/// 1-2-5 tick positions covering [lo, hi] with about `target` ticks.
std::vector<double> nice_ticks(double lo, double hi, int target = 6);

/// One line of a panel.
struct PlotSeries {
  std::string label;  ///< legend text; a panel with one unlabelled series draws no legend
  PlotBinner binner;
};

struct PlotPanel {
  PlotPanel() = default;
  /// A panel of one series.
  PlotPanel(std::string panel_title, PlotBinner binner, std::string label = {})
      : title(std::move(panel_title)), series{PlotSeries{std::move(label), std::move(binner)}} {}
  std::string title;  ///< e.g. "0x400: pitch_x100", "pitch [deg]"
  std::vector<PlotSeries> series;
  /// Points of all series.
  [[nodiscard]] std::uint64_t count() const;
};

/// What a marker marks: its colour, and the "what" column of the HTML table.
enum class MarkerKind : std::uint8_t { state, faults };
/// "state", "faults".
const char* to_string(MarkerKind kind) noexcept;

/// A vertical line across every panel at one time, with a short label.
struct PlotMarker {
  double t = 0;  ///< on the time axis (same unit as PlotDocument::t0/t1)
  MarkerKind kind = MarkerKind::state;
  std::string label;   ///< drawn next to the line: "BALANCE", "+rc_loss"
  std::string detail;  ///< for the HTML table: "OFF -> BALANCE"
  std::string when;    ///< the capture's own timestamp ("1763800000.500900"), or ""
};

struct PlotDocument {
  std::string title;
  std::string time_label = "time since the first point [s]";
  double t0 = 0;  ///< seconds, the left edge
  double t1 = 1;  ///< the right edge
  std::vector<PlotPanel> panels;
  std::vector<PlotMarker> markers;  ///< drawn on every panel, in this order
  /// How many changes there were in all; markers.size() of them are drawn, the rest are counted in the picture.
  std::uint64_t markers_total = 0;
  /// Lines under the title (what was left out, and why).
  std::vector<std::string> notes;
};

/// Pixels of the plot area of each panel (PlotBinner columns should match it).
inline constexpr int kPlotWidth = 880;

/// The SVG document (UTF-8 text), a file of its own: XML declaration, namespace.
std::string render_svg(const PlotDocument& document);

/// One HTML page holding everything itself (no scripts, no links, nothing fetched): the same SVG inline, the
/// notes, and a table of the markers with their times.
std::string render_html(const PlotDocument& document);

}  // namespace saul::host
