#include "saulproto/host/report/telemetry_plot.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <vector>
#include <ostream>
#include <utility>

#include "saulproto/core/interboard.hpp"
#include "saulproto/core/saul_can.hpp"
#include "saulproto/core/signals.hpp"
#include "saulproto/core/vesc.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/signal_rows.hpp"

namespace saul::host {

// ---- messages -------------------------------------------------------------------------------------------------

SignalValues PlotMessage::values() const {
  if (bus != nullptr) return signal_values(*bus);
  if (serial != nullptr) return signal_values(*serial);
  return {};
}

std::optional<double> PlotMessage::field(std::string_view signal_name) const {
  if (const auto v = signal_value(values(), signal_name)) return v->number;
  return std::nullopt;
}

namespace {

void emit_frame(const CanFrame& f, const PlotSink& sink) {
  const auto r = decode_bus_frame(f);
  if (!r) return;
  sink(PlotMessage{f.timestamp_ns, f.id, saul::name_of(r.value()), &r.value()});
}

}  // namespace

PlotSource capture_plot_source(std::string path, SerialReadOptions options, std::optional<SerialProtocol> fallback) {
  return [path = std::move(path), options, fallback](const PlotSink& sink) {
    auto opened = open_capture(path, options);
    if (opened.frames) {
      read_in_order(opened.frames, {}, [&](const FrameBatch& batch) {
        for (const CanFrame& f : batch.frames) emit_frame(f, sink);
        return true;
      });
      return;
    }
    SerialCaptureDecoder decoder(fallback);
    const SerialCaptureDecoder::Callback on = [&](const SerialChunk& chunk, SerialProtocol, const SerialMessage& m) {
      const std::string name = name_of(m);
      sink(PlotMessage{chunk.timestamp_ns, std::nullopt, name, nullptr, &m});
    };
    for (;;) {
      const auto st = opened.chunks->next();
      if (st == SerialCaptureReader::Status::end) break;
      if (st == SerialCaptureReader::Status::corrupt) continue;
      decoder.add(opened.chunks->chunk(), on);
    }
    decoder.finish(on);
  };
}

PlotSource frames_plot_source(std::vector<CanFrame> frames) {
  return [frames = std::move(frames)](const PlotSink& sink) {
    for (const CanFrame& f : frames) emit_frame(f, sink);
  };
}

// ---- what to draw -------------------------------------------------------------------------------------------

std::optional<double> PlotSeriesSpec::value(const PlotMessage& m) const {
  if (can_id && (!m.can_id || *m.can_id != *can_id)) return std::nullopt;
  if ((!can_id || !message.empty()) && m.name != message) return std::nullopt;
  if (controller) {
    const auto c = m.field("controller_id");
    if (!c || *c != *controller) return std::nullopt;
  }
  return m.field(field);
}

namespace {

const signals::SignalDesc& described(signals::Protocol protocol, std::uint32_t id, std::string_view name) {
  return *signals::find_signal(*signals::find(protocol, id), name);
}

// A series of one described signal, by its name: its physical value (pitch in deg), in the signal's unit.
PlotSeriesSpec series_of(const char* signal, std::string label, std::string column, std::string message,
                         std::optional<std::uint8_t> controller = std::nullopt) {
  return {std::move(label), std::move(column), std::move(message), std::nullopt, signal, controller};
}

// "pitch [deg]": `what` and the unit of a SAUL frame's signal.
std::string with_unit(std::string_view what, std::uint32_t id, std::string_view signal) {
  return fmt::format("{} [{}]", what, described(signals::Protocol::saul_can, id, signal).unit);
}

}  // namespace

std::vector<PlotPanelSpec> dashboard_panels() {
  using saulcan::TelemetryA;
  using saulcan::TelemetryB;
  using saulcan::VelocityCmd;
  const std::string uart_state = interboard::State::kName;
  const std::string status1 = vesc::Status1::kName;
  const std::string status5 = vesc::Status5::kName;
  const auto left = vesc::kLeftId;
  const auto right = vesc::kRightId;
  // Titles name the quantity and the description's unit. The VESC ERPM panel shows no unit (ERPM is one).
  return {
      {with_unit("pitch", TelemetryA::kId, "pitch"),
       "no 0x400 telemetry_a or inter-board state messages",
       {series_of("pitch", "0x400", "pitch", TelemetryA::kName),
        series_of("pitch", "UART state", "uart_pitch", uart_state)}},
      {with_unit("pid_out", TelemetryA::kId, "pid_out"),
       "no 0x400 telemetry_a or inter-board state messages",
       {series_of("pid_out", "0x400", "pid_out", TelemetryA::kName),
        series_of("pid_out", "UART state", "uart_pid_out", uart_state)}},
      {with_unit("speed", TelemetryA::kId, "speed_mmps"),
       "no 0x400 telemetry_a or 0x300 velocity_cmd frames",
       {series_of("speed_mmps", "reported (0x400)", "speed_mmps", TelemetryA::kName),
        series_of("speed_mmps", "commanded (0x300)", "speed_cmd_mmps", VelocityCmd::kName)}},
      {with_unit("wheel speed", TelemetryB::kId, "vesc_l_rpm") + " (0x401)",
       "no 0x401 telemetry_b frames",
       {series_of("vesc_l_rpm", "left", "wheel_l_rpm", TelemetryB::kName),
        series_of("vesc_r_rpm", "right", "wheel_r_rpm", TelemetryB::kName)}},
      {"VESC ERPM (STATUS)",
       fmt::format("no VESC STATUS (vesc_status_1) frames from controllers {} and {}", left, right),
       {series_of("erpm", fmt::format("left ({})", left), "vesc_l_erpm", status1, left),
        series_of("erpm", fmt::format("right ({})", right), "vesc_r_erpm", status1, right)}},
      {with_unit("battery", TelemetryB::kId, "battery"),
       fmt::format("no 0x401 telemetry_b or VESC STATUS_5 (vesc_status_5) frames from controllers {} and {}", left,
                   right),
       {series_of("battery", "0x401", "battery", TelemetryB::kName),
        series_of("voltage_in", fmt::format("VESC {}", left), "vesc_l_v", status5, left),
        series_of("voltage_in", fmt::format("VESC {}", right), "vesc_r_v", status5, right)}},
  };
}

// ---- state and fault changes ----------------------------------------------------------------------------------

namespace {
// The names of the fault bits (0x401 faults), from the description.
std::string bit_name(unsigned bit) {
  const auto& faults = described(signals::Protocol::saul_can, saulcan::TelemetryB::kId, "faults");
  const char* name = signals::value_name(faults, bit);
  return name != nullptr ? name : fmt::format("bit{}", bit);
}

/// The value a message reports in the CAN message Bus's field or the inter-board message Serial's, if it is one of
/// them.
template <class Bus, class B, class Serial, class S>
std::optional<unsigned> reported(const PlotMessage& m, B Bus::*bus_field, S Serial::*serial_field) {
  if (const auto* b = m.bus != nullptr ? std::get_if<Bus>(m.bus) : nullptr) return static_cast<unsigned>(b->*bus_field);
  const auto* ib = m.serial != nullptr ? std::get_if<interboard::Message>(m.serial) : nullptr;
  if (const auto* s = ib != nullptr ? std::get_if<Serial>(ib) : nullptr) return static_cast<unsigned>(s->*serial_field);
  return std::nullopt;
}
/// The robot state (0x400 state, UART STATE error_state) or fault bits (0x401 faults, UART FAULT flags) reported.
std::optional<unsigned> robot_state_of(const PlotMessage& m) {
  return reported(m, &saulcan::TelemetryA::state, &interboard::State::error_state);
}
std::optional<unsigned> fault_bits_of(const PlotMessage& m) {
  return reported(m, &saulcan::TelemetryB::faults, &interboard::Fault::flags);
}

/// [lo, hi] widened to hold v.
void widen(std::optional<std::uint64_t>& lo, std::optional<std::uint64_t>& hi, std::uint64_t v) {
  lo = std::min(lo.value_or(v), v);
  hi = std::max(hi.value_or(v), v);
}

/// "1763800000.500900": a capture timestamp as candump writes it.
std::string format_timestamp(std::uint64_t ns) {
  return fmt::format("{}.{:06}", ns / 1'000'000'000ULL, (ns % 1'000'000'000ULL) / 1000);
}
}  // namespace

std::string state_name(unsigned value) {  // the name the description gives 0x400's state
  const auto& state = described(signals::Protocol::saul_can, saulcan::TelemetryA::kId, "state");
  if (const char* name = signals::value_name(state, value)) return name;
  return std::to_string(value);
}

std::string fault_names(unsigned bits) {
  std::string s;
  for (unsigned bit = 0; bit < 8; ++bit)
    if ((bits & (1U << bit)) != 0) s += (s.empty() ? "" : "+") + bit_name(bit);
  return s.empty() ? "none" : s;
}

std::string change_label(const StateChange& c) {
  if (c.kind == MarkerKind::state) return state_name(c.to);
  const unsigned from = c.from.value_or(0);
  std::string s;
  for (const unsigned set : {1U, 0U})  // the bits set, then those cleared
    for (unsigned bit = 0; bit < 8; ++bit)
      if ((c.to >> bit & 1U) == set && (from >> bit & 1U) != set)
        s += (s.empty() ? "" : " ") + std::string(1, set ? '+' : '-') + bit_name(bit);
  return s;
}

std::string change_detail(const StateChange& c) {
  if (c.kind == MarkerKind::state)
    return c.from ? state_name(*c.from) + " -> " + state_name(c.to) : state_name(c.to) + " (first seen)";
  return fault_names(c.from.value_or(0)) + " -> " + fault_names(c.to);
}

bool ChangeTracker::observe(const PlotMessage& m, std::uint64_t index, std::optional<std::uint64_t> timestamp_ns) {
  auto note = [&](MarkerKind kind, std::optional<unsigned> from, unsigned to) {
    ++total;
    if (kept.size() < keep) kept.push_back(StateChange{kind, from, to, timestamp_ns, index});
  };
  const auto s = robot_state_of(m);
  if (s && state != s) note(MarkerKind::state, state, *s);
  const auto f = fault_bits_of(m);
  if (f && *f != faults.value_or(0)) note(MarkerKind::faults, faults, *f);
  if (s) state = s;
  if (f) faults = f;
  return s || f;
}

// ---- the plot ---------------------------------------------------------------------------------------------------

template <class Visit>
void TelemetryPlotter::each(const Visit& visit) const {
  std::uint64_t index = 0;
  std::optional<std::uint64_t> last_ns;
  source_([&](const PlotMessage& m) {
    if (m.timestamp_ns) last_ns = m.timestamp_ns;
    visit(m, Position{m.timestamp_ns ? m.timestamp_ns : last_ns, index++});
  });
}

double TelemetryPlotter::position(const Position& p) const {
  if (min_ns_) return p.ns ? static_cast<double>(*p.ns - std::min(*p.ns, *min_ns_)) / 1e9 : 0.0;
  return static_cast<double>(p.index - std::min(p.index, min_index_.value_or(0)));
}

double TelemetryPlotter::points_span_s() const {
  if (!first_point_ns_ || !last_point_ns_) return 0;
  return static_cast<double>(*last_point_ns_ - *first_point_ns_) / 1e9;
}

void TelemetryPlotter::select(const PlotMessage& m) {
  if (!panels_.empty()) return;
  const signals::MessageDesc* described_as = m.values().message;
  auto fields = request_.fields;
  if (fields.empty() && described_as != nullptr)  // every number signal in its unit (their _raw twins left out)
    for (const auto& s : described_as->signals)
      if (s.kind != signals::Kind::string) fields.emplace_back(s.name);
  for (const auto& f : fields)
    if (described_as == nullptr || !has_signal(*described_as, f))
      throw PlotUsageError(unknown_signal_error(fmt::format("'{}' ({})", request_.id, m.name), described_as, f));
  if (fields.empty()) throw PlotUsageError(fmt::format("'{}' has no numeric fields to plot", request_.id));
  for (const auto& f : fields) {
    const PlotSeriesSpec s{"", f, std::string(m.name), can_id_, f, std::nullopt};
    panels_.push_back(PlotPanelSpec{fmt::format("{}: {}", request_.id, f), {}, {s}});
  }
}

TelemetryPlotter::TelemetryPlotter(PlotRequest request, PlotSource source)
    : request_(std::move(request)), source_(std::move(source)), changes_{request_.max_markers} {
  const std::string& id = request_.id;
  if (id.empty() && !request_.fields.empty())
    throw PlotUsageError("--field needs --id: the fields of which message?");
  if (!id.empty() && id[0] >= '0' && id[0] <= '9') {
    std::size_t used = 0;
    unsigned long v = 0;
    try {
      v = std::stoul(id, &used, 0);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != id.size() || v > CanFrame::kMaxExtendedId)
      throw PlotUsageError("bad id '" + id + "' (a CAN id such as 0x400, or a message name)");
    can_id_ = static_cast<std::uint32_t>(v);
  }
  const std::vector<PlotPanelSpec> dashboard = dashboard_panels();
  std::vector<std::vector<std::uint64_t>> counts(dashboard.size());
  for (std::size_t p = 0; p < dashboard.size(); ++p) counts[p].assign(dashboard[p].series.size(), 0);

  each([&](const PlotMessage& m, const Position& pos) {
    bool point = false;
    if (this->dashboard()) {
      for (std::size_t p = 0; p < dashboard.size(); ++p)
        for (std::size_t s = 0; s < dashboard[p].series.size(); ++s)
          if (dashboard[p].series[s].value(m)) {
            ++counts[p][s];
            point = true;
          }
    } else {
      if (can_id_ && m.serial != nullptr)
        throw PlotUsageError("a serial capture has no CAN ids: name the message (e.g. --id state)");
      if (can_id_ ? (m.can_id && *m.can_id == *can_id_) : m.name == id) {
        select(m);
        // By id: only messages of the first one's type (a 29-bit VESC frame can have the id of a SAUL frame).
        point = panels_.front().series.front().value(m).has_value();
      }
    }
    const bool reports = changes_.observe(m, pos.index, pos.ns);
    if (!point && !reports) return;
    if (point) ++messages_;
    if (point && pos.ns) widen(first_point_ns_, last_point_ns_, *pos.ns);
    if (pos.ns) widen(min_ns_, max_ns_, *pos.ns);
    widen(min_index_, max_index_, pos.index);
  });

  if (!this->dashboard()) {
    if (messages_ == 0) throw PlotEmptyError(fmt::format("no '{}' in {}", id, request_.source_name));
    return;
  }
  for (std::size_t p = 0; p < dashboard.size(); ++p) {
    PlotPanelSpec panel = dashboard[p];
    panel.series.clear();
    for (std::size_t s = 0; s < dashboard[p].series.size(); ++s)
      if (counts[p][s] > 0) panel.series.push_back(dashboard[p].series[s]);
    if (panel.series.empty())
      left_out_.push_back(fmt::format("{}: left out, {}", dashboard[p].title, dashboard[p].missing));
    else
      panels_.push_back(std::move(panel));
  }
  if (panels_.empty())
    throw PlotEmptyError(fmt::format(
        "none of the dashboard's messages (0x400 telemetry_a, 0x401 telemetry_b, 0x300 velocity_cmd, VESC STATUS "
        "and STATUS_5, inter-board state) is in {}: name a message with --id and --field",
        request_.source_name));
}

PlotDocument TelemetryPlotter::document(std::size_t columns) const {
  PlotDocument doc;
  const std::string from = min_ns_ ? format_timestamp(*min_ns_) : std::string("an untimed capture");
  doc.title = fmt::format("{}: {} ({} message{} from {})", request_.source_name,
                          dashboard() ? std::string("telemetry") : request_.id, messages_, messages_ == 1 ? "" : "s",
                          from);
  doc.time_label = timed() ? "time since the first plotted message [s]"
                           : "message number (the capture has no timestamps)";
  doc.t1 = timed() ? static_cast<double>(*max_ns_ - *min_ns_) / 1e9
                   : static_cast<double>(max_index_.value_or(0) - min_index_.value_or(0));
  for (const auto& spec : panels_) {
    PlotPanel& panel = doc.panels.emplace_back(PlotPanel{spec.title, {}});
    for (const auto& s : spec.series) panel.series.push_back(PlotSeries{s.label, PlotBinner(doc.t0, doc.t1, columns)});
  }
  each([&](const PlotMessage& m, const Position& pos) {
    double t = -1;
    for (std::size_t p = 0; p < panels_.size(); ++p)
      for (std::size_t s = 0; s < panels_[p].series.size(); ++s)
        if (const auto v = panels_[p].series[s].value(m)) {
          if (t < 0) t = position(pos);
          doc.panels[p].series[s].binner.add(t, *v);
        }
  });
  for (const auto& c : changes_.kept)
    doc.markers.push_back({position(Position{c.timestamp_ns, c.index}), c.kind, change_label(c), change_detail(c),
                           c.timestamp_ns ? format_timestamp(*c.timestamp_ns) : ""});
  doc.markers_total = changes_.total;
  doc.notes = left_out_;
  return doc;
}

void TelemetryPlotter::write_csv(std::ostream& out) const {
  out << (timed() ? "time_s" : "message");
  for (const auto& panel : panels_)
    for (const auto& s : panel.series) out << ',' << s.column;
  const bool states = dashboard() && changes_.state.has_value();
  const bool faults = dashboard() && changes_.faults.has_value();
  if (states) out << ",state";
  if (faults) out << ",faults";
  out << '\n';
  std::string row;
  each([&](const PlotMessage& m, const Position& pos) {
    row.clear();
    bool any = false;
    auto cell = [&](const auto& value) {  // an empty cell for what the message does not carry
      row += ',';
      if (value) row += fmt::format("{}", *value);
      any = any || value.has_value();
    };
    for (const auto& panel : panels_)
      for (const auto& s : panel.series) cell(s.value(m));
    if (states) cell(robot_state_of(m));
    if (faults) cell(fault_bits_of(m));
    if (!any) return;
    const double t = position(pos);
    out << (timed() ? fmt::format("{:.6f}", t) : fmt::format("{:.0f}", t)) << row << '\n';
  });
}

}  // namespace saul::host
