// Usage errors: suggestions for typos, "saulctl help VERB", and the verb's own --help named in every error.
#include "usage.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstddef>

#include "commands.hpp"

namespace saulctl {
namespace {

std::string g_say_prefix = "saulctl";  // say()'s "saulctl VERB"

// Optimal string alignment distance: Levenshtein plus the swap of two neighbouring letters ("jsno" -> "json").
std::size_t typo_distance(const std::string& a, const std::string& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[n][m];
}

std::string without_dashes(const std::string& s) { return s.substr(std::min(s.find_first_not_of('-'), s.size())); }

// Every name an app answers to as a verb (not the hidden ones: __complete).
std::vector<std::string> verb_names(const CLI::App& app) {
  std::vector<std::string> out;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App* s) { return !s->get_group().empty(); })) {
    out.push_back(sub->get_name());
    for (const auto& alias : sub->get_aliases()) out.push_back(alias);
  }
  return out;
}

// The chain of parsed verbs, the root first.
std::vector<const CLI::App*> parsed_chain(const CLI::App& app) {
  std::vector<const CLI::App*> chain{&app};
  for (;;) {
    const auto subs = chain.back()->get_subcommands();
    if (subs.empty()) break;
    chain.push_back(subs.back());
  }
  return chain;
}

// The candidate nearest to word: within a small edit distance (at most 1 for up to 4 letters, 2 up to 8, else 3),
// or the only candidate word is a prefix of. "" when none is near enough or two are equally near.
std::string nearest_word(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string bare = without_dashes(word);
  if (bare.empty()) return "";
  const std::size_t limit = bare.size() <= 4 ? 1 : bare.size() <= 8 ? 2 : 3;
  std::string best;
  std::size_t best_d = limit + 1;
  bool tie = false;
  for (const auto& c : candidates) {
    const std::size_t d = typo_distance(bare, without_dashes(c));
    if (d < best_d) {
      best = c;
      best_d = d;
      tie = false;
    } else if (d == best_d && c != best) {
      tie = true;
    }
  }
  if (!best.empty() && !tie) return best;
  // "--dur" for "--duration": an abbreviation of exactly one name.
  std::vector<std::string> prefixed;
  for (const auto& c : candidates)
    if (bare.size() >= 2 && without_dashes(c).rfind(bare, 0) == 0 && word.size() < c.size()) prefixed.push_back(c);
  std::sort(prefixed.begin(), prefixed.end());
  prefixed.erase(std::unique(prefixed.begin(), prefixed.end()), prefixed.end());
  return prefixed.size() == 1 ? prefixed[0] : "";
}

std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates, const char* quote) {
  const std::string near = nearest_word(word, candidates);
  return near.empty() ? std::string() : fmt::format("; did you mean {}{}{}?", quote, near, quote);
}

}  // namespace

std::vector<std::string> option_names(const CLI::App& app) {
  std::vector<std::string> out;
  for (const CLI::Option* opt : app.get_options()) {
    for (const auto& l : opt->get_lnames()) out.push_back("--" + l);
    for (const auto& s : opt->get_snames()) out.push_back("-" + s);
  }
  return out;
}

std::vector<std::string> expand_help_verb(const CLI::App& app, int argc, char** argv) {
  std::vector<std::string> args(argv, argv + argc);
  if (args.size() < 2 || args[1] != "help") return args;
  args.erase(args.begin() + 1);
  // Only verbs that exist get "--help": an unknown one is left for the parser to report with a suggestion.
  const CLI::App* level = &app;
  for (std::size_t i = 1; i < args.size(); ++i) {
    const auto subs = level->get_subcommands([&](const CLI::App* s) { return s->check_name(args[i]); });
    if (subs.empty()) return args;
    level = subs.front();
  }
  args.emplace_back("--help");
  return args;
}

void set_say_verb(std::string verb_path) { g_say_prefix = std::move(verb_path); }

void say_line(std::string_view message) { fmt::print(stderr, "{}: {}\n", g_say_prefix, message); }

std::string verb_path(const CLI::App& app) {
  std::string path;
  for (const CLI::App* a : parsed_chain(app)) path += (path.empty() ? "" : " ") + a->get_name();
  return path;
}

int report_usage_error(const CLI::App& app, const CLI::ParseError& e) {
  const auto chain = parsed_chain(app);
  const std::string path = verb_path(app);
  const std::string help = chain.size() > 1 ? fmt::format("see '{} --help'", path) : "'saulctl help' lists the verbs";
  // The first word nobody took, from the deepest verb that has one.
  const CLI::App* owner = nullptr;
  std::string extra;
  for (auto it = chain.rbegin(); it != chain.rend() && !owner; ++it) {
    const auto left = (*it)->remaining();
    if (!left.empty()) {
      owner = *it;
      extra = left.front();
    }
  }
  std::string message;
  if (owner && extra.size() > 1 && extra[0] == '-') {
    const std::string name = extra.substr(0, extra.find('='));
    message = fmt::format("unknown option {}{}", name, did_you_mean(name, option_names(*owner), ""));
  } else if (owner && !verb_names(*owner).empty()) {
    message = fmt::format("unknown verb '{}'{}", extra, did_you_mean(extra, verb_names(*owner), "'"));
  } else if (owner) {
    message = fmt::format("unexpected argument '{}'", extra);
  } else if (dynamic_cast<const CLI::RequiredError*>(&e) && chain.back()->get_require_subcommand_min() > 0 &&
             chain.back()->get_subcommands().empty()) {
    message = chain.size() == 1 ? std::string("no verb given")
                                : fmt::format("needs one of: {}", fmt::join(verb_names(*chain.back()), ", "));
  } else {
    message = e.what();
  }
  fmt::print(stderr, "{}: {} ({})\n", path, message, help);
  return kUsage;
}

}  // namespace saulctl
