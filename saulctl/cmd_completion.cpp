// saulctl completion bash|zsh: shell completion generated from the CLI11 app itself, so it never falls behind the
// verbs: verbs, options and their values (choices, links, serial ports, capture files by extension, files, folders).
// Both scripts share the generated tables (POSIX case statements); only the front end reading the line differs.
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <string>
#include <vector>

#include "commands.hpp"

namespace saulctl {
namespace {

// What the value of an option or positional is. Empty: a flag (no value).
//   values:a b c  one of these       link      a CAN or serial link     canlink  a CAN link
//   port          a serial port      capture   a capture file           file     any file
//   dir           a folder           -         a value with nothing to offer (a number, a duration)
std::string value_kind(const CLI::Option& opt) {
  if (opt.get_items_expected_max() == 0) return "";
  const std::string type = opt.get_type_name();
  if (const auto open = type.find('{'), close = type.find('}'); open != std::string::npos && close > open) {
    std::string values = type.substr(open + 1, close - open - 1);
    std::replace(values.begin(), values.end(), ',', ' ');
    return "values:" + values;
  }
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

struct Positional {
  int first = 1, last = 1;  ///< 1-based positions it takes (last < 0: all that follow)
  std::string kind;
};

struct Level {
  std::string path;                                         ///< "saulctl", "saulctl/pride", "saulctl/pride/vcu"
  std::vector<std::pair<std::string, std::string>> verbs;  ///< name, description
  std::vector<std::string> options;                        ///< "--json", "-o"
  std::vector<std::pair<std::string, std::string>> values;  ///< option name, value kind (options with a value)
  std::vector<Positional> positionals;
};

void walk(const CLI::App& app, const std::string& path, std::vector<Level>& levels) {
  Level level{path, {}, {}, {}, {}};
  const auto subs = app.get_subcommands([](const CLI::App*) { return true; });
  for (const CLI::App* sub : subs) level.verbs.emplace_back(sub->get_name(), sub->get_description());
  if (path == "saulctl") level.verbs.emplace_back("help", "a verb's options and examples: saulctl help VERB");
  int next = 1;
  for (const CLI::Option* opt : app.get_options()) {
    const std::string kind = value_kind(*opt);
    if (opt->nonpositional()) {
      std::vector<std::string> names;
      for (const auto& l : opt->get_lnames()) names.push_back("--" + l);
      for (const auto& s : opt->get_snames()) names.push_back("-" + s);
      for (const auto& n : names) {
        level.options.push_back(n);
        if (!kind.empty()) level.values.emplace_back(n, kind);
      }
    } else if (opt->get_positional()) {
      const int count = opt->get_items_expected_max();
      Positional p{next, count > 1000 ? -1 : next + count - 1, kind};
      if (count > 0) level.positionals.push_back(p);
      next += count > 1000 ? 0 : count;
    }
  }
  levels.push_back(level);
  for (const CLI::App* sub : subs) walk(*sub, path + "/" + sub->get_name(), levels);
}

std::string quoted(std::string s) {  // for a single-quoted shell word
  std::string out;
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out;
}

// The tables and the value sources, the same text for bash and zsh.
std::string shared_functions(const std::vector<Level>& levels) {
  std::string s;
  s += "# _saulctl_sub PATH WORD: the level WORD leads to when it is a verb at PATH\n";
  s += "_saulctl_sub() {\n  case \"$1/$2\" in\n";
  for (std::size_t i = 1; i < levels.size(); ++i) s += fmt::format("    {}) echo \"$1/$2\" ;;\n", levels[i].path);
  s += "  esac\n}\n";
  s += "# _saulctl_verbs PATH: the verbs there, as NAME:DESCRIPTION lines\n";
  s += "_saulctl_verbs() {\n  case \"$1\" in\n";
  for (const auto& l : levels) {
    if (l.verbs.empty()) continue;
    std::string lines;
    for (const auto& [name, what] : l.verbs) {
      std::string one = what.substr(0, what.find('\n'));
      std::replace(one.begin(), one.end(), ':', ';');
      lines += (lines.empty() ? "" : "\n") + name + ":" + one;
    }
    s += fmt::format("    {}) printf '%s\\n' '{}' ;;\n", l.path, quoted(lines));
  }
  s += "  esac\n}\n";
  s += "# _saulctl_options PATH: the option names there\n";
  s += "_saulctl_options() {\n  case \"$1\" in\n";
  for (const auto& l : levels) s += fmt::format("    {}) echo '{}' ;;\n", l.path, fmt::join(l.options, " "));
  s += "  esac\n}\n";
  s += "# _saulctl_value PATH OPTION: the kind of the option's value (values:..., link, canlink, port, capture, file,\n";
  s += "# dir, or - for a value with nothing to offer); nothing for a flag\n";
  s += "_saulctl_value() {\n  case \"$1 $2\" in\n";
  for (const auto& l : levels)
    for (const auto& [name, kind] : l.values) s += fmt::format("    '{} {}') echo '{}' ;;\n", l.path, name, quoted(kind));
  s += "  esac\n}\n";
  s += "# _saulctl_positional PATH N: the kind of the Nth positional argument there\n";
  s += "_saulctl_positional() {\n  case \"$1\" in\n";
  for (const auto& l : levels) {
    if (l.positionals.empty()) continue;
    s += fmt::format("    {})\n", l.path);
    for (const auto& p : l.positionals) {
      const std::string test =
          p.last < 0 ? fmt::format("$2 >= {}", p.first) : fmt::format("$2 >= {} && $2 <= {}", p.first, p.last);
      s += fmt::format("      if (( {} )); then echo '{}'; return; fi\n", test, quoted(p.kind));
    }
    s += "      ;;\n";
  }
  s += "  esac\n}\n";
  s += R"SH(# _saulctl_links SAULCTL KIND: SocketCAN interfaces (/sys/class/net/*/type 280, ARPHRD_CAN), then slcan: (and for
# KIND link also serial:) with each serial port 'saulctl ports' finds
_saulctl_links() {
  [ -n "${ZSH_VERSION-}" ] && setopt localoptions nullglob
  local d t p
  for d in "${SAUL_SYSFS:-/sys}"/class/net/*; do
    [ -r "$d/type" ] || continue
    t=$(<"$d/type")
    [ "$t" = 280 ] && echo "${d##*/}"
  done
  _saulctl_ports "$1" | while IFS= read -r p; do
    echo "slcan:$p"
    if [ "$2" = link ]; then echo "serial:$p"; fi
  done
}
# _saulctl_ports SAULCTL: serial ports as 'saulctl ports --json' lists them
_saulctl_ports() {
  "$1" ports --json 2>/dev/null | sed -n 's/^ *"path": *"\([^"]*\)".*/\1/p'
}
# Capture files by extension, also compressed (.gz, .zst): candump, pcap, pcapng, ASC, BLF, TRC, CSV, serial
# captures, sigrok/PulseView exports.
_saulctl_capture_re='\.(log|candump|pcap|cap|pcapng|ntar|asc|blf|trc|csv|serial|txt|json)(\.gz|\.zst)?$'
)SH";
  return s;
}

// The walk over the words typed so far, the same in both shells: sets lvl (the verb level; not "path", which zsh
// ties to PATH), n (positionals before the current word), want and opt (the current word is the value of option
// opt). Needs the array w, its first word after the program, and last, the index of the word being completed.
const char* kWalk = R"SH(  local lvl=saulctl want="" opt="" n=0 i next
  for ((i = first; i < last; i++)); do
    if [[ -n $want ]]; then want=""; continue; fi
    case ${w[i]} in
      --*=*) continue ;;
      -*) opt=${w[i]}; [[ -n $(_saulctl_value "$lvl" "$opt") ]] && want=1; continue ;;
    esac
    next=$(_saulctl_sub "$lvl" "${w[i]}")
    if [[ -n $next ]]; then lvl=$next; n=0; continue; fi
    [[ $lvl == saulctl && ${w[i]} == help ]] && continue
    n=$((n + 1))
  done
)SH";

std::string bash_script(const std::vector<Level>& levels) {
  std::string s;
  s += "# bash completion for saulctl, generated by 'saulctl completion bash'.\n";
  s += "# Load it now:     source <(saulctl completion bash)\n";
  s += "# or install it:   saulctl completion bash > ~/.local/share/bash-completion/completions/saulctl\n";
  s += shared_functions(levels);
  s += R"SH(_saulctl() {
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
  local last=$((${#w[@]} - 1)) first=1
  local cur=${w[last]} cmd=${w[0]}
)SH";
  s += kWalk;
  s += R"SH(  local kind="" prefix="" cands=""
  if [[ -n $want ]]; then
    kind=$(_saulctl_value "$lvl" "$opt")
  elif [[ $cur == --*=* ]]; then
    prefix=${cur%%=*}=
    kind=$(_saulctl_value "$lvl" "${cur%%=*}")
    cur=${cur#*=}
  elif [[ $cur == -* ]]; then
    cands=$(_saulctl_options "$lvl")
  else
    ((n == 0)) && cands=$(_saulctl_verbs "$lvl" | cut -d: -f1)
    kind=$(_saulctl_positional "$lvl" $((n + 1)))
    [[ -z $cands && -z $kind ]] && cands=$(_saulctl_options "$lvl")
  fi
  local -a reply=()
  local f
  case $kind in
    values:*) cands+=" ${kind#values:}" ;;
    link | canlink) cands+=" $(_saulctl_links "$cmd" "$kind")" ;;
    port) cands+=" $(_saulctl_ports "$cmd")" ;;
    capture)
      compopt -o filenames 2>/dev/null
      while IFS= read -r f; do
        [[ -d $f || $f =~ $_saulctl_capture_re ]] && reply+=("$f")
      done < <(compgen -f -- "$cur")
      ;;
    file) compopt -o filenames 2>/dev/null; while IFS= read -r f; do reply+=("$f"); done < <(compgen -f -- "$cur") ;;
    dir) compopt -o filenames 2>/dev/null; while IFS= read -r f; do reply+=("$f"); done < <(compgen -d -- "$cur") ;;
  esac
  while IFS= read -r f; do [[ -n $f ]] && reply+=("$f"); done < <(compgen -W "$cands" -- "$cur")
  # bash replaces only what follows the last '=' or ':' of the word (COMP_WORDBREAKS): drop that much.
  local typed=$prefix$cur
  local keep=${typed%"${typed##*[=:]}"}
  COMPREPLY=()
  for f in "${reply[@]}"; do
    f=$prefix$f
    COMPREPLY+=("${f#"$keep"}")
  done
}
complete -F _saulctl saulctl
)SH";
  return s;
}

std::string zsh_script(const std::vector<Level>& levels) {
  std::string s;
  s += "#compdef saulctl\n";
  s += "# zsh completion for saulctl, generated by 'saulctl completion zsh'.\n";
  s += "# Load it now:     source <(saulctl completion zsh)      (after compinit)\n";
  s += "# or install it:   saulctl completion zsh > \"${fpath[1]}/_saulctl\"\n";
  s += shared_functions(levels);
  s += R"SH(_saulctl() {
  local -a w
  w=("${(@)words[1,CURRENT]}")
  local first=2 last=$CURRENT cur=$words[CURRENT] cmd=${words[1]}
)SH";
  s += kWalk;
  s += R"SH(  local kind=""
  if [[ -n $want ]]; then
    kind=$(_saulctl_value "$lvl" "$opt")
  elif [[ $cur == --*=* ]]; then
    kind=$(_saulctl_value "$lvl" "${cur%%=*}")
    compset -P '*='
  elif [[ $cur == -* ]]; then
    compadd -- ${=$(_saulctl_options "$lvl")}
    return
  else
    local -a verbs
    ((n == 0)) && verbs=("${(@f)$(_saulctl_verbs "$lvl")}")
    [[ -n ${verbs[1]-} ]] && _describe -t verbs 'saulctl verb' verbs
    kind=$(_saulctl_positional "$lvl" $((n + 1)))
    [[ -z ${verbs[1]-} && -z $kind ]] && compadd -- ${=$(_saulctl_options "$lvl")}
  fi
  case $kind in
    values:*) compadd -- ${=kind#values:} ;;
    link | canlink) compadd -- ${(f)"$(_saulctl_links "$cmd" "$kind")"} ;;
    port) compadd -- ${(f)"$(_saulctl_ports "$cmd")"} ;;
    capture) _files -g '*.(log|candump|pcap|cap|pcapng|ntar|asc|blf|trc|csv|serial|txt|json)(|.gz|.zst)' ;;
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
  return s;
}

}  // namespace

void add_completion_command(CLI::App& app, Runner& run) {
  const CLI::App* root = &app;
  auto [cmd, shell] = add_verb<std::string>(
      app, run, "completion", "Print a shell completion script (bash or zsh)",
      [root](const std::string& shell_name) {
        std::vector<Level> levels;
        walk(*root, "saulctl", levels);
        fmt::print("{}", shell_name == "zsh" ? zsh_script(levels) : bash_script(levels));
        return kOk;
      },
      false);
  cmd->add_option("shell", *shell, "bash | zsh")->required()->check(CLI::IsMember({"bash", "zsh"}));
  cmd->footer("\nVerbs, options and their values: modes, formats, boards, links (SocketCAN interfaces and the serial\n"
              "ports 'saulctl ports' finds), capture files by extension.\n"
              "\nExamples:\n  source <(saulctl completion bash)\n"
              "  saulctl completion bash > ~/.local/share/bash-completion/completions/saulctl\n"
              "  source <(saulctl completion zsh)          # in ~/.zshrc, after compinit\n");
}

}  // namespace saulctl
