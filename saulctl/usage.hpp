// Usage errors the way a new user meets them: "saulctl help [VERB]", the nearest verb or option to a typo, and every
// error inside a verb pointing to that verb's own --help. main() hooks CLI11's parse errors here.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace saulctl {

/// argv with "help [VERB...]" turned into "[VERB...] --help" when those verbs exist (else without --help, for the
/// parser to report); argv unchanged when its first word is not "help".
std::vector<std::string> expand_help_verb(const CLI::App& app, int argc, char** argv);

/// Every option name an app takes: "--json", "-o".
std::vector<std::string> option_names(const CLI::App& app);

/// "saulctl", "saulctl decode", "saulctl pride vcu": the verbs parsed so far.
std::string verb_path(const CLI::App& app);

/// One line on stderr for a parse error: the verb it is about, a suggestion for an unknown verb or option, and
/// where the verb's help is. Returns the usage exit code (2).
int report_usage_error(const CLI::App& app, const CLI::ParseError& e);

}  // namespace saulctl
