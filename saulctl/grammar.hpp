// The words every saulctl verb spells the same way (docs/cli.md): the link, CAN ids and durations (--json is a
// plain add_flag). Each verb adds its options through these functions, so a spelling cannot drift;
// tests/cli/grammar.py checks every verb's --help against a table.
#pragma once

#include <CLI/CLI.hpp>

#include <chrono>
#include <string>
#include <vector>

#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/report/frame_text.hpp"

namespace saulctl {

/// Adds -l/--link to a verb. The default comes from $SAUL_LINK, else ~/.config/saulctl/link (one line); an
/// explicit link always wins over both. serial_too: the verb also takes serial byte links (serial:DEV@BAUD).
void add_link_option(CLI::App* cmd, std::string& link, bool serial_too = false);
/// --link, and the link as a positional LINK too (sniff, record: "sniff can0" = "sniff --link can0"). Both given
/// and different is a usage error; either ends in `link`. These verbs take serial byte links too.
void add_link_option_and_positional(CLI::App* cmd, std::string& link);

/// Adds --id (or `name`: replay --exclude-id): ids in hex (400 = 0x400; more than 3 digits or above 7FF: 29-bit),
/// ID:MASK, FIRST-LAST, comma separated or repeated; one value per --id, so "--id 400 can0" leaves can0 to the verb.
/// Checked while parsing (a bad id is a usage error).
CLI::Option* add_id_option(CLI::App* cmd, std::vector<std::string>& ids, const std::string& what,
                           const char* name = "--id");
/// The filters the --id values name (already checked: never throws for values add_id_option accepted).
std::vector<saul::host::CanFilter> id_filters(const std::vector<std::string>& ids);

/// Adds --duration (alias --for): 500ms, 10s, 1.5 (seconds), 2m. Checked while parsing.
CLI::Option* add_duration_option(CLI::App* cmd, std::string& duration, const std::string& what);
/// A check for any other option that takes a duration (--timeout, --wait, --window, ...).
CLI::Validator duration_check();
/// Parses "2s", "500ms", "1.5" (seconds), "2m", "1min", "100us" (rounded down to ms). Throws CLI::ValidationError.
std::chrono::milliseconds parse_duration(const std::string& text);

/// --time abs|rel|delta (decode, sniff) as the time column's mode.
saul::host::TimeMode time_mode(const std::string& time);

}  // namespace saulctl
