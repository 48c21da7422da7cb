// Inter-board UART StreamDecoder: byte by byte and in chunks must agree (counters and frame count).
#include "fuzz_util.hpp"
#include "saulproto/core/interboard.hpp"

extern "C" int saul_fuzz_interboard(const std::uint8_t* data, std::size_t size) {
  using namespace saul;
  std::span<const std::uint8_t> in(data, size);
  interboard::StreamDecoder one, chunked;
  std::size_t a = 0, b = 0;
  for (std::uint8_t byte : in)
    if (one.push(byte)) ++a;
  fuzz::in_chunks(in, [&](auto piece) { chunked.push(piece, [&](const auto&) { ++b; }); });
  if (a != b || !(one.counters() == chunked.counters())) fuzz::fail();
  return 0;
}
