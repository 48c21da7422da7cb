// saulctl record: a live CAN bus or serial link into capture files, with rotation, and nothing lost on Ctrl-C.
// Writing and rotation are in the host library (saulproto/host/capture/recorder.hpp); this file runs the receive loop.
#include <fmt/core.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <optional>

#include "capture_cli.hpp"
#include "commands.hpp"
#include "live.hpp"
#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/link/link_spec.hpp"
#include "saulproto/host/capture/mcap.hpp"
#include "saulproto/host/capture/recorder.hpp"
#include "saulproto/host/report/mcap_serial.hpp"
#include "saulproto/host/report/mcap_signals.hpp"

#include "saulproto/host/link/serial_port.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;

struct RecordOptions {
  std::string link;
  std::string output;
  std::string format;
  std::string rotate_size;
  std::string rotate_time;
  std::string compress;  // "", gz, zst
  std::string duration;
  std::uint64_t count = 0;
  std::string interface;
  std::string protocol;
  bool listen_only = false;
  bool quiet = false;
};

/// MCAP as recorded: chunks closed at every flush and every second (crash-safe), and written on the recording
/// thread, which reads the file's position between writes (mcap.hpp).
const saul::host::McapWriterOptions kRecordMcap{.library = "saulctl " SAULCTL_VERSION, .chunk_thread = false};

/// Progress on stderr: a line rewritten in place on a terminal, nothing in between otherwise.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled && ::isatty(STDERR_FILENO)) {}
  void update(std::uint64_t frames, const char* unit, const std::string& file, std::uint64_t bytes) {
    if (!enabled_) return;
    const auto now = steady_clock::now();
    if (now - last_ < milliseconds(500)) return;
    const double secs = duration<double>(now - start_).count();
    const double window = duration<double>(now - last_).count();
    const double rate = window > 0 ? static_cast<double>(frames - last_frames_) / window : 0;
    fmt::print(stderr, "\rrecord: {} {} ({:.0f}/s) in {:.0f} s, {} ({:.1f} KiB)   ", frames, unit, rate, secs, file,
               static_cast<double>(bytes) / 1024.0);
    last_ = now;
    last_frames_ = frames;
    shown_ = true;
  }
  void done() {
    if (shown_) fmt::print(stderr, "\n");
  }

 private:
  bool enabled_;
  bool shown_ = false;
  steady_clock::time_point start_ = steady_clock::now();
  steady_clock::time_point last_ = start_;
  std::uint64_t last_frames_ = 0;
};

saul::host::RotationOptions rotation_of(const RecordOptions& opt) {
  saul::host::RotationOptions r;
  if (!opt.rotate_size.empty()) r.max_bytes = parse_size_option("--rotate-size", opt.rotate_size);
  if (!opt.rotate_time.empty()) {
    const auto d = parse_duration(opt.rotate_time);
    if (d.count() <= 0) throw CLI::ValidationError("--rotate-time", "must be at least 1 ms");
    r.max_duration_ns = static_cast<std::uint64_t>(d.count()) * 1'000'000ULL;
  }
  if (!opt.compress.empty()) r.compress = *saul::host::compression_from_name(opt.compress);
  if (saul::host::compression_from_extension(opt.output) != saul::host::Compression::none)
    throw CLI::ValidationError("-o", "record writes plain files and compresses each one when it is finished: name it "
                                     "without .gz/.zst and add --compress gz (or zst)");
  return r;
}

/// receive_until() with a progress line (`taken` counts `unit`s), the writer flushed, what is on its way drained
/// after Ctrl-C, and the writer closed whatever happened (a link's error is said). Returns the exit code.
template <class Writer, class Take>
int receive_loop(const RecordOptions& opt, steady_clock::time_point start, Writer& writer, Take&& take,
                 const std::uint64_t& taken, const char* unit) {
  Progress progress(!opt.quiet);
  // The writer is flushed when the link is idle, and at least every 100 ms while data arrive.
  auto flushed = steady_clock::now();
  const auto take_and_flush = [&](milliseconds wait) {
    const bool got = take(wait);
    if (!got || steady_clock::now() - flushed > milliseconds(100)) {
      writer.flush();
      flushed = steady_clock::now();
    }
    return got;
  };
  const int status = report_errors([&] {
    receive_until(opt.duration, start, opt.count, taken, [&](milliseconds wait) {
      take_and_flush(wait);
      progress.update(taken, unit, writer.current_path(), writer.bytes_in_file());
    });
    // After Ctrl-C what the adapter already delivered is still written, until it is quiet for 200 ms (at most 1 s).
    const auto until = steady_clock::now() + seconds(1);
    while (g_interrupted && steady_clock::now() < until && (opt.count == 0 || taken < opt.count) &&
           take_and_flush(milliseconds(200))) {
    }
  });
  progress.done();
  writer.close();
  return status;
}

int record_can(const RecordOptions& opt, const saul::host::LinkSpec& spec) {
  using namespace saul::host;
  std::optional<CaptureFormat> format;
  if (!opt.format.empty()) format = capture_format_from_name(opt.format);
  if (!format) format = capture_format_from_extension(opt.output);
  if (!format)
    throw CLI::ValidationError("-o", "cannot tell the format of '" + opt.output +
                                         "': name it .log, .pcap, .pcapng, .asc, .blf, .trc, .csv or .mcap, or give --format");
  if (holds_serial_bytes(*format))
    throw CLI::ValidationError("--format", std::string(to_string(*format)) + " holds serial bytes; " + spec.text() +
                                               " is a CAN link: use candump, pcap, pcapng, asc, blf, trc or csv");
  const std::string iface =
      !opt.interface.empty() ? opt.interface : spec.kind == LinkSpec::Kind::socketcan ? spec.device : "can0";

  // Paced: every frame is written, so a burst waits in the adapter rather than being dropped here.
  auto link = open_can_link(spec, {.listen_only = opt.listen_only, .filters = {}, .paced = true});
  RotatingCaptureWriter::MakeWriter make;
  if (*format == CaptureFormat::mcap) {  // with the decoded signals' channels and what is known of the link
    McapMap metadata = {{"saulctl", SAULCTL_VERSION}, {"link", spec.text()}};
    if (spec.kind == LinkSpec::Kind::slcan) metadata.emplace_back("bitrate", std::to_string(spec.bitrate));
    make = [metadata](std::ostream& out) {
      return std::make_unique<McapCaptureWriter>(
          out, kRecordMcap, [] { return std::make_unique<McapSignalChannels>(); }, metadata);
    };
  }
  RotatingCaptureWriter writer(
      opt.output, *format, rotation_of(opt),
      [&](const std::string& path) {
        if (!opt.quiet) fmt::print(stderr, "record: writing {} ({})\n", path, to_string(*format));
      },
      make);
  if (!opt.quiet)
    fmt::print(stderr, "record: {} as {} (timestamps: {}); Ctrl-C to stop\n", link->name(), iface,
               to_string(link->timestamp_source()));
  std::uint64_t frames = 0;
  const auto start = steady_clock::now();
  auto take = [&](milliseconds wait) {
    const auto f = link->receive(wait);
    if (f) {
      writer.write(*f, iface);
      ++frames;
    }
    return f.has_value();
  };
  const int status = receive_loop(opt, start, writer, take, frames, "frames");
  const auto s = link->stats();
  const double secs = duration<double>(steady_clock::now() - start).count();
  fmt::print(stderr, "record: {} frames in {:.1f} s into {} file(s), last {}; link dropped {}, error frames {}\n",
             frames, secs, writer.files(), writer.current_path(), s.rx_dropped, s.error_frames);
  return status;
}

int record_serial(const RecordOptions& opt, const saul::host::LinkSpec& spec) {
  using namespace saul::host;
  if (!opt.format.empty() && opt.format != "serial" && opt.format != "mcap")
    throw CLI::ValidationError("--format", spec.text() + " is a serial link: its bytes are written as a serial log "
                                                         "(--format serial) or as MCAP (--format mcap, or -o x.mcap)");
  const bool mcap = opt.format == "mcap" ||
                    (opt.format.empty() && capture_format_from_extension(opt.output) == CaptureFormat::mcap);
  SerialChunk chunk;
  chunk.link = spec.text();
  chunk.protocol = opt.protocol.empty() ? protocol_for_baud(spec.serial.baud) : *serial_protocol_from_name(opt.protocol);

  auto port = open_serial_link(spec);  // shared with other saulctl processes (shared_link.hpp)
  RotatingSerialWriter::MakeWriter make;
  if (mcap) {  // the decoded messages on channels of their own, as convert writes a serial capture
    const McapMap metadata = {{"saulctl", SAULCTL_VERSION}, {"link", spec.text()},
                              {"protocol", std::string(to_string(chunk.protocol))}};
    make = [metadata](std::ostream& out) { return std::make_unique<McapSerialWriter>(out, kRecordMcap, metadata); };
  }
  RotatingSerialWriter writer(
      opt.output, rotation_of(opt),
      [&](const std::string& path) {
        if (!opt.quiet) fmt::print(stderr, "record: writing {} ({})\n", path, mcap ? "MCAP" : "serial");
      },
      make);
  if (!opt.quiet)
    fmt::print(stderr, "record: {} bytes on {} ({} {}); Ctrl-C to stop\n", to_string(chunk.protocol), port->path(),
               spec.serial.baud, to_string(spec.serial));
  std::uint64_t bytes = 0;
  std::uint64_t chunks = 0;
  const auto start = steady_clock::now();
  std::array<std::uint8_t, 4096> buf{};
  auto take = [&](milliseconds wait) {
    const std::size_t n = port->read(buf, wait);
    if (n == 0) return false;
    chunk.timestamp_ns = realtime_ns();
    chunk.bytes.assign(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
    writer.write(chunk);
    bytes += n;
    ++chunks;
    return true;
  };
  const int status = receive_loop(opt, start, writer, take, bytes, "bytes");
  const double secs = duration<double>(steady_clock::now() - start).count();
  fmt::print(stderr, "record: {} bytes in {} chunks in {:.1f} s into {} file(s), last {}\n", bytes, chunks, secs,
             writer.files(), writer.current_path());
  return status;
}

int run_record(const RecordOptions& opt) {
  // Files only: '-' would be a file called '-', and rotation needs names.
  if (opt.output == "-")
    throw CLI::ValidationError("-o", "record writes files, not standard output: name one (-o run.log); to watch "
                                     "frames as they come, use saulctl sniff");
  const auto spec = resolve_link(opt.link);
  return spec.is_can() ? record_can(opt, spec) : record_serial(opt, spec);
}

}  // namespace

void add_record_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<RecordOptions>(
      app, run, "record", "Record a CAN bus or a serial link into capture files", run_record);
  add_link_option_and_positional(cmd, o->link);
  cmd->add_option("-o,--output", o->output, "file to write (replaced); with rotation NAME-000.EXT, NAME-001.EXT, ...")
      ->required();
  cmd->add_option("--format", o->format,
                  "candump, pcap, pcapng, asc, blf, trc, csv, gvret-csv, mcap (CAN) or serial (default: from the "
                  "extension)")
      ->check(CLI::IsMember({"candump", "pcap", "pcapng", "asc", "blf", "trc", "csv", "gvret-csv", "mcap", "serial"}));
  cmd->add_option("--rotate-size", o->rotate_size, "start a new file when this one holds this much (100M, 1G, 64k)");
  cmd->add_option("--rotate-time", o->rotate_time, "start a new file after this long (10m, 30s)")->check(duration_check());
  cmd->add_option("--compress", o->compress, "gz or zst: compress each file once it is finished (in the background; "
                                             "the plain file is removed), the last one when recording stops")
      ->check(CLI::IsMember({"gz", "zst"}));
  add_duration_option(cmd, o->duration, "stop after this long");
  cmd->add_option("-n,--count", o->count, "stop after this many frames (serial: bytes)");
  cmd->add_option("--interface", o->interface, "CAN: interface name written in the file (default: can0, or the "
                                               "SocketCAN interface's own name)");
  cmd->add_option("--protocol", o->protocol, "serial: what the link carries (default: by baud rate: 460800 "
                                             "interboard, 420000 crsf, 38400 pride, else raw)")
      ->check(CLI::IsMember({"interboard", "crsf", "pride", "raw"}));
  cmd->add_flag("--listen-only", o->listen_only, "slcan: open the adapter silent (no ACKs on the bus)");
  cmd->add_flag("-q,--quiet", o->quiet, "no progress and no file names on stderr, only the summary");
  cmd->footer(
      "\nEvery file is complete and readable at any time after a flush (at most 100 ms behind while frames\n"
      "arrive, at once when the bus is idle) and after Ctrl-C: the frames already received are written and the\n"
      "file is closed properly. Progress (frames, rate, file) is shown on stderr when it is a terminal.\n"
      "\nExamples:\n"
      "  saulctl record --link can0 -o run.pcapng                 open it in Wireshark (or: record can0 -o ...)\n"
      "  saulctl record --link slcan:/dev/ttyACM0 -o run.log --rotate-size 100M --rotate-time 10m\n"
      "  saulctl record --link can0 -o run.blf --rotate-size 1G --compress zst   run-000.blf.zst, ...\n"
      "  saulctl record --link serial:/dev/ttyUSB0@460800 -o uart.serial --duration 2m   inter-board bytes\n"
      "  saulctl record --link slcan:/dev/ttyACM0 -o run.mcap      for Foxglove, Lichtblick, PlotJuggler: frames\n"
      "                                                           and decoded signals (docs/captures.md)\n"
      "  saulctl record --link serial:/dev/ttyUSB0@460800 -o uart.mcap   the link's decoded messages as MCAP\n"
      "                                                           (/serial/interboard/state, ..., /serial/bytes)\n"
      "\nMCAP (-o x.mcap) is written in chunks closed at every flush above and at least every second: after a\n"
      "crash or kill -9 the file reads up to its last closed chunk; Ctrl-C writes its summary.\n");
}

}  // namespace saulctl
