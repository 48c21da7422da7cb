// saulctl plot: a capture's telemetry over time, state and fault changes marked, as an interactive HTML page, an
// SVG/PNG/PDF drawn by gnuplot, or CSV. What is drawn, and how, is the host library's (report/telemetry_plot.hpp,
// plot.hpp); this file picks the output format and writes the file.
#include <fmt/core.h>
#include <fmt/format.h>

#include <cctype>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "capture_cli.hpp"
#include "commands.hpp"
#include "trace_cli.hpp"
#include "grammar.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/report/plot.hpp"
#include "saulproto/host/report/telemetry_plot.hpp"

namespace saulctl {
namespace {

struct PlotOptions {
  std::string file;
  std::string id;
  std::vector<std::string> fields;
  std::string output;
  std::string format;
  std::size_t max_markers = saul::host::PlotRequest{}.max_markers;
  SerialCliOptions serial;
};

std::string plural(std::uint64_t n, const char* word) { return fmt::format("{} {}{}", n, word, n == 1 ? "" : "s"); }

std::string base_name(const std::string& path) { return path.substr(path.find_last_of('/') + 1); }

/// html, svg, png, pdf or csv: --format, else the extension of -o, else html.
std::string output_format(const PlotOptions& opt) {
  if (!opt.format.empty()) return opt.format;
  if (opt.output.empty() || opt.output == "-") return "html";
  const auto dot = opt.output.find_last_of('.');
  std::string ext = dot == std::string::npos ? "" : opt.output.substr(dot + 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == "html" || ext == "svg" || ext == "png" || ext == "pdf" || ext == "csv") return ext;
  if (ext == "htm") return "html";
  throw CLI::ValidationError("-o", "write .html (the interactive page), .svg, .png or .pdf (a picture) or .csv (the "
                                   "numbers), or say --format html|svg|png|pdf|csv");
}

int run_plot(const PlotOptions& opt) {
  using namespace saul::host;
  const std::string format = output_format(opt);
  refuse_read_once("plot", opt.file, "once for the time range and panels and again for the points");
  std::string output = opt.output;
  if (output.empty()) {
    std::string base = base_name(opt.file);
    base = base.substr(0, base.find('.'));
    output = base + "." + format;
  }
  if (is_trace(opt.file)) return plot_trace(opt.file, format, output);  // a loop trace (saulctl tune record)

  PlotRequest request{
      .id = opt.id, .fields = opt.fields, .max_markers = opt.max_markers, .source_name = base_name(opt.file)};
  if (!opt.id.empty() && opt.id[0] >= '0' && opt.id[0] <= '9') {
    // Ids are hex here as in every verb (docs/cli.md): 400 = 0x400.
    if (opt.id.find_first_of(":-") != std::string::npos)
      throw CLI::ValidationError("--id", "plot takes one id, not ID:MASK or a range");
    request.id = fmt::format("0x{:X}", id_filters({opt.id}).front().id);
  }
  // Pass 1 (time range, panels, state and fault changes) before anything is written.
  const SerialReadOptions read = serial_read_options(opt.serial);
  const TelemetryPlotter plotter(request, capture_plot_source(opt.file, read, read.protocol));
  for (const auto& note : plotter.left_out()) say("{}", note);

  if (format == "svg" || format == "png" || format == "pdf") {
    std::fflush(stdout);  // gnuplot writes to the same standard output with -o -
    render_static(plotter.document(kStaticColumns), format, output == "-" ? "" : output);
  } else {
    // The page's scripts are read before the file is created, so a missing package leaves no empty file behind.
    const auto dygraphs = format == "html" ? load_dygraphs() : DygraphsAssets{};
    std::ofstream file;
    if (output != "-") {
      file.open(output, std::ios::out | std::ios::trunc);
      if (!file) {
        say("cannot create '{}': check the folder exists and is writable", output);
        return kFailure;
      }
    }
    std::ostream& out = output == "-" ? std::cout : file;
    if (format == "csv")
      plotter.write_csv(out);
    else
      out << render_html(plotter.document(kInteractiveColumns), dygraphs);
    out.flush();
    if (file.is_open()) file.close();
    if (!out) {
      say("cannot write '{}': is the disk full?", output);
      return kFailure;
    }
  }

  std::vector<std::string> titles;
  for (const auto& panel : plotter.panels()) titles.push_back(panel.title);
  const std::string where = output == "-" ? std::string("stdout") : output;
  if (plotter.dashboard()) {
    say("{} over {:.3f} s in {} ({}) written to {}", plural(plotter.messages(), "message"), plotter.points_span_s(),
        plural(titles.size(), "panel"), fmt::join(titles, ", "), where);
  } else {
    std::vector<std::string> fields;
    for (const auto& panel : plotter.panels()) fields.push_back(panel.series.at(0).field);
    say("{} points of {} ({}) over {:.3f} s written to {}", plotter.messages(), opt.id, fmt::join(fields, ", "),
        plotter.points_span_s(), where);
  }
  const auto& changes = plotter.changes();
  if (format != "csv" && changes.total > 0) {
    if (changes.kept.size() == changes.total)
      say("{} marked", plural(changes.total, "state/fault change"));
    else
      say("{} state/fault changes, the first {} marked (--max-markers)", changes.total, changes.kept.size());
  }
  return kOk;
}

}  // namespace

void add_plot_command(CLI::App& app, Runner& run) {
  const auto plot = [](const PlotOptions& o) {
    try {
      return run_plot(o);
    } catch (const saul::host::PlotUsageError& e) {  // a bad --id or --field: a usage error (report_error: exit 2)
      throw CLI::ValidationError(e.what());
    }
  };
  auto [cmd, opt] = add_verb<PlotOptions>(
      app, run, "plot", "Plot a capture's telemetry over time, state and fault changes marked", plot);
  cmd->add_option("FILE", opt->file, "capture file (any format decode reads; - = standard input)")->required();
  cmd->add_option("-o,--output", opt->output,
                  "run.html, run.svg, run.png, run.pdf or run.csv (by the extension), - for stdout; default: FILE's "
                  "name with the format's extension");
  cmd->add_option("--format", opt->format, "html, svg, png, pdf or csv, whatever the extension of -o")
      ->check(CLI::IsMember({"html", "svg", "png", "pdf", "csv"}));
  cmd->add_option("--id", opt->id,
                  "plot one message instead of the dashboard: a CAN id in hex (400 = 0x400) or a message name (telemetry_a, state)");
  cmd->add_option("--field", opt->fields,
                  "with --id: signal name(s) as decode --json keys them, one panel each (pitch,pid_out; pitch_raw for the "
                  "wire integer; docs/cli.md); default every signal in its unit")
      ->delimiter(',');
  cmd->add_option("--max-markers", opt->max_markers,
                  "state/fault changes drawn and listed at most; the rest are counted (0: none)")
      ->capture_default_str();
  add_serial_read_options(cmd, opt->serial);
  cmd->footer(
      "\nWithout --id, draws the telemetry dashboard: pitch [deg] and pid_out (0x400, or the inter-board STATE\n"
      "message), speed reported (0x400) and commanded (0x300), wheel rpm (0x401), VESC ERPM (STATUS from\n"
      "controllers 68 and 56) and battery voltage (0x401, VESC STATUS_5). A panel whose messages are not in the\n"
      "capture is left out, and stderr says so. Every panel marks each change of the robot state (0x400 state,\n"
      "UART STATE error_state: OFF, BALANCE, MANUAL, ESTOP, TILT_CUTOFF, FAULT) and of the fault bits (0x401\n"
      "faults, UART FAULT flags: +rc_loss when set, -rc_loss when cleared) with a dashed line and its label; the\n"
      "first --max-markers changes are drawn, the picture counts the rest.\n"
      "\n"
      "Time 0 is the first plotted message (a capture without timestamps is drawn by message number). Long\n"
      "captures are binned into columns keeping each column's first, lowest, highest and last value, so spikes\n"
      "stay visible; two passes over the file, constant memory.\n"
      "\n"
      "Output, by the extension of -o or --format (default .html):\n"
      "  .html  one self-contained interactive page (Debian's dygraphs inlined, nothing fetched): drag to zoom,\n"
      "         shift-drag to pan, every panel follows on a date-time axis, sample points once zoomed in; then\n"
      "         a table of the state and fault changes with their times\n"
      "  .svg .png .pdf   a static report drawn by gnuplot (gnuplot-nox)\n"
      "  .csv   the numbers: time_s and one column per series drawn (plus state, faults), empty cells where a\n"
      "         message does not carry a column; with --id, time_s and the signals\n"
      "\n"
      "Examples:\n"
      "  saulctl plot run.log                             # run.html: the dashboard after a tuning run\n"
      "  saulctl plot run.log -o run.pdf                  # the same on paper\n"
      "  saulctl plot captures/robot_bus.log --format html -o - > bus.html\n"
      "  saulctl plot run.pcapng -o run.csv               # the dashboard's numbers for a spreadsheet\n"
      "  saulctl plot run.log --max-markers 200 -o run.png   # a run with many state/fault changes\n"
      "  saulctl plot captures/robot_bus.log --id 400 --field pitch -o pitch.svg   # in deg\n"
      "  saulctl plot run.log --id telemetry_a --field pitch,pid_out,speed_mmps -o tuning.svg\n"
      "  saulctl plot run.log --id 944 -o status.svg     # every signal of VESC STATUS from controller 68\n"
      "  saulctl plot captures/interboard_uart.serial --id state --field pitch,pitch_raw -o state.csv\n"
      "  saulctl plot captures/interboard_uart.serial -o uart.html   # pitch, pid_out, STATE and FAULT changes\n");
}

}  // namespace saulctl
