// saulctl decode: every frame of a capture file, decoded: CAN captures frame by frame, serial byte captures (our
// serial log, sigrok/PulseView UART exports) through the streaming decoder of each link's protocol.
#include <fmt/core.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
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

// Standard input as the candump reader sees it, line by line, keeping the first line that is no candump -L line
// (the reader skips those): when no frame came, what that line looks like is the error ('candump can0' without
// -L, above all). Whole lines are handed on as they come, so a live pipe is decoded at once.
class WatchedLines : public std::streambuf {
 public:
  explicit WatchedLines(std::istream& in) : in_(in) {}
  [[nodiscard]] const std::string& first_other() const { return first_other_; }

 protected:
  int_type underflow() override {
    if (!std::getline(in_, line_)) return traits_type::eof();
    if (first_other_.empty() && !line_.empty() && line_[0] != '(' &&
        line_.find_first_not_of(" \t\r") != std::string::npos)
      first_other_ = line_;
    if (!in_.eof()) line_ += '\n';
    if (line_.empty()) return underflow();
    setg(line_.data(), line_.data(), line_.data() + line_.size());
    return traits_type::to_int_type(line_[0]);
  }

 private:
  std::istream& in_;
  std::string line_;
  std::string first_other_;
};

using saul::host::csv_quote;

/// Decodes the chunks of one serial capture file; returns the number of messages printed.
std::uint64_t decode_serial(const DecodeOptions& opt, const std::string& format, const std::string& path,
                            saul::host::SerialCaptureReader& reader, std::uint64_t& corrupt,
                            std::uint64_t& records, Progress& progress) {
  using namespace saul::host;
  TimeColumn time_column(time_mode(opt.time));
  std::uint64_t messages = 0;
  std::uint64_t untimed = 0;
  SerialCaptureDecoder decoder(fallback_protocol(opt.serial));
  const SerialCaptureDecoder::Callback print = [&](const SerialChunk& chunk, SerialProtocol protocol,
                                                   const SerialMessage& m) {
    ++messages;
    const std::string stamp = time_column(chunk.timestamp_ns.value_or(0));
    const std::string bare = stamp.substr(1, stamp.size() - 2);
    if (format == "jsonl") {
      nlohmann::json j;
      j["time"] = bare;
      j["link"] = chunk.link;
      j["protocol"] = std::string(to_string(protocol));
      if (is_decode_error(m)) {
        j["error"] = to_json(m);
      } else {
        j["message"] = to_json(m);
      }
      fmt::print("{}\n", saul::host::json_line(j));
    } else if (format == "long") {
      fmt::print("{}", long_csv_rows(bare, chunk.link, "", signal_values(m)));
    } else if (format == "csv") {
      const std::string name = name_of(m);
      std::string fields = describe(m);
      fields = fields.starts_with(name) ? fields.substr(std::min(fields.size(), name.size() + 1)) : fields;
      fmt::print("{},{},,,,,,{},{}\n", bare, chunk.link, name, csv_quote(fields));
    } else {
      fmt::print("{} {} {}\n", stamp, chunk.link, describe(m));
    }
  };
  for (;;) {
    const auto st = reader.next();
    if (st == SerialCaptureReader::Status::end) break;
    progress.update(reader.bytes_read(), reader.bytes_total());
    if (st == SerialCaptureReader::Status::corrupt) {
      ++corrupt;
      progress.finish();  // the message gets its own line; the progress line comes back at the next draw
      fmt::print(stderr, "saulctl decode: {}\n", format_capture_error(path, reader.error()));
      continue;
    }
    ++records;
    if (!reader.chunk().timestamp_ns) ++untimed;
    decoder.add(reader.chunk(), print);
  }
  decoder.finish(print);
  if (untimed > 0)
    fmt::print(stderr, "saulctl decode: {}: {} chunks carry no time (sample numbers need --samplerate; sigrok-cli "
                       "prints them with --protocol-decoder-samplenum)\n", path, untimed);
  for (const auto& link : decoder.links())
    fmt::print(stderr, "saulctl decode: {}: {} ({}{}): {}\n", path, link.name, to_string(link.protocol),
               link.guessed ? ", guessed from the bytes" : "", link.counters_text);
  if (const auto& other = decoder.unlisted(); other.chunks > 0)
    fmt::print(stderr, "saulctl decode: {}: {} chunks ({} bytes) on links beyond the first {}: not decoded (is the "
                       "capture's link column noise?)\n",
               path, other.chunks, other.bytes, SerialCaptureDecoder::kMaxLinks);
  return messages;
}

int run_decode(const DecodeOptions& opt) {
  if (opt.files.size() == 1 && is_trace(opt.files[0])) return decode_trace(opt.files[0], opt.json);  // a loop trace
  const std::string format = opt.json ? "jsonl" : opt.format;
  const auto ids = id_filters(opt.ids);
  const saul::host::SerialReadOptions serial_options = serial_read_options(opt.serial);

  std::uint64_t frames = 0, decoded = 0, unknown = 0, rejected = 0, errors = 0, corrupt = 0;
  std::uint64_t messages = 0;
  std::uint64_t records = 0;  // frames and chunks read, before --id
  bool any_can = false;
  bool any_serial = false;
  int status = kOk;
  if (format == "csv") fmt::print("time,interface,id,extended,remote,dlc,data,message,fields\n");
  if (format == "long") fmt::print("{}\n", saul::host::kLongCsvHeader);
  Progress progress("decode", true);

  // CAN frames go through the fast path: candump files (and '-') with the batch scanner, decoded on both cores
  // when large; every other format frame by frame from its reader, written by the same emitter.
  using saul::host::DecodeFormat;
  using saul::host::TimeMode;
  saul::host::FrameDecodeOptions fast;
  fast.format = format == "jsonl" ? DecodeFormat::jsonl : format == "csv" ? DecodeFormat::csv : DecodeFormat::text;
  fast.time = time_mode(opt.time);
  if (!ids.empty()) fast.keep = [&ids](const saul::CanFrame& f) { return saul::host::passes(ids, f); };
  // From --parallel-from bytes on, candump, pcap and pcapng files are decoded in blocks on both cores and the other
  // formats are read on a second thread.
  fast.parallel_from = parse_size_option("--parallel-from", opt.parallel_from);
  const std::uint64_t read_ahead_from = fast.parallel_from;
  auto write_out = [](std::string_view text) { std::fwrite(text.data(), 1, text.size(), stdout); };
  auto count = [&](const saul::host::DecodeCounts& c) {
    frames += c.frames;
    decoded += c.decoded;
    unknown += c.unknown;
    rejected += c.rejected;
    errors += c.errors;
  };

  // Standard input that held lines but not one candump -L line: what it looks like, and exit 1.
  auto not_candump_on_stdin = [&](const std::string& first_other) {
    progress.finish();
    fmt::print(stderr, "saulctl decode: -: not a capture ({}); standard input is read as candump -L lines\n",
               saul::host::describe_non_capture(first_other));
    status = kFailure;
  };
  for (const auto& path : opt.files) {
    std::uint64_t progress_records = 0;
    saul::host::FrameDecodeSinks sinks;
    sinks.write = write_out;
    sinks.corrupt = [&](const saul::host::CaptureError& e) {
      progress.finish();
      fmt::print(stderr, "saulctl decode: {}\n", saul::host::format_capture_error(path, e));
    };
    sinks.progress = [&](std::uint64_t n, std::uint64_t bytes) {
      progress.update_many(n - progress_records, bytes, std::nullopt);
      progress_records = n;
    };
    std::optional<saul::host::FrameDecodeResult> fast_result;
    // '-' is candump text from standard input; files are any capture format, told by their content.
    std::unique_ptr<saul::host::CaptureReader> opened;
    std::unique_ptr<WatchedLines> watched;
    std::unique_ptr<std::istream> watched_in;
    const std::uint64_t records_before = records, corrupt_before = corrupt;
    try {
      if (path == "-" && format != "long") {
        // Standard input through the scanner (big reads, each written at once, so a pipe from candump stays live);
        // its first line that is not candump -L gives the hint below when nothing decoded.
        sinks.write = [&](std::string_view text) {  // every read's lines out at once: stdout to a pipe buffers
          write_out(text);
          std::fflush(stdout);
        };
        fast_result = saul::host::decode_candump(STDIN_FILENO, std::nullopt, fast, sinks);
      } else if (path == "-") {
        // The long CSV frame by frame, watching for a first line that is not candump -L (the hint below).
        watched = std::make_unique<WatchedLines>(std::cin);
        watched_in = std::make_unique<std::istream>(watched.get());
        opened = std::make_unique<saul::host::CandumpReader>(*watched_in);
      } else {
        auto any = saul::host::open_capture(path, serial_options);
        if (any.chunks) {
          any_serial = true;
          messages += decode_serial(opt, format, path, *any.chunks, corrupt, records, progress);
          continue;
        }
        const auto total = any.frames->bytes_total();
        sinks.progress = [&, total](std::uint64_t n, std::uint64_t bytes) {
          progress.update_many(n - progress_records, bytes, total);
          progress_records = n;
        };
        if (format == "long") {
          // the long CSV is written frame by frame below
        } else if (any.frames->format() == saul::host::CaptureFormat::candump) {
          fast_result = saul::host::decode_candump_file(path, fast, sinks);
          // A compressed log: its text cut into blocks on both cores as it inflates (whatever its size: a few MB
          // of zstd hold 40 MB of text), taken from the file already open (a pipe is read once).
          if (!fast_result && any.compressed && saul::host::decodes_candump_text(fast)) {
            if (const auto text = saul::host::take_capture_text(any.frames))
              fast_result = saul::host::decode_candump_text(*text, fast, sinks);
          }
        } else if (any.frames->format() == saul::host::CaptureFormat::pcap) {
          fast_result = saul::host::decode_pcap_file(path, fast, sinks);
        } else if (any.frames->format() == saul::host::CaptureFormat::pcapng) {
          fast_result = saul::host::decode_pcapng_file(path, fast, sinks);  // large ones on both cores
        }
        if (!fast_result) opened = std::move(any.frames);
      }
    } catch (const saul::host::CaptureOpenError& e) {
      fmt::print(stderr, "saulctl decode: {}\n", e.what());
      status = kFailure;
      continue;
    } catch (const std::system_error& e) {
      fmt::print(stderr, "saulctl decode: {}: {}\n", path, e.what());
      status = kFailure;
      continue;
    }
    any_can = true;
    if (!fast_result && format != "long" && !watched) {
      // Any other file format: its reader in batches through the same emitter, reading ahead on a second thread
      // from read_ahead_from bytes on.
      const auto total = opened->bytes_total();
      fast_result = saul::host::decode_reader(*opened, total && *total >= read_ahead_from, fast, sinks);
    }
    if (fast_result) {
      count(fast_result->counts);
      records += fast_result->records;
      corrupt += fast_result->corrupt;
      if (path == "-" && records == records_before && corrupt == corrupt_before && !fast_result->first_other.empty())
        not_candump_on_stdin(fast_result->first_other);
      continue;
    }
    saul::host::CaptureReader& reader = *opened;
    saul::host::FrameEmitter emitter(fast.format, fast.time);
    saul::host::DecodeCounts counts;
    fmt::memory_buffer out;
    saul::host::TimeColumn time_column(fast.time);  // the long CSV's times
    for (;;) {
      const auto st = reader.next();
      if (st == saul::host::CaptureReader::Status::end) break;
      progress.update(reader.bytes_read(), reader.bytes_total());
      if (st == saul::host::CaptureReader::Status::corrupt) {
        ++corrupt;
        sinks.corrupt(reader.error());
        continue;
      }
      ++records;
      const saul::CanFrame& f = reader.frame();
      if (!ids.empty() && !saul::host::passes(ids, f)) continue;
      if (format == "long") {
        const auto result = saul::decode_bus_frame(f);
        counts.count(result);
        const std::string stamp = time_column(f.timestamp_ns.value_or(0));
        fmt::print("{}", saul::host::long_csv_rows(stamp.substr(1, stamp.size() - 2), reader.interface(),
                                                   f.extended ? fmt::format("{:08X}", f.id) : fmt::format("{:03X}", f.id),
                                                   result ? saul::host::signal_values(result.value())
                                                          : saul::host::SignalValues{}));
        continue;
      }
      emitter.add(f, reader.interface(), out, counts);
      if (out.size() >= fast.flush_at) {
        write_out(std::string_view(out.data(), out.size()));
        out.clear();
      }
    }
    write_out(std::string_view(out.data(), out.size()));
    count(counts);
    if (watched && records == records_before && corrupt == corrupt_before && !watched->first_other().empty())
      not_candump_on_stdin(watched->first_other());
  }
  progress.finish();
  if (any_can || !any_serial)
    fmt::print(stderr,
               "saulctl decode: {} frames: {} decoded, {} unknown id, {} rejected, {} error frames; {} corrupt lines\n",
               frames, decoded, unknown, rejected, errors, corrupt);
  if (any_serial)
    fmt::print(stderr, "saulctl decode: {} serial messages; {} corrupt lines\n", messages, corrupt);
  // Exit 1 when nothing at all could be read (every file unopenable, or only corrupt records), or with --strict
  // when any record was corrupt; otherwise corrupt records are reported above and the exit stays 0.
  if (records == 0 && corrupt > 0) {
    fmt::print(stderr, "saulctl decode: nothing could be read\n");
    status = kFailure;
  }
  if (opt.strict && corrupt > 0) {
    fmt::print(stderr, "saulctl decode: --strict: {} corrupt record(s)\n", corrupt);
    status = kFailure;
  }
  return status;
}

}  // namespace

void add_decode_command(CLI::App& app, Runner& run) {
  auto opt = std::make_shared<DecodeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "decode", "Decode every frame of capture files (" + saul::host::capture_format_list(true) + ")");
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
  add_json_flag(cmd, opt->json, "same as --format jsonl: one JSON object per frame");
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
  cmd->callback([opt, &run] {
    run = [opt] {
      try {
        return run_decode(*opt);
      } catch (const CLI::ValidationError& e) {
        fmt::print(stderr, "saulctl decode: {}\n", e.what());
        return static_cast<int>(kUsage);
      }
    };
  });
}

}  // namespace saulctl
