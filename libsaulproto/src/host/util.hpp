// Private helpers shared by several host sources (not installed, not part of the API).
#pragma once

#include <fstream>
#include <string>
#include <string_view>

namespace saul::host::detail {

/// ASCII lower case, whatever the C locale says (capture formats are ASCII).
constexpr char ascii_lower(char c) noexcept { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; }
inline std::string ascii_lower(std::string s) {
  for (char& c : s) c = ascii_lower(c);
  return s;
}

/// Whether `s` starts with `prefix` (written in lower case) in any ASCII case.
constexpr bool starts_with_nocase(std::string_view s, std::string_view prefix) noexcept {
  if (s.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i)
    if (ascii_lower(s[i]) != prefix[i]) return false;
  return true;
}
/// Whether `s` ends with `suffix` (written in lower case) in any ASCII case.
constexpr bool ends_with_nocase(std::string_view s, std::string_view suffix) noexcept {
  return s.size() >= suffix.size() && starts_with_nocase(s.substr(s.size() - suffix.size()), suffix);
}

/// `s` with &, <, > and " written as entities: text and attribute values in HTML (plot, tune reports) and XML
/// (JUnit).
inline std::string markup_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

/// The first line of a text file (/proc, /sys, a lock file); "" when it cannot be read.
inline std::string first_line(const std::string& path) {
  std::ifstream f(path);
  std::string line;
  std::getline(f, line);
  return line;
}

/// One visitor out of several lambdas, for std::visit over message variants.
template <class... F>
struct Overload : F... {
  using F::operator()...;
};
template <class... F>
Overload(F...) -> Overload<F...>;

}  // namespace saul::host::detail
