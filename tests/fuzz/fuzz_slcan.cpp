// slcan LineDecoder: byte by byte and in chunks must give the same events; parse_frame on the whole input too.
#include <string_view>

#include "fuzz_util.hpp"
#include "saulproto/core/slcan.hpp"

extern "C" int saul_fuzz_slcan(const std::uint8_t* data, std::size_t size) {
  using namespace saul;
  std::span<const std::uint8_t> in(data, size);
  slcan::LineDecoder one, chunked;
  std::size_t a = 0, b = 0;
  for (std::uint8_t byte : in)
    if (one.push(static_cast<char>(byte))) ++a;
  fuzz::in_chunks(in, [&](auto piece) { chunked.push(piece, [&](const slcan::Event&) { ++b; }); });
  if (a != b) fuzz::fail();
  slcan::DeviceTime t;
  (void)slcan::parse_frame(std::string_view(reinterpret_cast<const char*>(data), size), &t);
  return 0;
}
