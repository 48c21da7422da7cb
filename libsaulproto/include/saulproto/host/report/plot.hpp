// How `saulctl plot` draws (what to draw is telemetry_plot.hpp's): panels of series on one time axis, with markers
// (state and fault changes) across every panel. Points are binned into columns keeping each column's first, lowest,
// highest and last value: constant memory, and spikes survive. Two outputs, neither drawn by hand: render_html, a
// self-contained page on Debian's dygraphs (inlined when written), and render_static, SVG, PNG or PDF by gnuplot.
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
  [[nodiscard]] std::uint64_t count() const;  ///< points of all series
};

/// What a marker marks: its colour, and the "what" column of the HTML table.
enum class MarkerKind : std::uint8_t { state, faults };
const char* to_string(MarkerKind kind) noexcept;  ///< "state", "faults"

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
  std::uint64_t markers_total = 0;  ///< changes in all; those beyond markers are counted in the picture
  std::vector<std::string> notes;   ///< lines under the title (what was left out, and why)
};

/// Columns of the default binning (telemetry_plot's document()). The renderers take any number.
inline constexpr int kPlotWidth = 880;
/// Columns for the interactive page: every sample of a 5-minute run at 100 Hz kept.
inline constexpr std::size_t kInteractiveColumns = 8192;
inline constexpr std::size_t kStaticColumns = 3000;  ///< for a static picture: about two a pixel

/// Seconds since 1970 of the plot's time 0, from the capture timestamp in the title ("from 1763800000.500900");
/// nullopt when it has none.
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
/// Reads them from Debian's libjs-dygraphs (`dir`). Throws std::runtime_error naming the package when absent.
DygraphsAssets load_dygraphs(const std::string& dir = "/usr/share/javascript/dygraphs");

/// One HTML page holding everything itself: a dygraphs chart per panel, zoom and pan shared by all, markers, a
/// table of the changes, the notes. Its <html> element gets data-plot-errors (script errors) and, once drawn,
/// data-plot-panels, data-plot-windows (each chart's window, s) and data-plot-points (charts showing their
/// points). page.html#t=A,B opens zoomed into A..B seconds.
std::string render_html(const PlotDocument& document, const DygraphsAssets& dygraphs);

/// The gnuplot script for a static picture: terminal (svg, png, pdf) and `output` ("" = standard output), the
/// data inline, one plot per panel stacked, markers as dashed vertical arrows with labels.
std::string gnuplot_script(const PlotDocument& document, const std::string& format, const std::string& output);
/// Runs gnuplot on gnuplot_script. Throws std::runtime_error (gnuplot missing, or failing with its message).
void render_static(const PlotDocument& document, const std::string& format, const std::string& output);

}  // namespace saul::host
