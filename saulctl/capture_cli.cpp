#include "capture_cli.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

namespace saulctl {

std::vector<std::string> input_format_names() {
  using saul::host::CaptureFormat;
  std::vector<std::string> names;
  for (auto f : {CaptureFormat::candump, CaptureFormat::pcap, CaptureFormat::pcapng, CaptureFormat::asc,
                 CaptureFormat::blf, CaptureFormat::trc, CaptureFormat::csv, CaptureFormat::gvret_csv, CaptureFormat::mcap,
                 CaptureFormat::serial, CaptureFormat::sigrok, CaptureFormat::sigrok_json, CaptureFormat::pulseview_csv})
    names.emplace_back(saul::host::to_string(f));
  return names;
}

void add_input_format_option(CLI::App* cmd, std::string& input_format) {
  cmd->add_option("--input-format", input_format,
                  "read the file as this format instead of the one its content says (a .gz/.zst file is still "
                  "decompressed first)")
      ->check(CLI::IsMember(input_format_names()));
}

std::optional<saul::host::CaptureFormat> input_format(const std::string& input_format) {
  if (input_format.empty()) return std::nullopt;
  return saul::host::capture_format_from_name(input_format);
}

void add_serial_read_options(CLI::App* cmd, SerialCliOptions& options) {
  add_input_format_option(cmd, options.input_format);
  cmd->add_option("--protocol", options.protocol,
                  "serial captures: protocol of links the file does not name (sigrok/PulseView exports): "
                  "interboard, crsf, pride or raw (default: guessed from the first 4 KiB)")
      ->check(CLI::IsMember({"interboard", "crsf", "pride", "raw"}));
  cmd->add_option("--samplerate", options.samplerate,
                  "logic-analyser exports with sample numbers: the capture's sample rate (10M, 1MHz, 1000000), "
                  "to turn samples into time");
}

bool refuse_read_once(std::string_view verb, const std::string& file, std::string_view reads) {
  std::error_code error;
  const auto status = std::filesystem::status(saul::host::capture_open_name(file), error);  // "-": standard input
  if (error || !std::filesystem::exists(status) || std::filesystem::is_regular_file(status) ||
      std::filesystem::is_directory(status))
    return false;
  fmt::print(stderr,
             "saulctl {}: {}: not a regular file (a pipe?), which can be read only once: {} reads the capture {}; "
             "save it to a file first (... > run.log)\n",
             verb, file, verb, reads);
  return true;
}

std::uint64_t parse_rate_hz(const std::string& text) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (...) {
    used = 0;
  }
  std::string unit = text.substr(used);
  if (unit.size() >= 2 && (unit.substr(unit.size() - 2) == "Hz" || unit.substr(unit.size() - 2) == "hz"))
    unit.resize(unit.size() - 2);
  double scale = 0;
  if (unit.empty()) scale = 1;
  if (unit == "k" || unit == "K") scale = 1e3;
  if (unit == "M") scale = 1e6;
  if (unit == "G") scale = 1e9;
  if (used == 0 || scale == 0 || !(v > 0) || v * scale > 1e12)
    throw CLI::ValidationError("--samplerate", "bad sample rate '" + text + "' (use e.g. 10M, 1MHz, 1000000)");
  return static_cast<std::uint64_t>(std::llround(v * scale));
}

saul::host::SerialReadOptions serial_read_options(const SerialCliOptions& options) {
  saul::host::SerialReadOptions r;
  r.protocol = fallback_protocol(options);
  if (!options.samplerate.empty()) r.samplerate_hz = parse_rate_hz(options.samplerate);
  r.format = input_format(options.input_format);
  return r;
}

std::optional<saul::host::SerialProtocol> fallback_protocol(const SerialCliOptions& options) {
  if (options.protocol.empty()) return std::nullopt;
  return saul::host::serial_protocol_from_name(options.protocol);
}

Progress::Progress(std::string verb, bool stdout_carries_records)
    : verb_(std::move(verb)), start_(std::chrono::steady_clock::now()), last_(start_) {
  const char* env = std::getenv("SAUL_PROGRESS");
  const std::string setting = env ? env : "";
  forced_ = setting == "1";
  enabled_ = forced_ || (setting != "0" && isatty(STDERR_FILENO) && !(stdout_carries_records && isatty(STDOUT_FILENO)));
}

void Progress::draw(std::uint64_t bytes_read, std::optional<std::uint64_t> bytes_total) {
  using namespace std::chrono;
  const auto now = steady_clock::now();
  if (!forced_ && (now - start_ < milliseconds(500) || now - last_ < milliseconds(250))) return;
  last_ = now;
  const double seconds = duration<double>(now - start_).count();
  std::string where;
  if (bytes_total && *bytes_total > 0) {
    const double share = std::min(1.0, static_cast<double>(bytes_read) / static_cast<double>(*bytes_total));
    where = fmt::format("{:.0f}% of {:.1f} MB, ", 100.0 * share, static_cast<double>(*bytes_total) / 1e6);
  } else {
    where = fmt::format("{:.1f} MB, ", static_cast<double>(bytes_read) / 1e6);
  }
  // \r and erase-to-end-of-line: the line is redrawn in place and never scrolls.
  fmt::print(stderr, "\r{}: {}{} records, {:.1f} s\x1b[K", verb_, where, records_, seconds);
  std::fflush(stderr);
  drawn_ = true;
}

void Progress::finish() {
  if (!drawn_) return;
  fmt::print(stderr, "\r\x1b[K");
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace saulctl
