// Console grammar: every line of the input through parse() and the reply parsers.
#include <string_view>

#include "fuzz_util.hpp"
#include "saulproto/core/console.hpp"

extern "C" int saul_fuzz_console(const std::uint8_t* data, std::size_t size) {
  using namespace saul;
  std::string_view all(reinterpret_cast<const char*>(data), size);
  (void)console::parse(all);
  while (!all.empty()) {
    std::size_t nl = all.find('\n');
    std::string_view line = all.substr(0, nl);
    (void)console::parse(line);
    (void)console::parse_float(line);
    (void)console::parse_status(line);
    (void)console::parse_can_stats(line);
    (void)console::parse_uart_stats(line);
    if (nl == std::string_view::npos) break;
    all.remove_prefix(nl + 1);
  }
  return 0;
}
