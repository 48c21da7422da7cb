// saulctl tune report / tune compare: a trace of the balance loop (a CSV of named columns, or a CAN capture's 10 Hz
// telemetry) analysed by the host library (saulproto/host/tune) and printed as text, JSON or an HTML page.
#include <fmt/core.h>

#include <fstream>
#include <memory>

#include "commands.hpp"
#include "saulproto/host/tune/analysis.hpp"
#include "saulproto/host/report/plot.hpp"
#include "saulproto/host/tune/report.hpp"
#include "saulproto/host/tune/report_html.hpp"
#include "saulproto/host/tune/series.hpp"

namespace saulctl {
namespace {

namespace tune = saul::host::tune;

struct TuneReportOptions {
  std::vector<std::string> files;
  bool json = false;
  std::string output;  ///< report: the HTML page, when given
};

/// Reads and analyses one file; prints the refusal (file and why) and returns nullopt when it cannot be read.
std::optional<tune::Report> analyse_file(const char* verb, const std::string& file) {
  try {
    return tune::analyse(tune::read_series(file));
  } catch (const tune::SeriesError& e) {
    fmt::print(stderr, "saulctl tune {}: {}\n", verb, e.what());
    return std::nullopt;
  }
}

int run_report(const TuneReportOptions& opt) {
  // The page's scripts are read first, so a missing package leaves no half-written page behind.
  const auto dygraphs = opt.output.empty() ? saul::host::DygraphsAssets{} : saul::host::load_dygraphs();
  std::optional<tune::Series> series;
  try {
    series = tune::read_series(opt.files.front());
  } catch (const tune::SeriesError& e) {
    say("{}", e.what());
    return kFailure;
  }
  if (series->size() < 2) {
    say("{}: {} record(s) read: nothing to analyse{}", opt.files.front(),
        series->size(), series->problems.empty() ? "" : " (the first problem: " + series->problems.front() + ")");
    return kFailure;
  }
  const auto report = std::optional<tune::Report>(tune::analyse(*series));
  if (!opt.output.empty()) {
    std::ofstream page(opt.output, std::ios::out | std::ios::trunc);
    page << tune::render_html(*report, *series, dygraphs);
    page.close();
    if (!page) {
      say("cannot write '{}': check the folder exists and is writable",
          opt.output);
      return kFailure;
    }
    say("the page is {}", opt.output);
  }
  if (opt.json)
    fmt::print("{}\n", tune::to_json(*report).dump());
  else
    fmt::print("{}", tune::to_text(*report));
  if (opt.json && report->problems_total > 0)
    say("{} input problem(s), the first: {}", report->problems_total,
        report->problems.front());
  return kOk;
}

int run_compare(const TuneReportOptions& opt) {
  std::vector<tune::Report> reports;
  for (const auto& file : opt.files) {
    auto report = analyse_file("compare", file);
    if (!report) return kFailure;
    reports.push_back(std::move(*report));
  }
  if (opt.json)
    fmt::print("{}\n", tune::compare_json(reports).dump());
  else
    fmt::print("{}", tune::compare_text(reports));
  return kOk;
}

/// The files, --json and the runner: what report and compare share.
struct Wiring {
  const char* positional;
  const char* positional_help;
  int min_files, max_files;
  const char* json_help;
};
void wire(CLI::App* cmd, const std::shared_ptr<TuneReportOptions>& opt, Runner& run,
          int (*body)(const TuneReportOptions&), const Wiring& w) {
  cmd->add_option(w.positional, opt->files, w.positional_help)->required()->expected(w.min_files, w.max_files);
  cmd->add_flag("--json", opt->json, w.json_help);
  cmd->callback([opt, body, &run] { run = [opt, body] { return body(*opt); }; });
}

}  // namespace

void add_tune_report_commands(CLI::App& tune_cmd, Runner& run) {
  auto opt = std::make_shared<TuneReportOptions>();
  auto* report = tune_cmd.add_subcommand("report", "What a trace says about the balance loop's tuning");
  report->footer(
      "\nFILE is a loop trace (saulctl tune record: 1 kHz, with the gains it ran with), a CSV with a header naming\n"
      "its columns (time_s, setpoint_deg, pitch_deg needed; rate_dps, p_term, i_term, d_term, output, excite, state\n"
      "used when there; saulctl convert run.trace out.csv writes one) or a\n"
      "CAN capture, whose 10 Hz telemetry (0x400) gives pitch RMS, offset, drift, saturation and falls only: a step\n"
      "response or a spectrum from 10 Hz samples would be wrong, so it is refused with the reason.\n"
      "The step response (setpoint -> pitch) is estimated by regularised deconvolution over 8 s windows where the\n"
      "setpoint moves (an excitation: chirp, PRBS, steps) and measured directly at held setpoint steps; spectra of\n"
      "the pitch rate, D term and output show an oscillation as a peak 40x the median of its octave (1-100 Hz).\n"
      "A CSV comment '# kp=30 ki=2 kd=1.5' gives the gains. Rows that are not numbers or go back in time are left\n"
      "out and told (file:line). docs/tuning.md explains every figure.\n"
      "\nExamples:\n"
      "  saulctl tune report run.csv                       the figures, each with what it means and a verdict\n"
      "  saulctl tune report --json run.csv | jq .step.overshoot_pct\n"
      "  saulctl tune report run.csv -o report.html        and the charts, to open in a browser\n"
      "  saulctl tune report captures/robot_bus.log        10 Hz telemetry: what it can say, and what not\n");
  report->add_option("-o,--output", opt->output,
                     "also write the charts as one HTML page (report.html: step response, spectra, the trace with "
                     "the excitation marked)");
  wire(report, opt, run, run_report, {"FILE", "a loop trace, a CSV of named columns, or a CAN capture", 1, 1,
                                      "one JSON object instead of the text (docs/tuning.md lists its keys)"});

  auto copt = std::make_shared<TuneReportOptions>();
  auto* compare = tune_cmd.add_subcommand("compare", "The figures of several traces side by side, with their gains");
  compare->footer(
      "\nEach FILE is analysed as tune report does; the table has one column a file: gains (a trace's own, or a CSV comment\n"
      "'# kp=30 ki=2 kd=1.5'), sample rate, gaps, pitch RMS, saturation, step response figures, oscillation.\n"
      "\nExamples:\n"
      "  saulctl tune compare soft.csv shipped.csv stiff.csv\n"
      "  saulctl tune compare --json a.csv b.csv | jq '.[].step.overshoot_pct'\n");
  wire(compare, copt, run, run_compare, {"FILES", "two or more traces, CSVs or captures", 2, 64,
                                         "a JSON array of tune report's objects instead of the table"});
}

}  // namespace saulctl
