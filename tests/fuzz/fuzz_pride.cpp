// Pride ES StreamDecoder (and the echo filter in front of it): byte by byte and in chunks must agree.
#include "fuzz_util.hpp"
#include "saulproto/core/pride.hpp"

extern "C" int saul_fuzz_pride(const std::uint8_t* data, std::size_t size) {
  using namespace saul;
  std::span<const std::uint8_t> in(data, size);
  pride::StreamDecoder one, chunked;
  std::size_t a = 0, b = 0;
  for (std::uint8_t byte : in)
    if (one.push(byte)) ++a;
  fuzz::in_chunks(in, [&](auto piece) { chunked.push(piece, [&](const auto&) { ++b; }); });
  if (a != b || !(one.counters() == chunked.counters())) fuzz::fail();
  // Every 12-byte window through the one-frame decoder too.
  for (std::size_t i = 0; i + 12 <= size; i += 12) (void)pride::decode_frame(in.subspan(i, 12));
  return 0;
}
