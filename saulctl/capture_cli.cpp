#include "capture_cli.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "commands.hpp"
#include "saulproto/core/quantity.hpp"
#include "saulproto/host/capture/recorder.hpp"

namespace saulctl {

void add_serial_read_options(CLI::App* cmd, SerialCliOptions& options) {
  cmd->add_option("--input-format", options.input_format,
                  "read the file as this format instead of the one its content says (a .gz/.zst file is still "
                  "decompressed first)")
      ->check(CLI::IsMember(saul::host::capture_format_names()));  // every capture format, CAN and serial
  cmd->add_option("--protocol", options.protocol,
                  "serial captures: protocol of links the file does not name (sigrok/PulseView exports): "
                  "interboard, crsf, pride or raw (default: guessed from the first 4 KiB)")
      ->check(CLI::IsMember({"interboard", "crsf", "pride", "raw"}));
  cmd->add_option("--samplerate", options.samplerate,
                  "logic-analyser exports with sample numbers: the capture's sample rate (10M, 1MHz, 1000000), "
                  "to turn samples into time");
}

void refuse_read_once(std::string_view verb, const std::string& file, std::string_view reads) {
  std::error_code error;
  const auto status = std::filesystem::status(saul::host::capture_open_name(file), error);  // "-": standard input
  if (error || !std::filesystem::exists(status) || std::filesystem::is_regular_file(status) ||
      std::filesystem::is_directory(status))
    return;
  throw CLI::ValidationError(fmt::format("{}: not a regular file (a pipe?), which can be read only once: {} reads the "
                                         "capture {}; save it to a file first (... > run.log)",
                                         file, verb, reads));
}

std::uint64_t parse_rate_hz(const std::string& text) {
  const auto hz = saul::quantity::parse(text, {"Hz", "hz"}, 1e3);
  if (!hz || *hz > 1'000'000'000'000ULL)
    throw CLI::ValidationError("--samplerate", "bad sample rate '" + text + "' (use e.g. 10M, 1MHz, 1000000)");
  return *hz;
}

void add_parallel_from_option(CLI::App* cmd, std::string& size) {
  size = kParallelFrom;
  cmd->add_option("--parallel-from", size,
                  "files of this size and more are worked on both cores (1: always; larger than the file: one core)")
      ->capture_default_str();
}

std::uint64_t parse_size_option(const std::string& option, const std::string& text) {
  try {
    return saul::host::parse_size(text);
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError(option, e.what());
  }
}

saul::host::SerialReadOptions serial_read_options(const SerialCliOptions& options) {
  saul::host::SerialReadOptions r;
  if (!options.protocol.empty()) r.protocol = saul::host::serial_protocol_from_name(options.protocol);
  if (!options.samplerate.empty()) r.samplerate_hz = parse_rate_hz(options.samplerate);
  if (!options.input_format.empty()) r.format = saul::host::capture_format_from_name(options.input_format);
  return r;
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

std::function<void(const saul::host::CaptureError&)> corrupt_reporter(const std::string& path, Progress* progress) {
  return [path, progress](const saul::host::CaptureError& e) {
    if (progress) progress->finish();
    say("{}", saul::host::format_capture_error(path, e));
  };
}

void read_serial_chunks(const std::string& path, saul::host::SerialCaptureReader& reader,
                        ::saulctl::Progress& progress, std::uint64_t& corrupt,
                        const std::function<void(const saul::host::SerialChunk&)>& on_chunk) {
  using Status = saul::host::SerialCaptureReader::Status;
  const auto report = corrupt_reporter(path, &progress);
  for (Status st; (st = reader.next()) != Status::end;) {
    progress.update_many(1, reader.bytes_read(), reader.bytes_total());
    if (st == Status::corrupt) {
      ++corrupt;
      report(reader.error());
      continue;
    }
    on_chunk(reader.chunk());
  }
}

}  // namespace saulctl
