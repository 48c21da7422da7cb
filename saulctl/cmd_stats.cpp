// saulctl stats: what a capture holds, in one streaming pass: per id (or serial message type) counts, rates and
// longest silences, error frames, decode errors, bus load from each frame's real length on the wire.
// The arithmetic lives in the host library (saulproto/host/report/bus_stats.hpp).
#include <fmt/core.h>

#include "capture_cli.hpp"
#include "commands.hpp"
#include "grammar.hpp"
#include "trace_cli.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/bus_stats.hpp"
#include "saulproto/host/report/signal_stats.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/serial_capture.hpp"

namespace saulctl {
namespace {

/// --block-size: 1 MiB is as fast as larger blocks, and a pcapng block is held whole while it is counted (tests
/// give 64k to have many blocks from a small file).
constexpr const char* kStatsBlock = "1MiB";

struct StatsOptions {
  std::string file;
  bool json = false;
  bool signals = false;
  std::string bitrate = "500k";
  std::string window = "100ms";
  std::string parallel_from;  // --parallel-from
  std::string block_size = kStatsBlock;
  SerialCliOptions serial;
};

int run_stats(const StatsOptions& opt) {
  using namespace saul::host;
  if (is_trace(opt.file)) return stats_trace(opt.file, opt.json);  // a loop trace (saulctl tune record)
  const std::uint64_t bitrate = parse_rate_hz(opt.bitrate);
  if (bitrate > 1'000'000) throw CLI::ValidationError("--bitrate", "classic CAN runs at 1 Mbit/s at most");
  const auto window = parse_duration(opt.window);
  if (window.count() <= 0) throw CLI::ValidationError("--window", "the window must be at least 1 ms");
  const BusStatsOptions bus{.bitrate = static_cast<std::uint32_t>(bitrate),
                            .window_ns = static_cast<std::uint64_t>(window.count()) * 1'000'000ULL};
  const ReadOptions read{.parallel_from = parse_size_option("--parallel-from", opt.parallel_from),
                         .block = parse_size_option("--block-size", opt.block_size)};

  const SerialReadOptions serial = serial_read_options(opt.serial);
  OpenedCapture opened = open_capture(opt.file, serial);  // CaptureOpenError: main says it

  Progress progress("stats", false);
  SignalStats signal_stats;  // --signals: per signal count, mean, min, max in its unit
  // Both reports, text or JSON: the bus's, then the signals' when asked for.
  auto print = [&](const auto& stats) {
    if (opt.json) {
      nlohmann::json j = stats.json(opt.file);
      if (opt.signals) j["signals"] = signal_stats.json();
      fmt::print("{}\n", saul::host::json_line(j));
    } else {
      fmt::print("{}", stats.text(opt.file));
      if (opt.signals) fmt::print("\nsignals (physical units):\n{}", signal_stats.text());
    }
  };
  if (opened.frames) {
    BusStats stats(bus);
    // The one read path: large files on both cores (blocks of --block-size from --parallel-from bytes on; not with
    // --signals, which needs the frames in order on one thread: a reading thread ahead then).
    const auto total = opened.frames->bytes_total();
    std::function<void(const saul::CanFrame&)> also;
    if (opt.signals) also = [&](const saul::CanFrame& f) { signal_stats.add(f); };
    add_capture(
        stats, opt.file, opened.frames, opened.compressed, read, corrupt_reporter(opt.file, &progress),
        [&](std::uint64_t records, std::uint64_t bytes) { progress.read_so_far(records, bytes, total); }, also);
    progress.finish();
    print(stats);
    return kOk;
  }
  SerialStats stats(serial.protocol);
  SerialCaptureDecoder signal_decoder(serial.protocol);  // only with --signals
  const SerialCaptureDecoder::Callback count_signals = [&](const SerialChunk&, SerialProtocol, const SerialMessage& m) {
    signal_stats.add(signal_values(m));
  };
  std::uint64_t corrupt = 0;
  read_serial_chunks(opt.file, *opened.chunks, progress, corrupt, [&](const SerialChunk& chunk) {
    stats.add(chunk);
    if (opt.signals) signal_decoder.add(chunk, count_signals);
  });
  for (; corrupt > 0; --corrupt) stats.add_corrupt();
  progress.finish();
  stats.finish();
  if (opt.signals) signal_decoder.finish(count_signals);
  print(stats);
  return kOk;
}

}  // namespace

void add_stats_command(CLI::App& app, Runner& run) {
  auto [cmd, opt] = add_verb<StatsOptions>(app, run, "stats",
                                           "Counts, rates, silences, errors and bus load of a capture file", run_stats,
                                           false);
  cmd->footer(
      "\nCAN captures: per id the count, rate, mean and longest gap (and when it began), jitter, the frame's bits\n"
      "on the wire and decode failures; error frames by kind; decode errors by reason; bus load at --bitrate\n"
      "from every frame's real length: worst-case stuff bits (as canbusload), exact stuff bits (the frame's own\n"
      "bits and CRC, as canbusload -e) and none; the busiest --window; and how often 0x300 fell silent for\n"
      "longer than the BALANCE board's 500 ms Orin timeout.\n"
      "Serial captures: per link the bytes, byte rate, line load, the decoder's counters, and per message type\n"
      "the count, rate and longest gap.\n"
      "--signals adds per signal of every decoded message its count, mean, min and max in its physical unit\n"
      "(the values of decode --format long, so a DuckDB or pandas aggregate of that CSV gives the same).\n"
      "One pass, constant memory in the number of frames. Corrupt records are reported on stderr and counted.\n"
      "\nExamples:\n"
      "  saulctl stats captures/robot_bus.log\n"
      "  saulctl stats --json run.pcapng | jq '.ids[] | select(.id_hex == \"300\") | .max_gap_s'\n"
      "  saulctl stats captures/interboard_uart.serial\n"
      "  saulctl stats --signals --json run.log | jq '.signals[] | select(.signal == \"pitch\")'\n"
      "  ssh robot cat run.log.zst | saulctl stats -              standard input, compressed or not\n");
  cmd->add_option("FILE", opt->file, "capture file (any format decode reads; - = standard input)")->required();
  cmd->add_flag("--json", opt->json, "one JSON object instead of the text report");
  cmd->add_flag("--signals", opt->signals, "also count, mean, min and max of every signal, in physical units");
  cmd->add_option("--bitrate", opt->bitrate, "CAN bit rate for the load (500k, 1M, 250000)")->capture_default_str();
  cmd->add_option("--window", opt->window, "window of the peak load (100ms, 1s)")->capture_default_str()->check(duration_check());
  add_serial_read_options(cmd, opt->serial);
  add_parallel_from_option(cmd, opt->parallel_from);
  cmd->add_option("--block-size", opt->block_size, "size of the blocks counted on both cores")->capture_default_str();
}

}  // namespace saulctl
