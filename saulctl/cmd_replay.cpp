// saulctl replay: a CAN capture back onto a bus, or a serial capture back onto a serial port, with its original
// timing. All but the link and the report is in the host library (saulproto/host/replay/replay.hpp, serial_replay.hpp).
#include <fmt/format.h>

#include <iostream>
#include <optional>

#include "capture_cli.hpp"
#include "commands.hpp"
#include "live.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/report/fast_emit.hpp"
#include "saulproto/host/link/link_spec.hpp"
#include "saulproto/host/replay/replay.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/link/serial_port.hpp"
#include "saulproto/host/replay/serial_replay.hpp"

namespace saulctl {
namespace {

using namespace std::chrono_literals;

struct ReplayCliOptions {
  std::string file;
  std::string link;
  std::string speed = "1";
  unsigned loops = 1;
  std::vector<std::string> ids;
  std::vector<std::string> exclude;
  std::vector<std::string> maps;
  std::string max_gap;
  bool step = false;
  bool yes = false;
  bool no_motion = false;
  bool json = false;
  std::string from;           ///< serial captures: the captured link to replay
  SerialCliOptions serial;    ///< serial captures: --protocol, --samplerate
};

std::string micros(std::uint64_t ns) { return fmt::format("{:.0f} us", static_cast<double>(ns) / 1e3); }

/// The final report with the totals and how late the `unit`s left: `j` on stdout for --json, else on stderr "replay:
/// `sent` in S s (N pass(es)); `rest`".
void print_report(bool json, nlohmann::json j, const std::string& sent, const std::string& rest,
                  const saul::host::ReplayTotals& totals, const char* unit) {
  const auto& l = totals.lateness;
  const double secs = static_cast<double>(totals.elapsed_ns) / 1e9;
  if (json) {
    j["passes"] = totals.passes;
    j["elapsed_s"] = secs;
    j["stopped"] = totals.stopped;
    if (l.count() > 0)
      j["lateness"] = {{unit, l.count()},
                       {"p50_us", static_cast<double>(l.percentile_ns(50)) / 1e3},
                       {"p99_us", static_cast<double>(l.percentile_ns(99)) / 1e3},
                       {"max_us", static_cast<double>(l.max_ns()) / 1e3},
                       {"later_than_1ms", l.over_1ms()}};
    fmt::print("{}\n", saul::host::json_line(j));
    return;
  }
  fmt::print(stderr, "replay: {} in {:.3f} s ({} pass(es){}); {}\n", sent, secs, totals.passes,
             totals.stopped ? ", stopped early" : "", rest);
  if (l.count() > 0)
    fmt::print(stderr, "replay: lateness p50 {}, p99 {}, max {}; {} of {} {} later than 1 ms\n",
               micros(l.percentile_ns(50)), micros(l.percentile_ns(99)), micros(l.max_ns()), l.over_1ms(), l.count(),
               unit);
}

/// --step: shows the `n`th thing to send and waits; true for Enter, false for q, quit or the end of the input.
bool step_prompt(std::uint64_t n, const std::string& what) {
  fmt::print(stderr, "[{}] {}  (Enter sends, q quits) ", n, what);
  std::string answer;
  return std::getline(std::cin, answer) && answer != "q" && answer != "quit";
}

/// A serial capture onto a serial port. `link_text` is --link as given (serial:...), or the resolved link's name.
int run_serial_replay(const ReplayCliOptions& opt, const saul::host::ReplayOptions& can_options,
                      std::unique_ptr<saul::host::SerialCaptureReader> first_pass, const std::string& link_text) {
  using namespace saul::host;
  if (!opt.ids.empty() || !opt.exclude.empty() || !opt.maps.empty())
    throw CLI::ValidationError("--id/--exclude-id/--map", opt.file + " holds serial bytes, not CAN ids; pick one of "
                                                                     "its links with --from");
  const SerialReadOptions read_options = serial_read_options(opt.serial);
  const SerialReplayPreview preview = preview_serial_replay(*first_pass, read_options.protocol);
  first_pass.reset();
  if (preview.links.empty()) {
    fmt::print(stderr, "replay: {} holds no serial bytes; nothing to send\n", opt.file);
    return kOk;
  }
  std::vector<std::string> names;
  for (const auto& l : preview.links) names.push_back(l.name);
  if (opt.from.empty() && preview.links.size() > 1)
    throw CLI::ValidationError("--from", fmt::format("{} holds {} links ({}); pick the one to replay with --from LINK",
                                                     opt.file, preview.links.size(), fmt::join(names, ", ")));
  const SerialLinkPreview* link = opt.from.empty() ? &preview.links.front() : preview.find(opt.from);
  if (link == nullptr)
    throw CLI::ValidationError("--from", fmt::format("{} has no link '{}'; its links: {}", opt.file, opt.from,
                                                     fmt::join(names, ", ")));
  if (link->protocol == SerialProtocol::raw && !opt.yes)
    throw CLI::ValidationError(
        "--protocol", fmt::format("cannot tell which bytes of {} can move motors: the capture names no protocol and "
                                  "none could be guessed; give --protocol interboard|crsf|pride, or --allow-motion to "
                                  "send every byte as captured",
                                  link->name));

  const SerialReplayOptions options{can_options, link->name, link->protocol};  // allow_motion: --yes

  LinkSpec spec;
  try {
    spec = parse_serial_replay_link(link_text, replay_serial_settings(link->name, link->protocol));
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--link", e.what());
  }
  if (link->motion > 0 && !options.allow_motion && !opt.json)
    fmt::print(stderr, "replay: dropping {} message(s) that can move motors ({} per pass: {}); --allow-motion sends "
                       "them\n",
               link->motion * opt.loops, link->motion, format_motion_by_type(link->motion_by_type));
  auto port = open_serial(spec.device, spec.serial);
  const std::string protocol_text =
      fmt::format("{}{}", to_string(link->protocol), link->guessed ? ", guessed from the bytes" : "");
  if (!opt.json)
    fmt::print(stderr, "replay: {} ({}, {}) -> {}: {} chunks per pass, {} pass(es), speed {}{}\n", opt.file,
               link->name, protocol_text, spec.text(), options.allow_motion ? link->chunks : link->writes, opt.loops,
               options.speed > 0 ? fmt::format("{:g}", options.speed) : std::string("max"),
               opt.step ? ", one chunk per Enter" : "");

  MonotonicReplayClock clock(&g_interrupted);
  SerialReplayHooks hooks;
  hooks.write = [&port](std::span<const std::uint8_t> bytes) { port->write(bytes, 1000ms); };
  hooks.on_corrupt = corrupt_reporter(opt.file, nullptr);
  hooks.stop = interrupted;
  std::uint64_t stepped = 0;
  if (opt.step) {
    hooks.step = [&stepped](const SerialChunk& chunk, std::span<const std::uint8_t> bytes) {
      const std::uint64_t t = chunk.timestamp_ns.value_or(0);
      const std::size_t left_out = chunk.bytes.size() - bytes.size();
      return step_prompt(++stepped, fmt::format("({:010}.{:06}) {:02X}{}", t / 1'000'000'000ULL,
                                                t % 1'000'000'000ULL / 1'000ULL, fmt::join(bytes, ""),
                                                left_out ? fmt::format(" ({} bytes of motion left out)", left_out)
                                                         : std::string()));
    };
  }
  const auto open_pass = [&opt, &read_options]() { return open_serial_capture_reader(opt.file, read_options); };
  SerialReplayReport report;
  const int status = report_errors<SerialError>([&] { report = replay_serial(open_pass, options, clock, hooks); });
  const std::string motion =
      options.allow_motion
          ? fmt::format("{} message(s) that can move motors sent (--allow-motion)", report.motion_sent)
          : fmt::format("not sent: {} message(s) that can move motors{}", report.motion_dropped,
                        report.motion_dropped
                            ? fmt::format(" ({}; {} bytes)", format_motion_by_type(report.motion_by_type),
                                          report.motion_bytes)
                            : std::string());
  print_report(opt.json,
               {{"file", opt.file},
                {"link", spec.text()},
                {"captured_link", report.link},
                {"protocol", std::string(to_string(report.protocol))},
                {"protocol_guessed", link->guessed},
                {"chunks", report.chunks},
                {"bytes", report.bytes},
                {"writes", report.writes},
                {"bytes_sent", report.bytes_sent},
                {"frames", report.frames},
                {"motion_dropped", report.motion_dropped},
                {"motion_dropped_bytes", report.motion_bytes},
                {"motion_dropped_by_type", report.motion_by_type},
                {"motion_sent", report.motion_sent},
                {"other_links", report.other_links},
                {"corrupt", report.corrupt}},
               fmt::format("{} chunks written of {} read ({} of {} bytes)", report.writes, report.chunks,
                           report.bytes_sent, report.bytes),
               fmt::format("{}, {} chunks of other links, {} corrupt records", motion, report.other_links,
                           report.corrupt),
               report, "chunks");
  return status;
}

int run_replay(const ReplayCliOptions& opt) {
  using namespace saul::host;
  ReplayOptions options;
  if (opt.speed == "max") {
    options.speed = 0;
  } else {
    std::size_t used = 0;
    try {
      options.speed = std::stod(opt.speed, &used);
    } catch (...) {
      used = 0;
    }
    if (used == 0 || used != opt.speed.size() || !(options.speed > 0) || options.speed > 1000)
      throw CLI::ValidationError("--speed", "bad speed '" + opt.speed + "' (a factor such as 0.5 or 2, or max)");
  }
  options.loops = opt.loops;
  if (options.loops == 0) throw CLI::ValidationError("--loop", "give at least 1 pass");
  try {
    options.include = id_filters(opt.ids);
    options.exclude = id_filters(opt.exclude);
    for (const auto& t : opt.maps) options.mappings.push_back(parse_id_mapping(t));
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--id/--map", e.what());
  }
  if (!opt.max_gap.empty())
    options.max_gap_ns = static_cast<std::uint64_t>(parse_duration(opt.max_gap).count()) * 1'000'000ULL;
  if (opt.yes && opt.no_motion) throw CLI::ValidationError("--no-motion", "give --yes (--allow-motion) or --no-motion, not both");
  // The rule, for CAN and serial captures alike: what can move motors is left out unless --allow-motion, and
  // the user is told how many before anything is sent (no question: a replay in a script behaves as on a terminal).
  options.allow_motion = opt.yes;

  // Replay reads the capture more than once, so a pipe would replay nothing: refused before it is touched.
  refuse_read_once("replay", opt.file, "once to show what it will send and again for each pass");
  OpenedCapture opened = open_capture(opt.file, serial_read_options(opt.serial));  // CaptureOpenError: main says it
  // The kind of link --link names: a serial link may leave its rate out (it follows the capture), so it is parsed
  // later; anything else is resolved now (--to, $SAUL_LINK, the config file).
  std::optional<LinkSpec> resolved;
  if (!opt.link.starts_with("serial:")) resolved = resolve_link(opt.link);
  const bool to_serial = !resolved || !resolved->is_can();
  const std::string link_text = resolved ? resolved->text() : opt.link;
  if (opened.chunks) {
    if (!to_serial)
      throw CLI::ValidationError("--link", fmt::format("{} holds serial bytes and {} is a CAN link: replay it onto a "
                                                     "serial port, --link serial:/dev/ttyUSB0 (the baud rate follows "
                                                     "the capture)",
                                                     opt.file, link_text));
    return run_serial_replay(opt, options, std::move(opened.chunks), link_text);
  }
  if (to_serial)
    throw CLI::ValidationError("--link", fmt::format("{} holds CAN frames and {} is a serial link: replay it onto a CAN "
                                                   "link, --link can0 or --link slcan:/dev/ttyACM0",
                                                   opt.file, link_text));
  if (!opt.from.empty())
    throw CLI::ValidationError("--from", opt.file + " holds CAN frames: --from picks a link of a serial capture "
                                                    "(select CAN ids with --id)");

  auto open_pass = [&opt]() { return open_capture_reader(opt.file, serial_read_options(opt.serial).format); };
  ReplayPreview preview = preview_replay(opened.frames, options);  // (motion allowed: it counts what moves)
  opened.frames.reset();
  if (preview.motion > 0 && !opt.yes && !opt.json)
    fmt::print(stderr, "replay: dropping {} frame(s) that can move motors ({} per pass: 0x300, 0x302 balance/manual, "
                       "VESC set commands); --allow-motion sends them\n",
               preview.motion * opt.loops, preview.motion);
  const LinkSpec& spec = *resolved;
  auto link = open_can_link(spec);
  if (!opt.json)
    fmt::print(stderr, "replay: {} -> {}: {} frames per pass, {} pass(es), speed {}{}\n", opt.file, link->name(),
               preview.to_send - (options.allow_motion ? 0 : preview.motion), opt.loops,
               options.speed > 0 ? fmt::format("{:g}", options.speed) : std::string("max"),
               opt.step ? ", one frame per Enter" : "");

  MonotonicReplayClock clock(&g_interrupted);
  ReplayHooks hooks;
  hooks.send = [&link](const saul::CanFrame& f) { link->send(f, 1000ms); };
  hooks.on_corrupt = corrupt_reporter(opt.file, nullptr);
  hooks.stop = interrupted;
  std::uint64_t stepped = 0;
  if (opt.step) {
    hooks.step = [&stepped](const saul::CanFrame& f) {
      return step_prompt(++stepped, frame_text(f));
    };
  }
  ReplayReport report;
  const int status = report_errors<LinkError>([&] { report = replay(open_pass, options, clock, hooks); });
  print_report(opt.json,
               {{"file", opt.file},
                {"link", link->name()},
                {"frames", report.frames},
                {"sent", report.sent},
                {"filtered", report.filtered},
                {"motion_dropped", report.motion_dropped},
                {"error_frames", report.error_frames},
                {"corrupt", report.corrupt}},
               fmt::format("{} frames sent of {} read", report.sent, report.frames),
               fmt::format("not sent: {} filtered, {} that can move motors{}, {} error frames, {} corrupt records",
                           report.filtered, report.motion_dropped,
                           report.motion_dropped ? " (--allow-motion sends them)" : "", report.error_frames,
                           report.corrupt),
               report, "frames");
  return status;
}

}  // namespace

void add_replay_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<ReplayCliOptions>(
      app, run, "replay", "Replay a CAN or serial capture onto a bus or serial port with its original timing",
      run_replay);
  cmd->add_option("FILE", o->file,
                  "capture file, CAN frames or serial bytes: " + saul::host::capture_format_list(true))
      ->required();
  cmd->add_option("-l,--link,--to", o->link,
                  "the link: can0 | slcan:/dev/ttyACM0[@500000] for CAN captures; serial:/dev/ttyUSB0[@BAUD[:8E1]] "
                  "for serial captures (default: $SAUL_LINK, else ~/.config/saulctl/link; --to is the same)");
  cmd->add_option("--speed", o->speed, "time factor: 2 = twice as fast, 0.5 = half speed, max = no waiting")
      ->capture_default_str();
  cmd->add_option("--loop", o->loops, "passes over the file")->capture_default_str();
  add_id_option(cmd, o->ids, "only these logged ids");
  add_id_option(cmd, o->exclude, "never these logged ids", "--exclude-id");
  cmd->add_option("--map", o->maps, "send id FROM as id TO, hex (--map 300=310); repeatable")->delimiter(',');
  cmd->add_option("--max-gap", o->max_gap, "shorten longer silences of the file to this (1s)")->check(duration_check());
  cmd->add_flag("--step", o->step, "one frame (serial: one chunk) per Enter (q quits); no timing");
  cmd->add_flag("-y,--yes,--allow-motion", o->yes, "send the frames and messages that can move motors too");
  cmd->add_flag("--no-motion", o->no_motion, "leave out what can move motors and say how many (the default)");
  cmd->add_option("--from", o->from, "serial captures: the captured link to replay, when the file holds several");
  add_serial_read_options(cmd, o->serial);
  cmd->add_flag("--json", o->json, "the final report as one JSON object on stdout");
  cmd->footer(
      "\nEvery frame is due at an absolute deadline on the monotonic clock (start + file time / speed), never\n"
      "relative to the frame before, so timing does not drift. At the end: how late frames left (p50, p99, max,\n"
      "and how many later than 1 ms).\n"
      "Frames that can move motors (0x300, 0x302 balance/manual, VESC set commands: 29-bit ids with command\n"
      "0..4 or 10..13) are left out unless --allow-motion (same as --yes); how many is said before the first\n"
      "frame goes and again in the report. --no-motion says the default explicitly.\n"
      "Filters apply to the ids in the file, then --map, then the motion rule (to what goes out).\n"
      "\nSerial captures (inter-board, CRSF, Pride) go to a serial port: each chunk of bytes is written at its\n"
      "timestamp, with the same deadlines, --speed, --loop, --step and lateness report (per chunk). Without a\n"
      "rate in --to, the port runs as the capture was recorded, else as its protocol: inter-board 460800 8N1,\n"
      "CRSF 420000 8N1, Pride 38400 8E1. The bytes are cut into frames with the protocol's decoder, and\n"
      "messages that can move motors are left out unless --allow-motion, and counted:\n"
      "  inter-board rc_cmd (unless its kill flag is set: an estop goes through),\n"
      "  CRSF rc_channels (unless CH6 asks for estop; an RC frame that does not decode counts too),\n"
      "  Pride vcu_command (all of them, neutral ones too).\n"
      "Everything else (sensor, fault, state, led_cmd, buzzer, CRSF telemetry, Pride controller_status) and\n"
      "every byte outside a valid frame (noise, bad CRCs) goes out as captured. A capture whose protocol is\n"
      "neither named nor guessable needs --protocol, or --allow-motion to send it unexamined. A CAN capture\n"
      "needs a CAN link and a serial capture a serial link (exit 2 otherwise).\n"
      "\nExamples:\n"
      "  saulctl replay run.log --link can0 --no-motion           telemetry and acks only\n"
      "  saulctl replay run.pcapng --link slcan:/dev/ttyACM0 --speed 2 --loop 3 --yes\n"
      "  saulctl replay run.log --link can0 --id 400,401 --map 400=410\n"
      "  saulctl replay run.log --link vcan0 --step --no-motion\n"
      "  saulctl replay uart.serial --link serial:/dev/ttyUSB0    inter-board bytes at 460800, rc_cmd left out\n"
      "  saulctl replay pride.serial --link serial:/dev/ttyUSB1 --allow-motion --loop 10\n"
      "  saulctl replay --protocol pride --samplerate 1M la.txt --link serial:/dev/ttyUSB1@38400:8E1\n");
}

}  // namespace saulctl
