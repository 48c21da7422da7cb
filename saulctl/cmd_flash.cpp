// saulctl flash: write firmware to the BALANCE or IO board's ESP32-S3 through its ROM bootloader, verify every
// region by MD5, reset into the application. The protocol work is in saulproto/host/flash/esp_flasher.hpp.
#include <fmt/core.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <optional>

#include "commands.hpp"
#include "live.hpp"
#include "saulproto/core/saul_can.hpp"
#include "saulproto/host/flash/esp_flasher.hpp"
#include "saulproto/host/link/device_holders.hpp"
#include "saulproto/host/robot/robot_client.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;
using saul::host::FlashError;
using saul::host::ResetStyle;

struct FlashOptions {
  std::vector<std::string> inputs;
  std::string offset = "0x10000";
  std::string build_dir;
  std::string port;
  std::string board;
  std::string flash_size;
  std::uint32_t baud = 460800;
  bool no_compress = false;
  bool force = false;
  bool no_reset = false;
  std::string reset;  ///< "bootloader" | "app": only reset the board, write nothing
  int connect_attempts = 4;
  std::string link;
  bool skip_robot_check = false;
  std::string robot_timeout = "1s";
};

std::string kib(std::uint64_t bytes) { return fmt::format("{:.1f} KiB", static_cast<double>(bytes) / 1024.0); }
std::string mb(std::uint64_t bytes) {
  return bytes % (1024 * 1024) == 0 ? fmt::format("{} MB", bytes / (1024 * 1024)) : kib(bytes);
}

const char* board_name(ResetStyle s) { return s == ResetStyle::usb_serial_jtag ? "IO board" : "BALANCE board"; }

saul::host::FlashPlan build_plan(const FlashOptions& opt) {
  saul::host::FlashPlan plan;
  if (!opt.build_dir.empty()) {
    if (!opt.inputs.empty()) throw CLI::ValidationError("inputs", "give either --build-dir or files, not both");
    plan = saul::host::load_build_dir(opt.build_dir);
  } else if (opt.inputs.size() == 1) {
    std::error_code ec;
    if (saul::host::parse_offset(opt.inputs[0]) && !std::filesystem::exists(opt.inputs[0], ec))
      throw CLI::ValidationError("inputs", "'" + opt.inputs[0] + "' is an offset with no file: give OFFSET FILE pairs");
    const auto offset = saul::host::parse_offset(opt.offset);
    if (!offset) throw CLI::ValidationError("--offset", "'" + opt.offset + "' is not an offset (e.g. 0x10000)");
    plan.images.push_back(saul::host::load_image(*offset, opt.inputs[0]));
  } else if (!opt.inputs.empty() && opt.inputs.size() % 2 == 0) {
    for (std::size_t i = 0; i < opt.inputs.size(); i += 2) {
      const auto offset = saul::host::parse_offset(opt.inputs[i]);
      if (!offset)
        throw CLI::ValidationError("inputs", "'" + opt.inputs[i] +
                                                 "' is not an offset: give OFFSET FILE pairs, "
                                                 "e.g. 0x0 bootloader.bin 0x8000 partition-table.bin 0x10000 app.bin");
      plan.images.push_back(saul::host::load_image(*offset, opt.inputs[i + 1]));
    }
  } else {
    throw CLI::ValidationError("inputs", "give FILE (written at --offset), OFFSET FILE pairs, or --build-dir DIR");
  }
  if (!opt.flash_size.empty()) {
    plan.flash_size = saul::host::parse_flash_size(opt.flash_size);
    if (!plan.flash_size)
      throw CLI::ValidationError("--flash-size", "'" + opt.flash_size + "': use e.g. 4MB, 8MB, 16MB");
    plan.flash_size_source = "--flash-size";
  }
  saul::host::check_plan(plan, opt.force);
  for (const auto& w : plan.warnings) say("warning: {}", w);
  return plan;
}

// Picks the port and the board. Throws CLI::ValidationError for usage problems, FlashError(input) when the
// board cannot be found.
std::pair<std::string, ResetStyle> pick_port(const FlashOptions& opt, std::optional<saul::host::PortInfo>& info) {
  std::optional<ResetStyle> style;
  if (opt.board == "io") style = ResetStyle::usb_serial_jtag;
  if (opt.board == "balance") style = ResetStyle::usb_uart_bridge;
  if (!opt.port.empty()) {
    std::error_code ec;
    const auto real = std::filesystem::weakly_canonical(opt.port, ec);
    // Listing is harmless (never opens a port); it tells the USB identity of a real device.
    for (const auto& p : saul::host::list_serial_ports()) {
      std::error_code e2;
      if (p.path == opt.port || std::filesystem::weakly_canonical(p.path, e2) == real) info = p;
    }
    if (!style && info) {
      if (saul::host::is_board_port(*info, ResetStyle::usb_serial_jtag)) style = ResetStyle::usb_serial_jtag;
      if (saul::host::is_board_port(*info, ResetStyle::usb_uart_bridge)) style = ResetStyle::usb_uart_bridge;
    }
    if (!style)
      throw CLI::ValidationError("--board", "cannot tell which board " + opt.port +
                                                " is: add --board balance (CH343 bridge) or --board io "
                                                "(USB-Serial/JTAG); it picks the reset sequence");
    return {opt.port, *style};
  }
  if (!style) throw CLI::ValidationError("--board", "give --board balance|io (or --port PATH)");
  std::vector<saul::host::PortInfo> found;
  for (const auto& p : saul::host::list_serial_ports())
    if (saul::host::is_board_port(p, *style)) found.push_back(p);
  if (found.empty())
    throw FlashError(FlashError::Kind::input,
                     fmt::format("no {} found ({}): is it plugged in and powered? 'saulctl ports' lists the serial "
                                 "ports; or give --port",
                                 board_name(*style),
                                 *style == ResetStyle::usb_serial_jtag ? "USB 303a:1001" : "USB 1a86:55d3/55d4"));
  if (found.size() > 1) {
    std::vector<std::string> paths;
    for (const auto& p : found) paths.push_back(p.path + " (serial " + p.serial_number + ")");
    throw FlashError(FlashError::Kind::input,
                     fmt::format("several {}s found: {}; pick one with --port", board_name(*style), fmt::join(paths, ", ")));
  }
  info = found[0];
  return {found[0].path, *style};
}

// Before flashing: mode off, then an 0x400 saying OFF. Returns an exit code (kOk to go on).
int check_robot(const FlashOptions& opt) {
  if (opt.skip_robot_check) {
    say("WARNING: --skip-robot-check: the robot's state is NOT checked before flashing. A BALANCE "
        "board that is balancing stops controlling the motors the moment it resets: hold the robot or put it "
        "on its stand.");
    return kOk;
  }
  const char* home = std::getenv("HOME");
  std::error_code ec;
  const char* env = std::getenv("SAUL_LINK");
  const bool have_link = !opt.link.empty() || (env && *env) ||
                         (home && std::filesystem::exists(std::string(home) + "/.config/saulctl/link", ec));
  if (!have_link) {
    fmt::print(
        "note: no CAN link (--link, $SAUL_LINK): the robot's state is not checked; with a link saulctl puts "
        "it in mode off first\n");
    return kOk;
  }
  const auto spec = resolve_link(opt.link);
  const auto timeout = parse_duration(opt.robot_timeout);
  auto link = saul::host::open_can_link(spec);
  saul::host::RobotClient client(*link);
  const auto ack = client.set_mode(saul::saulcan::Mode::off, timeout);
  if (ack.status == saul::host::CommandOutcome::Status::no_answer) {
    say("robot check: no acknowledgement of mode off within {} ms on {}: is the BALANCE board powered "
        "and on the bus? (if it is already in download mode or not running, use --skip-robot-check)",
        timeout.count(), link->name());
    return kTimeout;
  }
  if (ack.status == saul::host::CommandOutcome::Status::rejected) {
    say("robot check: the robot refused mode off ({}): not flashing; see why with 'saulctl monitor "
        "--link {}', or hold the robot and use --skip-robot-check",
        saul::saulcan::to_string(ack.result), link->name());
    return kFailure;
  }
  // The acknowledgement says the command was taken; the telemetry says what the robot is doing now.
  std::optional<saul::saulcan::RobotState> state;
  const auto deadline = steady_clock::now() + timeout;
  while (!(state && (*state == saul::saulcan::RobotState::off || *state == saul::saulcan::RobotState::estop))) {
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() <= 0) break;
    const auto frame = link->receive(left);
    if (!frame) continue;
    if (auto t = saul::saulcan::decode_telemetry_a(*frame)) state = t->state;
  }
  if (!state) {
    say("robot check: mode off was acknowledged but no 0x400 telemetry came within {} ms on {}: "
        "cannot confirm the robot is OFF (use --skip-robot-check to flash anyway)",
        timeout.count(), link->name());
    return kTimeout;
  }
  if (*state != saul::saulcan::RobotState::off && *state != saul::saulcan::RobotState::estop) {
    say("robot check: the robot still reports state {} after mode off: not flashing; bring it to rest "
        "and disarm it (saulctl mode off, or its RC kill switch), then run again",
        saul::saulcan::to_string(*state));
    return kFailure;
  }
  fmt::print("robot check: state {} on {} (0x400 telemetry)\n", saul::saulcan::to_string(*state), link->name());
  return kOk;
}

class ProgressBar {
 public:
  explicit ProgressBar(std::size_t total) : total_(total), tty_(::isatty(STDERR_FILENO) != 0) {}
  void operator()(const saul::host::FlashProgress& p) {
    if (!tty_ || !p.image) return;
    const char* stage = p.stage == saul::host::FlashProgress::Stage::checking    ? "checking "
                        : p.stage == saul::host::FlashProgress::Stage::verifying ? "verifying"
                                                                                 : "writing  ";
    const double frac = p.bytes_total ? static_cast<double>(p.bytes_done) / static_cast<double>(p.bytes_total) : 0;
    constexpr int kWidth = 24;
    const int filled = static_cast<int>(frac * kWidth);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(kWidth, '-');
    std::string name = std::filesystem::path(p.image->name).filename().string();
    if (name.size() > 22) name = name.substr(0, 21) + "~";
    fmt::print(stderr, "\r[{}/{}] {:<22} {} [{}] {:3.0f}%  {}/{}  {:.1f} KiB/s   ", p.index + 1, total_, name, stage,
               bar, frac * 100, kib(p.bytes_done), kib(p.bytes_total), p.bytes_per_second() / 1024.0);
    dirty_ = true;
  }
  void clear() {
    if (tty_ && dirty_) fmt::print(stderr, "\r{:<110}\r", "");
    dirty_ = false;
  }

 private:
  std::size_t total_;
  bool tty_;
  bool dirty_ = false;
};

void print_outcome(const saul::host::RegionOutcome& r) {
  using S = saul::host::RegionOutcome::State;
  std::string what;
  switch (r.state) {
    case S::unchanged: what = "unchanged (flash MD5 already matches), skipped"; break;
    case S::written:
      what = fmt::format("written and verified in {:.2f} s ({:.1f} KiB/s effective, {} on the wire{}{})", r.seconds,
                         r.seconds > 0 ? static_cast<double>(r.size) / 1024.0 / r.seconds : 0.0, kib(r.wire_bytes),
                         r.compressed ? ", compressed" : "",
                         r.retries ? fmt::format(", {} block(s) sent again", r.retries) : std::string());
      break;
    case S::unverified: what = "UNVERIFIED: the write did not complete or did not verify"; break;
    case S::pending: what = "not written"; break;
  }
  fmt::print("0x{:06X} {:<40} {:>11}  {}\n", r.offset, r.name, kib(r.size), what);
}

void print_app_versions(const saul::host::FlashPlan& plan) {
  for (const auto& img : plan.images) {
    auto app = saul::esp::parse_app_description(img.data);
    if (!app) continue;
    fmt::print("app at 0x{:06X}: {} {} (built {} {}, ESP-IDF {})\n", img.offset, app->project_name, app->version,
               app->date, app->time, app->idf_ver);
  }
}

// Another program with the port open (a serial monitor) would swallow the bootloader's answers. The far end of a
// pseudo-terminal (the simulator, a test) is the device itself and is not listed (device_holders.hpp).
void warn_holders(const std::string& path) {
  if (const auto holders = saul::host::device_holders(path); !holders.empty())
    say("warning: {} is also open in {}: a serial monitor there would swallow the bootloader's answers; close it",
        path, saul::host::describe_holders(holders));
}

// Runs the sequence on the port's DTR and RTS lines; says what they were.
std::string run_lines(saul::host::SerialPort& port, const std::vector<saul::host::LineStep>& steps) {
  saul::host::run_line_sequence(port, steps, saul::host::sleep_real);
  std::string s;
  for (const auto& st : steps) {
    s += fmt::format("{}({:d},{:d})", s.empty() ? "" : " ", st.dtr, st.rts);
    if (st.hold.count() > 0) s += fmt::format(" {} ms", st.hold.count());
  }
  return s;
}

// saulctl flash --reset bootloader|app: the reset alone, nothing written (a bench engineer's "hold BOOT, tap
// RESET" or "tap RESET", done over USB), on the port run_flash() opened after the robot check.
int run_reset(const FlashOptions& opt, saul::host::SerialPort& port, const std::string& path, ResetStyle style) {
  if (opt.reset == "bootloader") {
    fmt::print("reset the {} on {} into download mode: (DTR,RTS) {}; nothing written, the bootloader's answer not "
               "checked (flash with --no-reset now)\n",
               board_name(style), path, run_lines(port, saul::host::bootloader_reset_sequence(style, 0)));
    return kOk;
  }
  if (style == ResetStyle::usb_uart_bridge) {
    fmt::print("reset the {} on {} into its application: EN pulse, (DTR,RTS) {}\n", board_name(style), path,
               run_lines(port, saul::host::hard_reset_sequence(style)));
    return kOk;
  }
  // IO board: a USB-Serial/JTAG RTS reset is a core reset that leaves a chip in download mode there. When a
  // loader answers, leave download mode as a flash does (RTC watchdog); otherwise the application is running and
  // the RTS reset restarts it.
  saul::host::FlasherOptions fo;
  fo.reset = style;
  fo.reset_before = false;
  fo.connect_attempts = 1;
  fo.cancelled = interrupted;
  saul::host::EspFlasher flasher(port, fo);
  try {
    flasher.connect();
  } catch (const FlashError& e) {
    if (e.kind() != FlashError::Kind::no_answer) throw;
    fmt::print("no bootloader answered on {}: restarted the {}'s application by the USB-Serial/JTAG reset, "
               "(DTR,RTS) {}\n",
               path, board_name(style), run_lines(port, saul::host::hard_reset_sequence(style)));
    return kOk;
  }
  flasher.reset_to_app();
  fmt::print("the {} on {} left download mode ({})\n", board_name(style), path,
             flasher.chip().usb_serial_jtag ? "RTC watchdog system reset: re-samples GPIO0" : "EN pulse on RTS");
  return kOk;
}

int run_flash(const FlashOptions& opt) {
  const bool reset_only = !opt.reset.empty();
  if (reset_only && (!opt.inputs.empty() || !opt.build_dir.empty()))
    throw CLI::ValidationError("--reset", "--reset only resets the board: give no files and no --build-dir");
  if (reset_only && opt.no_reset) throw CLI::ValidationError("--reset", "--reset and --no-reset contradict each other");
  const saul::host::FlashPlan plan = reset_only ? saul::host::FlashPlan{} : build_plan(opt);
  std::optional<saul::host::PortInfo> info;
  const auto [path, style] = pick_port(opt, info);

  if (const int rc = check_robot(opt); rc != kOk) return rc;

  warn_holders(path);
  if (!reset_only)
    fmt::print("flashing the {} on {} ({}): {} region(s), flash {} ({})\n", board_name(style), path,
               saul::host::to_string(style), plan.images.size(), mb(plan.flash_size), plan.flash_size_source);

  auto port = saul::host::open_serial(path, saul::host::SerialSettings{});  // 115200 8N1; a held port names its holder
  if (reset_only) return run_reset(opt, *port, path, style);

  ProgressBar bar(plan.images.size());
  saul::host::FlasherOptions fo;
  fo.reset = style;
  fo.reset_before = !opt.no_reset;
  fo.connect_attempts = opt.connect_attempts;
  fo.compress = !opt.no_compress;
  fo.skip_unchanged = !opt.force;
  fo.progress = [&bar](const saul::host::FlashProgress& p) { bar(p); };
  fo.cancelled = interrupted;
  fo.note = [&bar](const std::string& s) {
    bar.clear();
    fmt::print("{}\n", s);
  };
  saul::host::EspFlasher flasher(*port, fo);

  const auto t0 = steady_clock::now();
  try {
    flasher.connect();
    flasher.attach_flash(plan.flash_size);
    if (!flasher.chip().usb_serial_jtag) flasher.change_baud(opt.baud);  // USB-Serial/JTAG runs at USB speed anyway
    for (std::size_t i = 0; i < plan.images.size(); ++i) {
      const auto r = flasher.write(plan.images[i], i);
      bar.clear();
      print_outcome(r);
    }
    print_app_versions(plan);
    flasher.reset_to_app();
  } catch (const std::exception& e) {
    bar.clear();
    // What was done before the failure, and what was left unverified.
    for (const auto& r : flasher.outcomes())
      if (r.state == saul::host::RegionOutcome::State::unverified) print_outcome(r);
    if (dynamic_cast<const FlashError*>(&e)) return report_error(e);  // 3 for no answer, else 1
    // The port failing under us (a write that would not go out, a driver error): FlashError's lines carry their
    // fix, the port's own do not.
    say("{}: replug the board and flash again{}", e.what(),
        flasher.outcomes().empty() ? "" : " (regions listed UNVERIFIED may not boot until then)");
    return kFailure;
  }

  const bool usj = flasher.chip().usb_serial_jtag;
  fmt::print("reset into the application ({})\n",
             usj ? "RTC watchdog system reset: re-samples GPIO0, leaves download mode" : "EN pulse on RTS");
  port.reset();
  if (usj && info && !info->serial_number.empty()) {
    const auto back =
        saul::host::wait_for_usb_port(info->serial_number, info->usb_vid, path, seconds(10), saul::host::sleep_real);
    if (back.empty())
      say("warning: the IO board (serial {}) did not come back on USB within 10 s: unplug "
          "and replug it; the flash itself is verified",
          info->serial_number);
    else
      fmt::print("the IO board is back on {}{}\n", back, back == path ? "" : " (a new name)");
  }
  std::size_t written = 0, unchanged = 0;
  std::uint64_t bytes = 0;
  for (const auto& r : flasher.outcomes()) {
    if (r.state == saul::host::RegionOutcome::State::written) {
      ++written;
      bytes += r.size;
    }
    if (r.state == saul::host::RegionOutcome::State::unchanged) ++unchanged;
  }
  const double secs = duration<double>(steady_clock::now() - t0).count();
  fmt::print("done: {} written, {} unchanged, {} in {:.1f} s ({:.1f} KiB/s overall, {} bytes sent at {} baud)\n",
             written, unchanged, kib(bytes), secs, secs > 0 ? static_cast<double>(bytes) / 1024.0 / secs : 0.0,
             flasher.bytes_sent(), usj ? 0U : opt.baud);
  return kOk;
}

}  // namespace

void add_flash_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<FlashOptions>(
      app, run, "flash", "Flash firmware to the BALANCE or IO board's ESP32-S3 (verified by MD5)", run_flash);
  cmd->add_option("inputs", o->inputs, "FILE (written at --offset), or OFFSET FILE pairs");
  cmd->add_option("--offset", o->offset, "where a single FILE goes")->capture_default_str();
  cmd->add_option("-B,--build-dir", o->build_dir, "an ESP-IDF build folder (its flasher_args.json)");
  cmd->add_option("-b,--board", o->board, "balance (CH343 bridge, DTR/RTS reset) | io (USB-Serial/JTAG)")
      ->check(CLI::IsMember({"balance", "io"}));
  cmd->add_option("-p,--port", o->port, "serial port (default: the one board found by USB identity)");
  cmd->add_option("--flash-size", o->flash_size, "4MB, 8MB, 16MB (default: from the build, else 4MB)");
  cmd->add_option("--baud", o->baud, "transfer baud rate over the bridge (sync is at 115200)")
      ->capture_default_str()
      ->check(CLI::Range(9600, 4000000));
  cmd->add_flag("--no-compress", o->no_compress, "send the image uncompressed (FLASH_DATA instead of FLASH_DEFL_DATA)");
  cmd->add_flag("--force", o->force,
                "write anyway: regions whose flash MD5 already matches, a non-image at 0x0, an ELF file");
  cmd->add_flag("--no-reset", o->no_reset, "the board is already in download mode (BOOT held, RESET tapped)");
  cmd->add_option("--reset", o->reset,
                  "only reset the board, write nothing: bootloader (into download mode) | app (into its "
                  "application)")
      ->check(CLI::IsMember({"bootloader", "app"}));
  cmd->add_option("--connect-attempts", o->connect_attempts, "resets into the bootloader before giving up")
      ->capture_default_str()
      ->check(CLI::Range(1, 20));
  add_link_option(cmd, o->link);
  cmd->add_flag("--skip-robot-check", o->skip_robot_check, "do not put the robot in mode off first (warns loudly)");
  cmd->add_option("--robot-timeout", o->robot_timeout, "wait for the mode-off acknowledgement and telemetry")
      ->capture_default_str()
      ->check(duration_check());
  cmd->footer(
      "\nBefore flashing, with a CAN link (--link or $SAUL_LINK), the robot is put in mode off and its 0x400\n"
      "telemetry must show OFF. Every region is verified by the chip's flash MD5; regions that already match are\n"
      "skipped. Afterwards the board is reset into the application (docs/flashing.md).\n"
      "\nExamples:\n"
      "  saulctl flash --board balance --build-dir firmware/balance/build --link can0\n"
      "  saulctl flash --board io build/saul_io.bin                 # at 0x10000\n"
      "  saulctl flash --board balance 0x0 bootloader.bin 0x8000 partition-table.bin 0x10000 app.bin\n"
      "  saulctl flash --board balance --reset bootloader          # only the DTR/RTS reset into download mode\n"
      "\n--reset app: BALANCE, the EN pulse on RTS; IO, a watchdog reset through the ROM loader when it answers,\n"
      "else the USB-Serial/JTAG reset (restarts a running application). The robot check applies as for a flash.\n"
      "\nExit codes: 0 flashed and verified, 1 failure (wrong chip, file, verify, port gone: regions UNVERIFIED),\n"
      "2 usage, 3 no answer (no bootloader, or no acknowledgement from the robot).\n");
}

}  // namespace saulctl
