// saulctl replay: a CAN capture back onto a bus with its original timing. Scheduling, filters, remapping, the
// motion rule and the lateness statistics are in the host library (saulproto/host/replay.hpp); this file asks,
// opens the link and reports.
#include <fmt/core.h>
#include <unistd.h>

#include <iostream>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/host/candump.hpp"
#include "saulproto/host/capture.hpp"
#include "saulproto/host/frame_text.hpp"
#include "saulproto/host/link_spec.hpp"
#include "saulproto/host/replay.hpp"

namespace saulctl {
namespace {

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
};

std::string micros(std::uint64_t ns) { return fmt::format("{:.0f} us", static_cast<double>(ns) / 1e3); }

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
    for (const auto& t : opt.ids) options.include.push_back(parse_id_filter(t));
    for (const auto& t : opt.exclude) options.exclude.push_back(parse_id_filter(t));
    for (const auto& t : opt.maps) options.mappings.push_back(parse_id_mapping(t));
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--id/--map", e.what());
  }
  if (!opt.max_gap.empty())
    options.max_gap_ns = static_cast<std::uint64_t>(parse_duration(opt.max_gap).count()) * 1'000'000ULL;
  if (opt.yes && opt.no_motion) throw CLI::ValidationError("--no-motion", "give --yes (--allow-motion) or --no-motion, not both");

  auto open_pass = [&opt]() { return open_capture_reader(opt.file); };
  ReplayPreview preview;
  try {
    auto reader = open_pass();
    preview = preview_replay(*reader, options);
  } catch (const CaptureOpenError& e) {
    fmt::print(stderr, "saulctl replay: {}\n", e.what());
    return kFailure;
  }
  if (preview.motion > 0) {
    if (opt.no_motion) {
      options.allow_motion = false;
      if (!opt.json)
        fmt::print(stderr, "replay: --no-motion: dropping {} frame(s) that can move motors ({} per pass)\n",
                   preview.motion * opt.loops, preview.motion);
    } else if (confirm_motion(opt.yes, fmt::format("replay {} frame(s) that can move motors (0x300, 0x302 "
                                                   "balance/manual, VESC set commands)",
                                                   preview.motion * opt.loops))) {
      options.allow_motion = true;
    } else {
      fmt::print(stderr, "saulctl replay: add --allow-motion (--yes) to send them, or --no-motion to replay "
                         "everything else\n");
      return kUsage;
    }
  }
  const LinkSpec spec = resolve_link(opt.link);
  if (!spec.is_can()) throw CLI::ValidationError("--to", spec.text() + " is a serial link; replay sends CAN frames");
  auto link = open_can_link(spec);
  if (!opt.json)
    fmt::print(stderr, "replay: {} -> {}: {} frames per pass, {} pass(es), speed {}{}\n", opt.file, link->name(),
               preview.to_send - (options.allow_motion ? 0 : preview.motion), opt.loops,
               options.speed > 0 ? fmt::format("{:g}", options.speed) : std::string("max"),
               opt.step ? ", one frame per Enter" : "");

  MonotonicReplayClock clock(&g_interrupted);
  ReplayHooks hooks;
  hooks.send = [&link](const saul::CanFrame& f) { link->send(f, std::chrono::milliseconds(1000)); };
  hooks.stop = [] { return g_interrupted.load(); };
  hooks.on_corrupt = [&opt](const CaptureError& e) {
    fmt::print(stderr, "saulctl replay: {}\n", format_capture_error(opt.file, e));
  };
  std::uint64_t stepped = 0;
  if (opt.step) {
    hooks.step = [&stepped](const saul::CanFrame& f) {
      ++stepped;
      fmt::print(stderr, "[{}] {:<24} {}  (Enter sends, q quits) ", stepped, format_candump_frame(f),
                 describe_frame(f));
      std::string answer;
      if (!std::getline(std::cin, answer) || answer == "q" || answer == "quit") return false;
      return true;
    };
  }
  ReplayReport report;
  int status = kOk;
  try {
    report = replay(open_pass, options, clock, hooks);
  } catch (const CaptureOpenError& e) {
    fmt::print(stderr, "saulctl replay: {}\n", e.what());
    return kFailure;
  } catch (const LinkError& e) {
    status = report_link_error(e);
  }
  const auto& l = report.lateness;
  if (opt.json) {
    nlohmann::json j{{"file", opt.file},
                     {"link", link->name()},
                     {"passes", report.passes},
                     {"frames", report.frames},
                     {"sent", report.sent},
                     {"filtered", report.filtered},
                     {"motion_dropped", report.motion_dropped},
                     {"error_frames", report.error_frames},
                     {"corrupt", report.corrupt},
                     {"elapsed_s", static_cast<double>(report.elapsed_ns) / 1e9},
                     {"stopped", report.stopped}};
    if (l.count() > 0)
      j["lateness"] = {{"frames", l.count()},
                       {"p50_us", static_cast<double>(l.percentile_ns(50)) / 1e3},
                       {"p99_us", static_cast<double>(l.percentile_ns(99)) / 1e3},
                       {"max_us", static_cast<double>(l.max_ns()) / 1e3},
                       {"later_than_1ms", l.over_1ms()}};
    fmt::print("{}\n", j.dump());
  } else {
    fmt::print(stderr, "replay: {} frames sent of {} read in {:.3f} s ({} pass(es){}); not sent: {} filtered, {} that "
                       "can move motors{}, {} error frames, {} corrupt records\n",
               report.sent, report.frames, static_cast<double>(report.elapsed_ns) / 1e9, report.passes,
               report.stopped ? ", stopped early" : "", report.filtered, report.motion_dropped,
               report.motion_dropped ? " (--no-motion)" : "", report.error_frames, report.corrupt);
    if (l.count() > 0)
      fmt::print(stderr, "replay: lateness p50 {}, p99 {}, max {}; {} of {} frames later than 1 ms\n",
                 micros(l.percentile_ns(50)), micros(l.percentile_ns(99)), micros(l.max_ns()), l.over_1ms(),
                 l.count());
  }
  return status;
}

}  // namespace

void add_replay_command(CLI::App& app, Runner& run) {
  auto o = std::make_shared<ReplayCliOptions>();
  auto* cmd = app.add_subcommand("replay", "Replay a CAN capture onto a bus with its original timing");
  cmd->add_option("FILE", o->file, "CAN capture file (candump, pcap, pcapng, ASC)")->required();
  cmd->add_option("--to,-l,--link", o->link, "can0 | slcan:/dev/ttyACM0[@500000] (default: $SAUL_LINK)");
  cmd->add_option("--speed", o->speed, "time factor: 2 = twice as fast, 0.5 = half speed, max = no waiting")
      ->capture_default_str();
  cmd->add_option("--loop", o->loops, "passes over the file")->capture_default_str();
  cmd->add_option("--id", o->ids, "only these logged ids, ID[:MASK] in hex (300, 400:7F0), comma separated")
      ->delimiter(',');
  cmd->add_option("--exclude-id", o->exclude, "never these logged ids, ID[:MASK] in hex")->delimiter(',');
  cmd->add_option("--map", o->maps, "send id FROM as id TO, hex (--map 300=310); repeatable")->delimiter(',');
  cmd->add_option("--max-gap", o->max_gap, "shorten longer silences of the file to this (1s)");
  cmd->add_flag("--step", o->step, "one frame per Enter (q quits); no timing");
  cmd->add_flag("-y,--yes,--allow-motion", o->yes, "send frames that can move motors without asking");
  cmd->add_flag("--no-motion", o->no_motion, "drop frames that can move motors and say how many");
  cmd->add_flag("--json", o->json, "the final report as one JSON object on stdout");
  cmd->footer(
      "\nEvery frame is due at an absolute deadline on the monotonic clock (start + file time / speed), never\n"
      "relative to the frame before, so timing does not drift. At the end: how late frames left (p50, p99, max,\n"
      "and how many later than 1 ms).\n"
      "Frames that can move motors (0x300, 0x302 balance/manual, VESC set commands: 29-bit ids with command\n"
      "0..4 or 10..13) need --allow-motion (same as --yes), or a typed 'yes' on a terminal; --no-motion drops\n"
      "them instead, and the report says how many were dropped.\n"
      "Filters apply to the ids in the file, then --map, then the motion rule (to what goes out).\n"
      "\nExamples:\n"
      "  saulctl replay run.log --to can0 --no-motion           telemetry and acks only\n"
      "  saulctl replay run.pcapng --to slcan:/dev/ttyACM0 --speed 2 --loop 3 --yes\n"
      "  saulctl replay run.log --to can0 --id 400,401 --map 400=410\n"
      "  saulctl replay run.log --to vcan0 --step --no-motion\n");
  cmd->callback([o, &run] {
    run = [o]() -> int {
      install_signal_handlers();
      try {
        return run_replay(*o);
      } catch (const CLI::ValidationError& e) {
        fmt::print(stderr, "saulctl: {}\n", e.what());
        return kUsage;
      } catch (const std::exception& e) {
        return report_link_error(e);
      }
    };
  });
}

}  // namespace saulctl
