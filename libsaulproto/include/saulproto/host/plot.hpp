// A small SVG line plot, written by hand (no plotting library): `saulctl plot`. One panel per field, all on the
// same time axis. Points are binned into one column per pixel keeping each column's first, lowest, highest and
// last value, so memory is constant in the number of points and spikes survive however long the capture.
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

/// 1-2-5 tick positions covering [lo, hi] with about `target` ticks.
std::vector<double> nice_ticks(double lo, double hi, int target = 6);

struct PlotPanel {
  std::string title;  ///< e.g. "0x400 telemetry_a: pitch_x100"
  PlotBinner binner;
};

struct PlotDocument {
  std::string title;
  std::string time_label = "time since the first point [s]";
  double t0 = 0;  ///< seconds, the left edge
  double t1 = 1;  ///< the right edge
  std::vector<PlotPanel> panels;
};

/// Pixels of the plot area of each panel (PlotBinner columns should match it).
inline constexpr int kPlotWidth = 880;

/// The SVG document (UTF-8 text).
std::string render_svg(const PlotDocument& document);

}  // namespace saul::host
