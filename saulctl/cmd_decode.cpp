// saulctl decode: every frame of a capture file, decoded: CAN captures frame by frame, serial byte captures (our
// serial log, sigrok/PulseView UART exports) through the streaming decoder of each link's protocol.
#include <fmt/core.h>

#include <unistd.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <system_error>

#include "capture_cli.hpp"
#include "commands.hpp"
#include "trace_cli.hpp"
#include "grammar.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/report/fast_decode.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/signal_rows.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/serial_decode.hpp"

namespace saulctl {
namespace {

struct DecodeOptions {
  std::vector<std::string> files;
  std::string format = "text";
  std::string time = "abs";
  std::vector<std::string> ids;
  bool json = false;
  bool strict = false;
  std::string parallel_from;  // --parallel-from
  SerialCliOptions serial;
};

/// Decodes the chunks of one serial capture file; returns the number of messages printed.
std::uint64_t decode_serial(const DecodeOptions& opt, const std::string& format, const std::string& path,
                            saul::host::SerialCaptureReader& reader, std::uint64_t& corrupt,
                            std::uint64_t& records, Progress& progress) {
  using namespace saul::host;
  TimeColumn time_column(time_mode(opt.time));
  std::uint64_t messages = 0;
  std::uint64_t untimed = 0;
  SerialCaptureDecoder decoder(serial_read_options(opt.serial).protocol);
  const SerialCaptureDecoder::Callback print = [&](const SerialChunk& chunk, SerialProtocol protocol,
                                                   const SerialMessage& m) {
    ++messages;
    const std::string stamp = time_column(chunk.timestamp_ns.value_or(0));
    const std::string bare = TimeColumn::bare(stamp);
    if (format == "jsonl") {
      const nlohmann::json j{{"time", bare}, {"link", chunk.link}, {"protocol", std::string(to_string(protocol))},
                             {is_decode_error(m) ? "error" : "message", to_json(m)}};
      fmt::print("{}\n", saul::host::json_line(j));
    } else if (format == "long") {
      fmt::print("{}", long_csv_rows(bare, chunk.link, "", signal_values(m)));
    } else if (format == "csv") {
      const std::string name = name_of(m);
      std::string fields = describe(m);
      fields = fields.starts_with(name) ? fields.substr(std::min(fields.size(), name.size() + 1)) : fields;
      fmt::print("{},{},,,,,,{},{}\n", bare, chunk.link, name, saul::host::csv_quote(fields));
    } else {
      fmt::print("{} {} {}\n", stamp, chunk.link, describe(m));
    }
  };
  read_serial_chunks(path, reader, progress, corrupt, [&](const saul::host::SerialChunk& chunk) {
    ++records;
    if (!chunk.timestamp_ns) ++untimed;
    decoder.add(chunk, print);
  });
  decoder.finish(print);
  if (untimed > 0)
    say("{}: {} chunks carry no time (sample numbers need --samplerate; sigrok-cli "
        "prints them with --protocol-decoder-samplenum)", path, untimed);
  for (const auto& link : decoder.links())
    say("{}: {} ({}{}): {}", path, link.name, to_string(link.protocol),
        link.guessed ? ", guessed from the bytes" : "", link.counters_text);
  if (const auto& other = decoder.unlisted(); other.chunks > 0)
    say("{}: {} chunks ({} bytes) on links beyond the first {}: not decoded (is the "
        "capture's link column noise?)",
        path, other.chunks, other.bytes, SerialCaptureDecoder::kMaxLinks);
  return messages;
}

int run_decode(const DecodeOptions& opt) {
  if (opt.files.size() == 1 && is_trace(opt.files[0])) return decode_trace(opt.files[0], opt.json);  // a loop trace
  const std::string format = opt.json ? "jsonl" : opt.format;
  const auto ids = id_filters(opt.ids);
  const saul::host::SerialReadOptions serial_options = serial_read_options(opt.serial);

  saul::host::DecodeCounts can;  // CAN frames of every file
  std::uint64_t messages = 0, corrupt = 0;
  std::uint64_t records = 0;  // frames and chunks read, before --id
  bool any_can = false, any_serial = false;
  int status = kOk;
  if (format == "csv") fmt::print("time,interface,id,extended,remote,dlc,data,message,fields\n");
  if (format == "long") fmt::print("{}\n", saul::host::kLongCsvHeader);
  Progress progress("decode", true);

  // CAN frames, whatever their format, go through the one read path (large files on both cores) into one emitter.
  using saul::host::DecodeFormat;
  saul::host::FrameDecodeOptions fast;
  fast.format = format == "jsonl" ? DecodeFormat::jsonl : format == "csv" ? DecodeFormat::csv : DecodeFormat::text;
  fast.time = time_mode(opt.time);
  if (!ids.empty()) fast.keep = [&ids](const saul::CanFrame& f) { return saul::host::passes(ids, f); };
  fast.read.parallel_from = parse_size_option("--parallel-from", opt.parallel_from);
  auto write_out = [](std::string_view text) { std::fwrite(text.data(), 1, text.size(), stdout); };

  for (const auto& path : opt.files) {
    std::uint64_t progress_records = 0;
    std::optional<std::uint64_t> total;
    saul::host::FrameDecodeSinks sinks{.write = write_out,
                                       .corrupt = corrupt_reporter(path, &progress),
                                       .progress = [&](std::uint64_t n, std::uint64_t bytes) {
                                         progress.update_many(n - progress_records, bytes, total);
                                         progress_records = n;
                                       }};
    saul::host::TimeColumn time_column(fast.time);  // the long CSV's times
    saul::host::FrameDecodeOptions options = fast;
    if (format == "long")
      options.render = [&](const saul::CanFrame& f, std::string_view interface, fmt::memory_buffer& out,
                           saul::host::DecodeCounts& counts) {
        const auto result = saul::decode_bus_frame(f);
        counts.count(result ? saul::Reason::ok : result.reason());
        const std::string rows = saul::host::long_csv_rows(
            saul::host::TimeColumn::bare(time_column(f.timestamp_ns.value_or(0))), interface,
            f.extended ? fmt::format("{:08X}", f.id) : fmt::format("{:03X}", f.id),
            result ? saul::host::signal_values(result.value()) : saul::host::SignalValues{});
        out.append(rows.data(), rows.data() + rows.size());
      };
    // '-' is candump text from standard input, read as it comes (a pipe from candump stays live: each read's lines
    // are written at once); files are any capture format, told by their content.
    std::unique_ptr<saul::host::CaptureReader> reader;
    const saul::host::CandumpReader* from_stdin = nullptr;
    bool compressed = false;
    try {
      if (path == "-") {
        auto candump = std::make_unique<saul::host::CandumpReader>(STDIN_FILENO);
        from_stdin = candump.get();
        reader = std::move(candump);
        options.read.live = true;
        sinks.write = [&](std::string_view text) {  // stdout to a pipe buffers
          write_out(text);
          std::fflush(stdout);
        };
      } else {
        auto any = saul::host::open_capture(path, serial_options);
        if (any.chunks) {
          any_serial = true;
          messages += decode_serial(opt, format, path, *any.chunks, corrupt, records, progress);
          continue;
        }
        total = any.frames->bytes_total();
        reader = std::move(any.frames);
        compressed = any.compressed;
      }
      any_can = true;
      const auto result = saul::host::decode_capture(path, reader, compressed, options, sinks);
      can += result.counts;
      records += result.records;
      corrupt += result.corrupt;
      // Standard input that held lines but not one candump -L line: what it looks like, and exit 1.
      if (from_stdin && result.records == 0 && result.corrupt == 0 && !from_stdin->first_other().empty()) {
        progress.finish();
        say("-: not a capture ({}); standard input is read as candump -L lines",
            saul::host::describe_non_capture(from_stdin->first_other()));
        status = kFailure;
      }
    } catch (const saul::host::CaptureOpenError& e) {
      status = report_error(e);
    } catch (const std::system_error& e) {
      say("{}: {}", path, e.what());
      status = kFailure;
    }
  }
  progress.finish();
  if (any_can || !any_serial)
    say("{} frames: {} decoded, {} unknown id, {} rejected, {} error frames; {} corrupt lines",
        can.frames, can.decoded, can.unknown, can.rejected, can.errors, corrupt);
  if (any_serial)
    say("{} serial messages; {} corrupt lines", messages, corrupt);
  // Exit 1 when nothing at all could be read (every file unopenable, or only corrupt records), or with --strict
  // when any record was corrupt; otherwise corrupt records are reported above and the exit stays 0.
  if (records == 0 && corrupt > 0) {
    say("nothing could be read");
    status = kFailure;
  }
  if (opt.strict && corrupt > 0) {
    say("--strict: {} corrupt record(s)", corrupt);
    status = kFailure;
  }
  return status;
}

}  // namespace

void add_decode_command(CLI::App& app, Runner& run) {
  auto [cmd, opt] = add_verb<DecodeOptions>(
      app, run, "decode", "Decode every frame of capture files (" + saul::host::capture_format_list(true) + ")",
      run_decode, false);
  cmd->footer(
      "\nOutput (text): one line per frame, greppable:\n"
      "  (1700000000.050000) can0 300#E8030CFE             velocity_cmd speed_mmps=1000 steer_mrad=-500\n"
      "  (1700000000.100000) can0 400#D2047800900101       telemetry_a pitch=12.34\u00B0 pid_out=120 ...\n"
      "Scaled values are shown in their unit (pitch in degrees, battery in V, RC channels in \u00B5s); JSON has\n"
      "the physical value and the wire integer: \"pitch\":12.34,\"pitch_raw\":1234 (docs/cli.md names every signal).\n"
      "A frame that does not decode shows '!' and the reason, e.g. '!wrong_dlc' or '!unknown_id'.\n"
      "Corrupt lines are reported on stderr as FILE:LINE:COLUMN (FILE: byte OFFSET in pcap/pcapng) and\n"
      "skipped; the rest still decodes. The format of a file is told by its content (docs/captures.md).\n"
      "Exit 0 even with corrupt lines, unless --strict is given or nothing at all could be read (then 1).\n"
      "\nExamples:\n"
      "  saulctl decode captures/robot_bus.log\n"
      "  saulctl decode --time delta --id 300 run.log       gaps between velocity commands (ids are hex)\n"
      "  saulctl decode --format csv run.log > run.csv\n"
      "  saulctl decode --format long run.log > signals.csv   one row per signal, for DuckDB or pandas\n"
      "  saulctl decode bench.pcapng                        pcap, pcapng and Vector ASC work the same\n"
      "  candump -L can0 | saulctl decode -                 decode live from can-utils\n"
      "  saulctl decode captures/pride_uart.serial          serial byte captures: each link's own decoder\n"
      "  sigrok-cli -i la.vcd -P uart:rx=rx:baudrate=38400:parity=even -A uart=rx-data \\\n"
      "      --protocol-decoder-samplenum > la.txt\n"
      "  saulctl decode --protocol pride --samplerate 1M la.txt   a logic analyser's UART decode\n"
      "Serial captures end with each link's decoder counters on stderr (frames, CRC errors, bytes skipped).\n");
  cmd->add_option("files", opt->files,
                  "capture files: " + saul::host::capture_format_list(true) + " ('-' = candump text on standard input)")
      ->required();
  cmd->add_option("--format", opt->format,
                  "text, jsonl, csv (a row per frame) or long (a row per signal: time,interface,id,message,signal,"
                  "value,unit, values in physical units)")
      ->check(CLI::IsMember({"text", "jsonl", "csv", "long"}))
      ->capture_default_str();
  cmd->add_flag("--json", opt->json, "same as --format jsonl: one JSON object per frame");
  cmd->add_flag("--strict", opt->strict,
                "exit 1 when any line or record was corrupt (default: report them, skip them, exit 0)");
  cmd->add_option("-t,--time", opt->time,
                  "abs (as logged), rel (since first frame), delta (since previous); negative where the log's times "
                  "go back")
      ->check(CLI::IsMember({"abs", "rel", "delta"}))
      ->capture_default_str();
  add_id_option(cmd, opt->ids, "only these CAN ids");
  add_serial_read_options(cmd, opt->serial);
  add_parallel_from_option(cmd, opt->parallel_from);
}

}  // namespace saulctl
