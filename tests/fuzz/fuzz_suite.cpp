// Bench-test suite parser (parse_suite over a std::istringstream): ParseError is the only thing it may throw.
#include <sstream>
#include <string>

#include "fuzz_util.hpp"
#include "saulproto/core/quantity.hpp"
#include "saulproto/host/suite/suite.hpp"

extern "C" int saul_fuzz_suite(const std::uint8_t* data, std::size_t size) {
  using namespace saul::host::suite;
  std::string text(reinterpret_cast<const char*>(data), size);
  std::istringstream in(text);
  try {
    (void)parse_suite(in, "fuzz.saul");
  } catch (const ParseError&) {
  }
  (void)saul::quantity::parse_duration_us(text.substr(0, 32));
  return 0;
}
