// esp_loader SlipDecoder: byte by byte and in chunks (fresh storage each) must deliver the same packets.
#include <array>
#include <vector>

#include "fuzz_util.hpp"
#include "saulproto/core/esp_loader.hpp"

extern "C" int saul_fuzz_esp_slip(const std::uint8_t* data, std::size_t size) {
  using namespace saul;
  std::span<const std::uint8_t> in(data, size);
  static std::array<std::uint8_t, 64> small_a, small_b;  // small storage: exercises the overlong path
  esp::SlipDecoder one(small_a), chunked(small_b);
  std::vector<std::vector<std::uint8_t>> a, b;
  for (std::uint8_t byte : in)
    if (auto p = one.push(byte)) a.emplace_back(p->begin(), p->end());
  fuzz::in_chunks(in, [&](auto piece) {
    for (std::uint8_t byte : piece)
      if (auto p = chunked.push(byte)) b.emplace_back(p->begin(), p->end());
  });
  if (a != b) fuzz::fail();
  for (const auto& p : a)
    if (p.size() > small_a.size()) fuzz::fail();
  return 0;
}
