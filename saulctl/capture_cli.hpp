// Options shared by the verbs that read capture files (decode, stats, plot): how to read logic-analyser exports
// that do not say everything (--protocol, --samplerate).
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

#include "saulproto/host/serial_capture.hpp"

namespace saulctl {

struct SerialCliOptions {
  std::string protocol;    ///< "", interboard, crsf, pride, raw
  std::string samplerate;  ///< "", "10M", "10MHz", "1000000"
};

/// Adds --protocol and --samplerate to a verb.
void add_serial_read_options(CLI::App* cmd, SerialCliOptions& options);
/// The reader options they give; throws CLI::ValidationError for a bad sample rate.
saul::host::SerialReadOptions serial_read_options(const SerialCliOptions& options);
/// The protocol for links whose capture names none, when --protocol was given.
std::optional<saul::host::SerialProtocol> fallback_protocol(const SerialCliOptions& options);
/// "10M", "10MHz", "200k", "1000000", "1e6" -> Hz. Throws CLI::ValidationError.
std::uint64_t parse_rate_hz(const std::string& text);

}  // namespace saulctl
