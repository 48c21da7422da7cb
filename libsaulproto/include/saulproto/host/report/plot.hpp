// How `saulctl plot` draws: panels of one or more series, all on the same time axis, with vertical markers (the
// robot's state and fault changes) across every panel. Points are binned into columns keeping each column's
// first, lowest, highest and last value, so memory is constant in the number of points and spikes survive however
// long the capture.
//
// Two outputs, neither drawn by hand:
//  - render_html: one self-contained interactive page built on Debian's dygraphs (libjs-dygraphs, read from
//    /usr/share/javascript/dygraphs when the page is written and inlined; nothing is fetched when it is viewed):
//    zoom and pan, every panel following the others on a date-time axis, distinct colours and dash patterns,
//    sample points once zoomed in, the markers drawn on every panel and listed in a table;
//  - render_static: SVG, PNG or PDF by handing the data to gnuplot (Debian's gnuplot-nox) as a script.
//
// What to draw from a capture (the default dashboard, --id/--field selections, the markers) is decided in
// telemetry_plot.hpp; this file only draws.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
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

/// One line of a panel.
struct PlotSeries {
  std::string label;  ///< legend text; a panel with one unlabelled series draws no legend
  PlotBinner binner;
};

struct PlotPanel {
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

/// Columns of the default binning (telemetry_plot's document()). The renderers take any number.
inline constexpr int kPlotWidth = 880;
/// Columns for the interactive page: 4 points a column at most, so every sample of a 5-minute run at 100 Hz is
/// kept and a 300 ms push in a 10-minute run keeps its shape when zoomed into.
inline constexpr std::size_t kInteractiveColumns = 8192;
/// Columns for a static picture: about two a pixel of its width.
inline constexpr std::size_t kStaticColumns = 3000;

/// Seconds since 1970 of the plot's time 0, from the capture timestamp in the title ("from 1763800000.500900",
/// as telemetry_plot writes it); nullopt when the title has none (a capture without timestamps).
std::optional<double> start_time_in_title(const std::string& title);
/// "2025-11-22 08:26:40.500 UTC".
std::string human_time(double epoch_s);
/// The title with its raw capture timestamp written as human_time.
std::string human_title(const std::string& title);

/// The dygraphs files inlined into the page.
struct DygraphsAssets {
  std::string script;        ///< dygraph.min.js
  std::string style;         ///< dygraph.min.css
  std::string synchronizer;  ///< extras/synchronizer.js (panels zoom together)
};
/// Reads them from Debian's libjs-dygraphs (`dir`). Throws std::runtime_error naming the package when absent (a
/// plot that cannot be written: the message ends with what to do).
DygraphsAssets load_dygraphs(const std::string& dir = "/usr/share/javascript/dygraphs");

/// One HTML page holding everything itself (scripts and data inline, nothing fetched): a dygraphs chart per
/// panel at the window's full width, zoom (drag) and pan (shift-drag) shared by all panels, double-click to zoom
/// out; the title with a human date; markers on every panel; a table of the markers with their times; the notes.
/// The page sets data-plot-errors (script errors, from its first script on) and, once drawn, data-plot-panels
/// (charts drawn), data-plot-windows (each chart's time window, seconds) and data-plot-points (charts showing
/// their sample points) on its <html> element. page.html#t=A,B opens zoomed into A..B seconds.
std::string render_html(const PlotDocument& document, const DygraphsAssets& dygraphs);

/// The gnuplot script for a static picture: terminal (svg, png, pdf) and `output` ("" = standard output), the
/// data inline ($panelN datablocks), one plot per panel stacked (multiplot), markers as dashed vertical arrows with
/// labels, series told apart by colour, dash pattern and width.
std::string gnuplot_script(const PlotDocument& document, const std::string& format, const std::string& output);
/// Runs gnuplot on gnuplot_script. Throws std::runtime_error (gnuplot missing, or failing with its message).
void render_static(const PlotDocument& document, const std::string& format, const std::string& output);

}  // namespace saul::host
