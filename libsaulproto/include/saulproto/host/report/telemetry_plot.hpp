// What `saulctl plot` draws from a capture (plot.hpp draws it): the telemetry dashboard, or the fields of one
// message named by id or name, with a marker at each change of the robot state or fault bits. Two streaming passes
// (range, panels and changes; then the points binned): memory is constant in the capture's length.
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/report/plot.hpp"
#include "saulproto/host/report/serial_decode.hpp"

namespace saul::host {

/// One decoded message of a capture, as the plot sees it. Exactly one of bus and serial is set.
struct PlotMessage {
  std::optional<std::uint64_t> timestamp_ns;
  std::optional<std::uint32_t> can_id;  ///< the frame's id, for CAN messages
  std::string_view name;                ///< "telemetry_a", "vesc_status_1", "state", ...
  const BusMessage* bus = nullptr;
  const SerialMessage* serial = nullptr;
  /// The message's signals as its description reads them (none for an undecoded CRSF frame).
  [[nodiscard]] SignalValues values() const;
  /// A signal by its one name (signal_value: "pitch" in deg, "pitch_raw"); nullopt when the message lacks it.
  [[nodiscard]] std::optional<double> field(std::string_view signal_name) const;
};

using PlotSink = std::function<void(const PlotMessage&)>;
/// Gives every message, in order, to the sink. Called once per pass, it must give the same messages each time.
using PlotSource = std::function<void(const PlotSink&)>;

/// Every message of a capture file (CAN or serial), opened again on each call; corrupt records and frames that do
/// not decode are skipped. Throws CaptureOpenError. `fallback`: the protocol of serial links that name none.
PlotSource capture_plot_source(std::string path, SerialReadOptions options = {},
                               std::optional<SerialProtocol> fallback = std::nullopt);
/// Every frame of a list that decodes (decode_bus_frame), for frames already in memory.
PlotSource frames_plot_source(std::vector<CanFrame> frames);

// ---- what to draw -------------------------------------------------------------------------------------------

/// One line of a panel: a signal of a message by its name (PlotMessage::field: "pitch" in degrees).
struct PlotSeriesSpec {
  std::string label;   ///< legend; empty for a panel of one series that needs none
  std::string column;  ///< CSV column name
  std::string message;                  ///< the message's name, e.g. "telemetry_a"
  std::optional<std::uint32_t> can_id;  ///< and/or a CAN id: frames with this id (of that message, when named)
  std::string field;  ///< the signal's name ("pitch", "pitch_raw")
  std::optional<std::uint8_t> controller;  ///< VESC status frames: only from this controller_id
  /// The value this series takes from `m`, or nullopt when `m` is not its message (or controller).
  [[nodiscard]] std::optional<double> value(const PlotMessage& m) const;
};

struct PlotPanelSpec {
  std::string title;    ///< "pitch [deg]"
  std::string missing;  ///< the note when it has no data: "no 0x400 telemetry_a or inter-board state messages"
  std::vector<PlotSeriesSpec> series;
};

/// The default dashboard, in drawing order: pitch, pid_out (from 0x400 or the inter-board STATE), speed (reported
/// and commanded), wheel speed (0x401), VESC ERPM (STATUS), battery (0x401 and VESC STATUS_5).
std::vector<PlotPanelSpec> dashboard_panels();

// ---- state and fault changes ----------------------------------------------------------------------------------

/// A change of the robot state (0x400 state, UART STATE error_state) or of the fault bits (0x401 faults, UART
/// FAULT flags). The first state seen is a change from nothing; fault bits start from none.
struct StateChange {
  MarkerKind kind = MarkerKind::state;
  std::optional<unsigned> from;  ///< nullopt: the first state seen
  unsigned to = 0;
  std::optional<std::uint64_t> timestamp_ns;  ///< of the message that showed it (nullopt: the capture has none)
  std::uint64_t index = 0;                    ///< that message's number in the source, from 0
};

/// The robot state's name from the library ("OFF", "BALANCE", ... "FAULT"), or the number for a value it lacks.
std::string state_name(unsigned value);
/// Names of the set fault bits joined by '+' ("rc_loss+orin_timeout"), "none" for 0.
std::string fault_names(unsigned bits);
/// Drawn next to the marker: "BALANCE"; faults as bits set and cleared, "+rc_loss -estop".
std::string change_label(const StateChange& change);
/// For the table: "OFF -> BALANCE", "BALANCE (first seen)", "none -> rc_loss+orin_timeout".
std::string change_detail(const StateChange& change);

/// Follows state and fault values through a capture and keeps the first `keep` changes; counts all of them.
struct ChangeTracker {
  std::size_t keep = 0;
  std::vector<StateChange> kept{};
  std::uint64_t total = 0;
  std::optional<unsigned> state{};   ///< the last one seen
  std::optional<unsigned> faults{};  ///< the last bits seen (before any, none are set)
  /// Looks at one message; true when it reports a state or fault value (whether or not it changed).
  bool observe(const PlotMessage& m, std::uint64_t index, std::optional<std::uint64_t> timestamp_ns);
};

// ---- the plot ---------------------------------------------------------------------------------------------------

struct PlotRequest {
  std::string id;  ///< a CAN id ("0x400", "1024") or a message name ("state"); empty: the default dashboard
  /// With an id: signal names (docs/cli.md), one panel each; empty: every number signal. Without an id: empty.
  std::vector<std::string> fields;
  std::size_t max_markers = 40;  ///< changes drawn and listed at most (0: none); the rest are counted
  std::string source_name;       ///< the capture's name, for the title
};

/// A request that cannot be met as asked: a bad id, a signal the message lacks, fields without an id.
class PlotUsageError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};
/// Nothing to draw: the message is not in the capture, or none of the dashboard's messages is.
class PlotEmptyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Time 0 is the first message that gives a point or a state/fault value; the right edge is the last one. A
/// capture without any timestamps is drawn against the message number instead.
class TelemetryPlotter {
 public:
  /// Makes the first pass. Throws PlotUsageError, PlotEmptyError, and what the source throws.
  TelemetryPlotter(PlotRequest request, PlotSource source);

  [[nodiscard]] bool dashboard() const { return request_.id.empty(); }
  /// The panels that will be drawn, with the series that have data.
  [[nodiscard]] const std::vector<PlotPanelSpec>& panels() const { return panels_; }
  /// One note per dashboard panel left out: "VESC ERPM (STATUS): left out, no VESC STATUS (vesc_status_1) ...".
  [[nodiscard]] const std::vector<std::string>& left_out() const { return left_out_; }
  /// Messages that gave at least one point.
  [[nodiscard]] std::uint64_t messages() const { return messages_; }
  /// From the first point to the last, in seconds (0 without timestamps).
  [[nodiscard]] double points_span_s() const;
  [[nodiscard]] bool timed() const { return min_ns_.has_value(); }
  [[nodiscard]] const ChangeTracker& changes() const { return changes_; }

  /// Second pass: the picture, `columns` bins per series, for render_static or render_html.
  [[nodiscard]] PlotDocument document(std::size_t columns = kPlotWidth) const;
  /// Second pass: the numbers, "time_s" (untimed: "message") and one column per series drawn (the dashboard adds
  /// "state" and "faults" when the capture has them); a row per message giving any, empty cells for the rest.
  void write_csv(std::ostream& out) const;

 private:
  struct Position {
    std::optional<std::uint64_t> ns;  ///< nullopt: untimed, before any timestamp
    std::uint64_t index = 0;
  };
  template <class Visit>
  void each(const Visit& visit) const;  // visit(const PlotMessage&, Position)
  [[nodiscard]] double position(const Position& p) const;  // seconds, or message number
  void select(const PlotMessage& m);  // --id: check the first match, resolve its fields into panels_

  PlotRequest request_;
  PlotSource source_;
  std::optional<std::uint32_t> can_id_;  // the request's id when it is a number
  std::vector<PlotPanelSpec> panels_;
  std::vector<std::string> left_out_;
  ChangeTracker changes_;
  std::uint64_t messages_ = 0;
  std::optional<std::uint64_t> min_ns_, max_ns_;          // over messages that count
  std::optional<std::uint64_t> min_index_, max_index_;    // the same by message number
  std::optional<std::uint64_t> first_point_ns_, last_point_ns_;
};

}  // namespace saul::host
