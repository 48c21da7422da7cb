// CRSF StreamDecoder: byte by byte and in chunks must deliver the same frames; every frame goes through decode().
#include "fuzz_util.hpp"
#include "saulproto/core/crsf.hpp"

extern "C" int saul_fuzz_crsf(const std::uint8_t* data, std::size_t size) {
  using namespace saul;
  std::span<const std::uint8_t> in(data, size);
  crsf::StreamDecoder one, chunked;
  std::size_t a = 0, b = 0;
  for (std::uint8_t byte : in)
    one.push(byte, [&](const crsf::Frame& f) {
      ++a;
      (void)crsf::decode(f);
    });
  fuzz::in_chunks(in, [&](auto piece) { chunked.push(piece, [&](const crsf::Frame&) { ++b; }); });
  if (a != b) fuzz::fail();
  return 0;
}
