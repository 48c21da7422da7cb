// saulctl plot: one or more fields of one message over time, as an SVG drawn by the host library
// (saulproto/host/plot.hpp) or as CSV for a spreadsheet or gnuplot. Two streaming passes over the file (the
// first finds the time range), so memory stays constant however long the capture.
#include <fmt/core.h>

#include <cstdio>
#include <fstream>
#include <functional>

#include "capture_cli.hpp"
#include "commands.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/capture.hpp"
#include "saulproto/host/plot.hpp"
#include "saulproto/host/serial_capture.hpp"
#include "saulproto/host/serial_decode.hpp"

namespace saulctl {
namespace {

struct PlotOptions {
  std::string file;
  std::string id;
  std::vector<std::string> fields;
  std::string output;
  SerialCliOptions serial;
};

/// A message of the selection: its time and a way to read its fields.
using FieldOf = std::function<std::optional<double>(std::string_view)>;
using NamesOf = std::function<std::vector<std::string>()>;
using Visit = std::function<void(std::optional<std::uint64_t> ns, const FieldOf& field, const NamesOf& names)>;

/// Calls visit for every message the selection names: a CAN id (0x400, or decimal) or a message name
/// (telemetry_a, state, vcu_command).
void for_each_selected(const PlotOptions& opt, const Visit& visit) {
  using namespace saul::host;
  std::optional<std::uint32_t> id;
  if (!opt.id.empty() && opt.id[0] >= '0' && opt.id[0] <= '9') {
    std::size_t used = 0;
    unsigned long v = 0;
    try {
      v = std::stoul(opt.id, &used, 0);
    } catch (...) {
      used = 0;
    }
    if (used == 0 || used != opt.id.size() || v > saul::CanFrame::kMaxExtendedId)
      throw CLI::ValidationError("--id", "bad id '" + opt.id + "' (a CAN id such as 0x400, or a message name)");
    id = static_cast<std::uint32_t>(v);
  }
  auto opened = open_capture(opt.file, serial_read_options(opt.serial));
  if (opened.frames) {
    for (;;) {
      const auto st = opened.frames->next();
      if (st == CaptureReader::Status::end) break;
      if (st == CaptureReader::Status::corrupt) continue;
      const saul::CanFrame& f = opened.frames->frame();
      if (id && f.id != *id) continue;
      const auto r = saul::decode_bus_frame(f);
      if (!r) continue;
      if (!id && opt.id != saul::name_of(r.value())) continue;
      const auto& m = r.value();
      visit(f.timestamp_ns, [&m](std::string_view name) { return numeric_field(m, name); },
            [&m] { return numeric_field_names(m); });
    }
    return;
  }
  if (id) throw CLI::ValidationError("--id", "a serial capture has no CAN ids: name the message (e.g. --id state)");
  SerialCaptureDecoder decoder(fallback_protocol(opt.serial));
  const SerialCaptureDecoder::Callback on = [&](const SerialChunk& chunk, SerialProtocol, const SerialMessage& m) {
    if (name_of(m) != opt.id) return;
    visit(chunk.timestamp_ns, [&m](std::string_view name) { return numeric_field(m, name); },
          [&m] { return numeric_field_names(m); });
  };
  for (;;) {
    const auto st = opened.chunks->next();
    if (st == SerialCaptureReader::Status::end) break;
    if (st == SerialCaptureReader::Status::corrupt) continue;
    decoder.add(opened.chunks->chunk(), on);
  }
  decoder.finish(on);
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

int run_plot(const PlotOptions& opt) {
  using namespace saul::host;
  std::string output = opt.output;
  if (output.empty()) {
    std::string base = opt.file.substr(opt.file.find_last_of('/') + 1);
    base = base.substr(0, base.find('.'));
    output = base + ".svg";
  }
  const std::string ext = output.substr(output.find_last_of('.') + 1);
  if (ext == "png")
    throw CLI::ValidationError("-o", "PNG needs a rasteriser: write .svg and convert it, e.g. rsvg-convert -o "
                                     "plot.png plot.svg");
  if (ext != "svg" && ext != "csv") throw CLI::ValidationError("-o", "write .svg (a picture) or .csv (the numbers)");

  // Pass 1: the time range, and whether the fields exist.
  std::optional<std::uint64_t> first, last;
  std::uint64_t found = 0;
  for_each_selected(opt, [&](std::optional<std::uint64_t> ns, const FieldOf& field, const NamesOf& names) {
    if (found++ == 0) {
      for (const auto& f : opt.fields)
        if (!field(f))
          throw CLI::ValidationError("--field", fmt::format("'{}' has no numeric field '{}': it has {}", opt.id, f,
                                                            join(names())));
    }
    if (!ns) return;
    if (!first || *ns < *first) first = ns;
    if (!last || *ns > *last) last = ns;
  });
  if (found == 0) {
    fmt::print(stderr, "saulctl plot: no '{}' in {}\n", opt.id, opt.file);
    return kFailure;
  }
  const std::uint64_t origin = first.value_or(0);
  auto rel = [origin](std::optional<std::uint64_t> ns) {
    return ns ? static_cast<double>(*ns - std::min(*ns, origin)) / 1e9 : 0.0;
  };

  std::ofstream out(output, std::ios::out | std::ios::trunc);
  if (!out) {
    fmt::print(stderr, "saulctl plot: cannot create '{}'\n", output);
    return kFailure;
  }
  if (ext == "csv") {
    out << "time_s";
    for (const auto& f : opt.fields) out << ',' << f;
    out << '\n';
    for_each_selected(opt, [&](std::optional<std::uint64_t> ns, const FieldOf& field, const NamesOf&) {
      out << fmt::format("{:.6f}", rel(ns));
      for (const auto& f : opt.fields) out << ',' << fmt::format("{:g}", field(f).value_or(0));
      out << '\n';
    });
  } else {
    PlotDocument doc;
    doc.title = fmt::format("{}: {} ({} messages from {})", opt.file.substr(opt.file.find_last_of('/') + 1), opt.id,
                            found, first ? fmt::format("{}.{:06}", origin / 1'000'000'000ULL,
                                                       (origin % 1'000'000'000ULL) / 1000)
                                         : std::string("untimed capture"));
    doc.t0 = 0;
    doc.t1 = rel(last);
    for (const auto& f : opt.fields)
      doc.panels.push_back(PlotPanel{fmt::format("{}: {}", opt.id, f), PlotBinner(doc.t0, doc.t1, kPlotWidth)});
    for_each_selected(opt, [&](std::optional<std::uint64_t> ns, const FieldOf& field, const NamesOf&) {
      for (std::size_t i = 0; i < opt.fields.size(); ++i)
        if (const auto v = field(opt.fields[i])) doc.panels[i].binner.add(rel(ns), *v);
    });
    out << render_svg(doc);
  }
  out.close();
  if (!out) {
    fmt::print(stderr, "saulctl plot: cannot write '{}'\n", output);
    return kFailure;
  }
  fmt::print(stderr, "saulctl plot: {} points of {} ({}) over {:.3f} s written to {}\n", found, opt.id,
             join(opt.fields), rel(last), output);
  return kOk;
}

}  // namespace

void add_plot_command(CLI::App& app, Runner& run) {
  auto opt = std::make_shared<PlotOptions>();
  auto* cmd = app.add_subcommand("plot", "Plot fields of one message over time (SVG, or CSV)");
  cmd->add_option("FILE", opt->file, "capture file (any format decode reads)")->required();
  cmd->add_option("--id", opt->id, "the message: a CAN id (0x400) or a message name (telemetry_a, state)")
      ->required();
  cmd->add_option("--field", opt->fields, "numeric field(s) to plot, one panel each (pitch_x100,pid_out)")
      ->required()
      ->delimiter(',');
  cmd->add_option("-o,--output", opt->output, "out.svg (a picture) or out.csv (the numbers); default FILE.svg");
  add_serial_read_options(cmd, opt->serial);
  cmd->footer(
      "\nDraws one panel per field against the time since the first point, as a plain SVG (any browser opens\n"
      "it). Long captures are binned to one column per pixel keeping each column's first, lowest, highest and\n"
      "last value, so spikes stay visible. .csv writes every point instead (time_s,field,...).\n"
      "\nExamples:\n"
      "  saulctl plot captures/robot_bus.log --id 0x400 --field pitch_x100 -o pitch.svg\n"
      "  saulctl plot run.log --id telemetry_a --field pitch_x100,pid_out,speed_mmps -o tuning.svg\n"
      "  saulctl plot captures/interboard_uart.serial --id state --field pitch_x100 -o state.csv\n");
  cmd->callback([opt, &run] {
    run = [opt]() -> int {
      try {
        return run_plot(*opt);
      } catch (const CLI::ValidationError& e) {
        fmt::print(stderr, "saulctl plot: {}\n", e.what());
        return kUsage;
      } catch (const saul::host::CaptureOpenError& e) {
        fmt::print(stderr, "saulctl plot: {}\n", e.what());
        return kFailure;
      }
    };
  });
}

}  // namespace saulctl
