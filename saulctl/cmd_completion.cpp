// saulctl completion bash|zsh: shell completion answered by saulctl itself, so it never falls behind the verbs.
// The scripts are small front ends: on every TAB they run the hidden verb 'saulctl __complete WORD...' (the words
// of the line up to the cursor, the program first), which walks the CLI11 app for the verbs, options and their
// values (choices, links, serial ports, capture files by extension, files, folders).
#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <string>
#include <vector>

#include "commands.hpp"
#include "usage.hpp"

namespace saulctl {
namespace {

// What the value of an option or positional is. Empty: a flag (no value).
//   values:a,b,c  one of these       link      a CAN or serial link     canlink  a CAN link
//   port          a serial port      capture   a capture file           file     any file
//   dir           a folder           -         a value with nothing to offer (a number, a duration)
std::string value_kind(const CLI::Option& opt) {
  if (opt.get_items_expected_max() == 0) return "";
  const std::string type = opt.get_type_name();
  if (const auto open = type.find('{'), close = type.find('}'); open != std::string::npos && close > open)
    return "values:" + type.substr(open + 1, close - open - 1);
  std::string pname = opt.get_positional() ? opt.get_name(true) : "";
  for (auto& c : pname) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));  // "LINK", "IN"
  auto named = [&](std::initializer_list<const char*> names) {
    return std::any_of(names.begin(), names.end(), [&](const char* n) { return pname == n || opt.check_lname(n); });
  };
  const std::string& what = opt.get_description();
  if (named({"link", "to"})) return what.find("serial:") != std::string::npos ? "link" : "canlink";
  if (named({"port", "console-balance", "console-io", "sim-control"})) return "port";
  if (named({"build-dir"})) return "dir";
  if (opt.get_positional() && (what.find("capture") != std::string::npos || named({"files", "file", "in", "input"})))
    return "capture";
  if (named({"output", "out", "junit", "paths-file", "dbc"}) || type.find("FILE") != std::string::npos ||
      (opt.get_positional() && (what.find("FILE") != std::string::npos || what.find("file") != std::string::npos)))
    return "file";
  return "-";
}

// The verbs of a level as NAME:DESCRIPTION (the description's first line, ':' made ';' for zsh's _describe), 'help'
// at the root; not the hidden ones (__complete).
std::vector<std::string> verbs(const CLI::App& app) {
  std::vector<std::string> out;
  auto add = [&](const std::string& name, std::string what) {
    what = what.substr(0, what.find('\n'));
    std::replace(what.begin(), what.end(), ':', ';');
    out.push_back(name + ":" + what);
  };
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App* s) { return !s->get_group().empty(); }))
    add(sub->get_name(), sub->get_description());
  if (app.get_parent() == nullptr) add("help", "a verb's options and examples: saulctl help VERB");
  return out;
}

// The kind of the Nth (1-based) positional argument of a level; one taking any number takes all that follow.
std::string positional_kind(const CLI::App& app, int n) {
  int first = 1;
  for (const CLI::Option* opt : app.get_options()) {
    if (opt->nonpositional() || !opt->get_positional()) continue;
    const int count = opt->get_items_expected_max();
    if (count > 1000 ? n >= first : n >= first && n < first + count) return value_kind(*opt);
    if (count <= 1000) first += count;
  }
  return "";
}

// The answer to 'saulctl __complete WORD...' (words[0] the program, the last the word being completed), on stdout:
// a first line with the kind of the file or link the shell lists (value_kind(): link, canlink, port, capture, file,
// dir; "=" before it when it is the value after the '=' of the word: --out=r), then one line per candidate, a verb
// as NAME:DESCRIPTION. The shell picks the candidates that start with the word.
int complete(const CLI::App& root, const std::vector<std::string>& words) {
  if (words.size() < 2) return kOk;
  const CLI::App* level = &root;
  const CLI::Option* want = nullptr;  // the option whose value the next word is
  int n = 0;                          // positionals at this level before the current word
  for (std::size_t i = 1; i + 1 < words.size(); ++i) {
    const std::string& w = words[i];
    if (want != nullptr) {
      want = nullptr;
    } else if (w.starts_with("-")) {
      want = level->get_option_no_throw(w);  // none for --format=csv
      if (want != nullptr && value_kind(*want).empty()) want = nullptr;
    } else if (const auto sub = level->get_subcommands([&](const CLI::App* s) {
                 return !s->get_group().empty() && s->get_name() == w;
               });
               !sub.empty()) {
      level = sub[0];
      n = 0;
    } else if (level != &root || w != "help") {
      ++n;
    }
  }
  const std::string& cur = words.back();
  const bool after_eq = want == nullptr && cur.starts_with("--") && cur.find('=') != cur.npos;  // --format=j
  std::string kind;
  std::vector<std::string> candidates;
  if (want != nullptr) {
    kind = value_kind(*want);
  } else if (after_eq) {
    const CLI::Option* opt = level->get_option_no_throw(cur.substr(0, cur.find('=')));
    kind = opt != nullptr ? value_kind(*opt) : "";
  } else if (cur.starts_with("-")) {
    candidates = option_names(*level);
  } else {
    if (n == 0) candidates = verbs(*level);
    kind = positional_kind(*level, n + 1);
    if (candidates.empty() && kind.empty()) candidates = option_names(*level);
  }
  if (kind.starts_with("values:")) {
    const auto values = CLI::detail::split(kind.substr(7), ',');
    candidates.insert(candidates.end(), values.begin(), values.end());
    kind.clear();
  }
  if (kind == "-") kind.clear();
  fmt::print("{}{}\n", after_eq ? "=" : "", kind);
  for (const auto& c : candidates) fmt::print("{}\n", c);
  return kOk;
}

// The links and ports to offer, the same in both shells. Capture files go by extension, also compressed (.gz,
// .zst): candump, pcap, pcapng, ASC, BLF, TRC, CSV, serial captures, sigrok/PulseView exports.
const char* kShared = R"SH(_saulctl_capture_ext='log|candump|pcap|cap|pcapng|ntar|asc|blf|trc|csv|serial|txt|json'
# _saulctl_links SAULCTL KIND: for KIND port the serial ports 'saulctl ports --json' lists; for a link the SocketCAN
# interfaces (/sys/class/net/*/type 280, ARPHRD_CAN), then slcan: (and for KIND link also serial:) with each port
_saulctl_links() {
  [ -n "${ZSH_VERSION-}" ] && setopt localoptions nullglob
  local d p
  if [ "$2" != port ]; then
    for d in "${SAUL_SYSFS:-/sys}"/class/net/*; do
      [ -r "$d/type" ] && [ "$(<"$d/type")" = 280 ] && echo "${d##*/}"
    done
  fi
  "$1" ports --json 2>/dev/null | sed -n 's/^ *"path": *"\([^"]*\)".*/\1/p' | while IFS= read -r p; do
    case $2 in
      port) echo "$p" ;;
      link) echo "slcan:$p"; echo "serial:$p" ;;
      *) echo "slcan:$p" ;;
    esac
  done
}
)SH";

const char* kBash = R"SH(# bash completion for saulctl, generated by 'saulctl completion bash'.
# Load it now:     source <(saulctl completion bash)
# or install it:   saulctl completion bash > ~/.local/share/bash-completion/completions/saulctl
%SHARED%_saulctl() {
  # The words as typed: from the line itself when bash gives it (so 'slcan:/dev/x' and '--format=csv' stay whole),
  # else from COMP_WORDS.
  local -a w
  if [[ -n ${COMP_LINE-} ]]; then
    local line=${COMP_LINE:0:${COMP_POINT:-${#COMP_LINE}}}
    read -ra w <<<"$line"
    [[ -z $line || $line == *[[:space:]] ]] && w+=("")
  else
    w=("${COMP_WORDS[@]:0:COMP_CWORD+1}")
  fi
  local cur=${w[-1]} cmd=${w[0]} kind f
  local -a cands reply=()
  { read -r kind; mapfile -t cands; } < <("$cmd" __complete "${w[@]}" 2>/dev/null)
  if [[ $kind == "="* ]]; then kind=${kind#=} cur=${cur#*=}; fi
  local list=${cands[*]%%:*}
  case $kind in
    link | canlink | port) list+=" $(_saulctl_links "$cmd" "$kind")" ;;
    capture)
      compopt -o filenames 2>/dev/null
      while IFS= read -r f; do
        [[ -d $f || $f =~ \.($_saulctl_capture_ext)(\.gz|\.zst)?$ ]] && reply+=("$f")
      done < <(compgen -f -- "$cur")
      ;;
    file) compopt -o filenames 2>/dev/null; while IFS= read -r f; do reply+=("$f"); done < <(compgen -f -- "$cur") ;;
    dir) compopt -o filenames 2>/dev/null; while IFS= read -r f; do reply+=("$f"); done < <(compgen -d -- "$cur") ;;
  esac
  while IFS= read -r f; do [[ -n $f ]] && reply+=("$f"); done < <(compgen -W "$list" -- "$cur")
  # bash replaces only what follows the last '=' or ':' of the word (COMP_WORDBREAKS): drop that much.
  local keep=${cur%"${cur##*[=:]}"}
  COMPREPLY=("${reply[@]#"$keep"}")
}
complete -F _saulctl saulctl
)SH";

const char* kZsh = R"SH(#compdef saulctl
# zsh completion for saulctl, generated by 'saulctl completion zsh'.
# Load it now:     source <(saulctl completion zsh)      (after compinit)
# or install it:   saulctl completion zsh > "${fpath[1]}/_saulctl"
%SHARED%_saulctl() {
  local cmd=${words[1]} kind
  local -a out verbs
  out=("${(@f)$("$cmd" __complete "${(@)words[1,CURRENT]}" 2>/dev/null)}")
  kind=${out[1]-}
  out=("${(@)out[2,-1]}")
  if [[ $kind == "="* ]]; then
    kind=${kind#=}
    compset -P '*='
  fi
  verbs=(${(M)out:#*:*})
  out=(${out:#*:*})
  (( $#verbs )) && _describe -t verbs 'saulctl verb' verbs
  (( $#out )) && compadd -- $out
  case $kind in
    link | canlink | port) compadd -- ${(f)"$(_saulctl_links "$cmd" "$kind")"} ;;
    capture) _files -g "*.($_saulctl_capture_ext)(|.gz|.zst)" ;;
    file) _files ;;
    dir) _files -/ ;;
  esac
}
if [[ ${funcstack[1]-} == _saulctl ]]; then
  _saulctl "$@"
else
  compdef _saulctl saulctl
fi
)SH";

}  // namespace

void add_completion_command(CLI::App& app, Runner& run) {
  auto [cmd, shell] = add_verb<std::string>(
      app, run, "completion", "Print a shell completion script (bash or zsh)",
      [](const std::string& shell_name) {
        std::string script = shell_name == "zsh" ? kZsh : kBash;
        script.replace(script.find("%SHARED%"), 8, kShared);
        fmt::print("{}", script);
        return kOk;
      },
      false);
  cmd->add_option("shell", *shell, "bash | zsh")->required()->check(CLI::IsMember({"bash", "zsh"}));
  cmd->footer("\nVerbs, options and their values: modes, formats, boards, links (SocketCAN interfaces and the serial\n"
              "ports 'saulctl ports' finds), capture files by extension.\n"
              "\nExamples:\n  source <(saulctl completion bash)\n"
              "  saulctl completion bash > ~/.local/share/bash-completion/completions/saulctl\n"
              "  source <(saulctl completion zsh)          # in ~/.zshrc, after compinit\n");

  // What the scripts run on every TAB: hidden from the help (no group), and every word after the program's name
  // taken as it is (prefix_command), options included.
  CLI::App* answer = app.add_subcommand("__complete")->group("")->prefix_command();
  const CLI::App* root = &app;
  answer->callback([answer, root, &run] { run = [answer, root] { return complete(*root, answer->remaining()); }; });
}

}  // namespace saulctl
