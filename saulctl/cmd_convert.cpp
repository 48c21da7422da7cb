// saulctl convert: rewrite a capture file in another format (candump, pcap, pcapng, Vector ASC and BLF, PEAK TRC,
// python-can and SavvyCAN CSV; any of them gzip- or zstd-compressed).
// All the work is in the host library (saulproto/host/capture/capture.hpp); this file parses arguments and reports.
#include <fmt/core.h>

#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "capture_cli.hpp"
#include "commands.hpp"
#include "trace_cli.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/mcap.hpp"
#include "saulproto/host/report/mcap_signals.hpp"

#ifndef SAULCTL_VERSION
#define SAULCTL_VERSION "unknown"  // CMake sets it to the project version (packaging/CMakeLists.txt)
#endif

namespace saulctl {
namespace {

struct ConvertOptions {
  std::string in;
  std::string out;
  std::string format;  // output format; empty = from OUT's extension
  std::string input_format;  // empty = from IN's content
  std::string compression = "zstd";  // MCAP chunks
  int zstd_level = 1;                 // MCAP chunks in zstd
};

/// Reads through another reader and draws the progress line (copy_frames() does the reading).
class ProgressReader final : public saul::host::CaptureReader {
 public:
  ProgressReader(saul::host::CaptureReader& inner, Progress& progress) : inner_(inner), progress_(progress) {}
  Status next() override {
    const Status st = inner_.next();
    if (st != Status::end) progress_.update(inner_.bytes_read(), inner_.bytes_total());
    return st;
  }
  [[nodiscard]] const saul::CanFrame& frame() const override { return inner_.frame(); }
  [[nodiscard]] std::string_view interface() const override { return inner_.interface(); }
  [[nodiscard]] const saul::host::CaptureError& error() const override { return inner_.error(); }
  [[nodiscard]] saul::host::CaptureFormat format() const override { return inner_.format(); }

 private:
  saul::host::CaptureReader& inner_;
  Progress& progress_;
};

/// The MCAP writer's options from the command line.
saul::host::McapWriterOptions mcap_options(const ConvertOptions& opt) {
  saul::host::McapWriterOptions mcap;
  mcap.compression = *saul::host::mcap_compression_from_name(opt.compression);
  mcap.zstd_level = opt.zstd_level;
  // Chunks by size only: a file is no live recording, and chunks closed every second of log time (a slow bus:
  // ~770 frames, 220 KB) made 4.5x as many chunk indexes for the summary to keep (~0.4 KB each): 130 MB on 10 GB.
  mcap.chunk_ns = std::numeric_limits<std::uint64_t>::max();
  mcap.library = "saulctl " SAULCTL_VERSION;
  return mcap;
}

int run_convert(const ConvertOptions& opt) {
  using namespace saul::host;
  std::optional<CaptureFormat> format;
  if (!opt.format.empty()) format = capture_format_from_name(opt.format);
  if (is_trace(opt.in)) {  // a loop trace (saulctl tune record): MCAP, or else CSV
    if ((format ? format : capture_format_from_extension(opt.out)) == CaptureFormat::mcap)
      return convert_trace_mcap(opt.in, opt.out, mcap_options(opt),
                                {{"saulctl", SAULCTL_VERSION}, {"source", opt.in}, {"source_format", "loop trace"}});
    return convert_trace(opt.in, opt.out);
  }
  std::unique_ptr<CaptureReader> reader;
  std::unique_ptr<CaptureWriter> writer;
  try {
    reader = open_capture_reader(opt.in, input_format(opt.input_format));
    const auto out_format = format ? format : capture_format_from_extension(opt.out);
    if (out_format == CaptureFormat::mcap) {  // with the decoded signals' channels (report/mcap_signals.hpp)
      writer = open_mcap_signal_writer(opt.out, mcap_options(opt),
                                       {{"saulctl", SAULCTL_VERSION}, {"source", opt.in},
                                        {"source_format", std::string(to_string(reader->format()))}});
    } else {
      writer = open_capture_writer(opt.out, format);
    }
  } catch (const CaptureOpenError& e) {
    fmt::print(stderr, "saulctl convert: {}\n", e.what());
    return kFailure;
  }
  Progress progress("convert", false);
  ProgressReader shown(*reader, progress);
  CopyStats stats;
  try {
    stats = copy_frames(shown, *writer, [&opt, &progress](const CaptureError& error) {
      progress.finish();  // the message gets its own line
      fmt::print(stderr, "saulctl convert: {}\n", format_capture_error(opt.in, error));
    });
    writer->close();
  } catch (const std::invalid_argument& e) {  // a frame the output format cannot hold (more interfaces than it numbers)
    progress.finish();
    writer.reset();
    if (opt.out != "-") std::remove(opt.out.c_str());  // half a file is no capture
    fmt::print(stderr,
               "saulctl convert: cannot write {} as {}: {}; {} not written (a candump log or python-can CSV holds "
               "any number)\n",
               opt.in, opt.out, e.what(), opt.out);
    return kFailure;
  }
  progress.finish();
  if (stats.frames == 0 && stats.corrupt > 0) {  // as decode: nothing could be read is a failure, not an empty file
    if (opt.out != "-") std::remove(opt.out.c_str());
    fmt::print(stderr, "saulctl convert: nothing could be read from {} ({} corrupt records); {} not written\n", opt.in,
               stats.corrupt, opt.out);
    return kFailure;
  }
  for (const auto& note : conversion_losses(stats, writer->format()))
    fmt::print(stderr, "saulctl convert: note: {}\n", note);
  fmt::print(stderr, "saulctl convert: {} frames from {} ({}) to {} ({}); {} corrupt records skipped\n", stats.frames,
             opt.in, to_string(reader->format()), opt.out, to_string(writer->format()), stats.corrupt);
  return kOk;
}

}  // namespace

void add_convert_command(CLI::App& app, Runner& run) {
  auto opt = std::make_shared<ConvertOptions>();
  CLI::App* cmd = app.add_subcommand(
      "convert", "Convert a capture file between " + saul::host::capture_format_list(false));
  cmd->footer(
      "\nThe input format is told by the file's content (--input-format to force one); gzip and zstd files\n"
      "are decompressed on the fly. The output format comes from OUT's extension (.log .pcap .pcapng .asc\n"
      ".blf .trc .csv .mcap, then .gz or .zst to compress) unless --format says. What each format keeps:\n"
      "docs/captures.md. Corrupt input records are reported on stderr and skipped, as in decode; when\n"
      "nothing could be read, convert fails (exit 1) and leaves no OUT.\n"
      "\nExamples:\n"
      "  saulctl convert captures/robot_bus.log run.pcapng     open it in Wireshark\n"
      "  saulctl convert run.pcap run.asc                       for CANalyzer/CANoe or python-can\n"
      "  saulctl convert canoe.blf run.log.zst                  a BLF as a compressed candump log\n"
      "  saulctl convert run.log run.csv --format gvret-csv     for SavvyCAN\n"
      "  saulctl convert captures/robot_bus.log run.mcap        for Foxglove, Lichtblick, PlotJuggler: a\n"
      "                                                         channel per message kind, physical values\n"
      "  saulctl convert run.trace run.mcap                     a loop trace (tune record) on /saul/loop_trace\n"
      "                                                         (or run.csv: a column per field)\n"
      "  saulctl convert vector.asc run.log && canplayer -I run.log\n"
      "  ssh robot cat run.log.zst | saulctl convert - - --format pcap | wireshark -k -i -\n"
      "                                                         '-': standard input, standard output\n");
  cmd->add_option("IN", opt->in,
                  "capture file to read (" + saul::host::capture_format_list(false) + "; - = stdin)")
      ->required();
  cmd->add_option("OUT", opt->out, "file to write (replaced if it exists; - = stdout, with --format)")->required();
  cmd->add_option("--format", opt->format, "output format: candump, pcap, pcapng, asc, blf, trc, csv, gvret-csv or mcap")
      ->check(CLI::IsMember({"candump", "pcap", "pcapng", "asc", "blf", "trc", "csv", "gvret-csv", "mcap"}));
  cmd->add_option("--compression", opt->compression, "MCAP: how chunks are compressed: zstd (default), lz4 or none")
      ->check(CLI::IsMember({"none", "lz4", "zstd"}));
  cmd->add_option("--zstd-level", opt->zstd_level,
                  "MCAP: zstd's level, -7 (fastest, largest) to 19 (smallest, slowest); default 1")
      ->check(CLI::Range(-7, 19));
  add_input_format_option(cmd, opt->input_format);
  cmd->callback([opt, &run] { run = [opt] { return run_convert(*opt); }; });
}

}  // namespace saulctl
