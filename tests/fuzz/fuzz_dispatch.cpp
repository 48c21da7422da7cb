// decode_bus_frame on every frame the input describes: 4 bytes id, 1 flags/dlc byte, 8 data bytes per frame.
#include <cstring>

#include "fuzz_util.hpp"
#include "saulproto/core/dispatch.hpp"

extern "C" int saul_fuzz_dispatch(const std::uint8_t* data, std::size_t size) {
  using namespace saul;
  for (std::size_t at = 0; at + 13 <= size; at += 13) {
    CanFrame f;
    std::uint32_t id = 0;
    std::memcpy(&id, data + at, 4);
    std::uint8_t flags = data[at + 4];
    f.extended = flags & 0x80;
    f.remote = flags & 0x40;
    f.error = flags & 0x20;
    f.dlc = flags & 0x0F;  // 9..15 too: decode must refuse them, not read past data
    f.id = f.extended || f.error ? (id & 0x1FFF'FFFF) : (flags & 0x10 ? id & 0x7FF : (id & 0x3F) | 0x300);
    std::memcpy(f.data.data(), data + at + 5, 8);
    (void)decode_bus_frame(f);
  }
  return 0;
}
