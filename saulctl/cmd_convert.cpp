// saulctl convert: rewrite a capture file in another format (candump, pcap, pcapng, Vector ASC and BLF, PEAK TRC,
// python-can and SavvyCAN CSV; any of them gzip- or zstd-compressed).
// All the work is in the host library (saulproto/host/capture/capture.hpp); this file parses arguments and reports.
#include <fmt/core.h>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "capture_cli.hpp"
#include "commands.hpp"
#include "trace_cli.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/mcap.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/mcap_serial.hpp"
#include "saulproto/host/report/mcap_signals.hpp"

namespace saulctl {
namespace {

struct ConvertOptions {
  std::string in;
  std::string out;
  std::string format;  // output format; empty = from OUT's extension
  SerialCliOptions serial;  // --input-format (empty = from IN's content), --protocol, --samplerate
  std::string compression = "zstd";  // MCAP chunks
  int zstd_level = -2;  // zstd --fast=2: faster than level 1 for a slightly larger file (bench/README.md)
  // 4 MiB chunks: the summary keeps a Chunk Index (~0.4 KB) per chunk to the end, so its memory grows as they shrink.
  std::uint64_t chunk_bytes = std::uint64_t{4} << 20;
  std::string parallel_from;  // --parallel-from
  std::string block_size = "512K";  // --block-size
};

/// The MCAP writer's options from the command line. Chunks by size only: closed every second of a slow bus's log
/// time they would be many small ones, each with a chunk index for the summary to keep.
saul::host::McapWriterOptions mcap_options(const ConvertOptions& opt) {
  return {.compression = *saul::host::mcap_compression_from_name(opt.compression),
          .zstd_level = opt.zstd_level,
          .chunk_bytes = opt.chunk_bytes,
          .chunk_ns = std::numeric_limits<std::uint64_t>::max(),
          .library = "saulctl " SAULCTL_VERSION};
}

/// A serial byte capture to MCAP: each link's decoded messages on channels of their own, the bytes on
/// /serial/bytes (report/mcap_serial.hpp). Corrupt lines and each link's decoder counters reported as decode does.
int run_convert_serial(const ConvertOptions& opt, saul::host::SerialCaptureReader& reader) {
  using namespace saul::host;
  std::ofstream file;
  if (opt.out != "-") file.open(opt.out, std::ios::binary | std::ios::trunc);
  std::ostream& stream = opt.out == "-" ? std::cout : file;
  if (!stream) {
    say("cannot create '{}'", opt.out);
    return kFailure;
  }
  std::uint64_t chunks = 0, corrupt = 0, untimed = 0;
  std::optional<std::uint64_t> messages;
  std::vector<SerialCaptureDecoder::Link> links;
  Progress progress("convert", false);
  try {
    McapSerialWriter mcap(stream, mcap_options(opt),
                          {{"saulctl", SAULCTL_VERSION}, {"source", opt.in},
                           {"source_format", std::string(to_string(reader.format()))}},
                          serial_read_options(opt.serial).protocol);
    read_serial_chunks(opt.in, reader, progress, corrupt, [&](const SerialChunk& chunk) {
      ++chunks;
      if (!chunk.timestamp_ns) ++untimed;
      mcap.write(chunk);
    });
    mcap.close();
    messages = mcap.channels().messages();
    links = mcap.channels().decoder().links();
  } catch (const std::runtime_error& e) {  // the stream failed (a full disk)
    progress.finish();
    say("cannot write '{}': {}", opt.out, e.what());
  }
  progress.finish();
  if (messages && chunks == 0 && corrupt > 0) {
    say("nothing could be read from {} ({} corrupt lines); {} not written", opt.in, corrupt, opt.out);
    messages.reset();
  }
  if (!messages) {
    if (opt.out != "-") {
      file.close();
      std::remove(opt.out.c_str());
    }
    return kFailure;
  }
  if (untimed > 0)
    say("{}: {} chunks carry no time, written at log time 0 (sample numbers need --samplerate)", opt.in, untimed);
  for (const auto& link : links)
    say("{}: {} ({}{}): {}", opt.in, link.name, to_string(link.protocol),
        link.guessed ? ", guessed from the bytes" : "", link.counters_text);
  say("{} serial messages from {} ({}) to {} (MCAP, /serial/...); {} corrupt lines "
      "skipped", *messages, opt.in, to_string(reader.format()), opt.out, corrupt);
  return kOk;
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
  const auto out_format = format ? format : capture_format_from_extension(opt.out);
  OpenedCapture opened = open_capture(opt.in, serial_read_options(opt.serial));
  if (opened.chunks) {  // serial bytes: their decoded messages, to MCAP only
    if (out_format == CaptureFormat::mcap) return run_convert_serial(opt, *opened.chunks);
    say("'{}' holds serial bytes ({}), which convert writes as MCAP only (each link's "
        "decoded messages): name the output .mcap or give --format mcap; saulctl decode prints them",
        opt.in, to_string(opened.format));
    return kFailure;
  }
  std::unique_ptr<CaptureReader> reader = std::move(opened.frames);
  const bool compressed = opened.compressed;
  // MCAP with the decoded signals' channels (report/mcap_signals.hpp)
  std::unique_ptr<CaptureWriter> writer =
      out_format == CaptureFormat::mcap
          ? open_mcap_signal_writer(opt.out, mcap_options(opt),
                                    {{"saulctl", SAULCTL_VERSION}, {"source", opt.in},
                                     {"source_format", std::string(to_string(reader->format()))}})
          : open_capture_writer(opt.out, format);
  Progress progress("convert", false);
  const auto total = reader->bytes_total();
  const CaptureFormat in_format = reader->format();  // the read path may take the reader (a compressed candump log)
  const ReadOptions read{.parallel_from = parse_size_option("--parallel-from", opt.parallel_from),
                         .block = parse_size_option("--block-size", opt.block_size)};
  CopyStats stats;
  try {
    stats = copy_frames(
        reader, *writer,
        corrupt_reporter(opt.in, &progress),
        [&](std::uint64_t records, std::uint64_t bytes) { progress.read_so_far(records, bytes, total); }, opt.in,
        compressed, read);
    writer->close();
  } catch (const std::invalid_argument& e) {  // a frame the output format cannot hold (more interfaces than it numbers)
    progress.finish();
    writer.reset();
    if (opt.out != "-") std::remove(opt.out.c_str());  // half a file is no capture
    say("cannot write {} as {}: {}; {} not written (a candump log or python-can CSV holds "
        "any number)",
        opt.in, opt.out, e.what(), opt.out);
    return kFailure;
  }
  progress.finish();
  if (stats.frames == 0 && stats.corrupt > 0) {  // as decode: nothing could be read is a failure, not an empty file
    if (opt.out != "-") std::remove(opt.out.c_str());
    say("nothing could be read from {} ({} corrupt records); {} not written", opt.in, stats.corrupt, opt.out);
    return kFailure;
  }
  for (const auto& note : conversion_losses(stats, writer->format())) say("note: {}", note);
  say("{} frames from {} ({}) to {} ({}); {} corrupt records skipped", stats.frames,
      opt.in, to_string(in_format), opt.out, to_string(writer->format()), stats.corrupt);
  return kOk;
}

}  // namespace

void add_convert_command(CLI::App& app, Runner& run) {
  auto [cmd, opt] = add_verb<ConvertOptions>(
      app, run, "convert", "Convert a capture file between " + saul::host::capture_format_list(false), run_convert,
      false);
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
      "  saulctl convert captures/interboard_uart.serial run.mcap\n"
      "                                                         a serial capture: each link's decoded messages\n"
      "                                                         (/serial/interboard/state, /serial/crsf/...)\n"
      "  saulctl convert --protocol pride --samplerate 1M uart.sigrok.txt run.mcap\n"
      "                                                         a sigrok/PulseView UART export, likewise\n"
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
                  "MCAP: zstd's level, -7 (fastest, largest) to 19 (smallest, slowest); default -2 (1: ~10 % smaller, slower)")
      ->check(CLI::Range(-7, 19));
  cmd->add_option_function<std::string>(
      "--chunk-size",
      [options = opt](const std::string& text) {
        options->chunk_bytes = parse_size_option("--chunk-size", text);
        if (options->chunk_bytes < 4096 || options->chunk_bytes > (std::uint64_t{256} << 20))
          throw CLI::ValidationError("--chunk-size", "a chunk holds 4K to 256M of records, not " + text);
      },
      "MCAP: close a chunk when its records reach this size (4K-256M, default 4M: smaller seeks finer, larger "
      "keeps a smaller summary)");
  add_parallel_from_option(cmd, opt->parallel_from);
  cmd->add_option("--block-size", opt->block_size,
                  "MCAP: size of the blocks of the file converted on both cores (each block's chunks end with it)")
      ->capture_default_str();
  add_serial_read_options(cmd, opt->serial);
}

}  // namespace saulctl
