// The exact stuff-bit count of a classic CAN frame, table-driven: the frame's header (SOF to the DLC) padded at the
// front to whole bytes so that the data bytes follow unshifted, its CRC-15 a byte at a time from a 256-entry table,
// and the bit stuffing as a state machine over (last bit, run length) stepped a byte at a time from a table of 9
// states x 256 bytes, alongside (the two chains of lookups overlap), then over the CRC's 8 + 7 bits. Exactly the bit-by-bit
// rule (after five equal bits the opposite bit is inserted, and it starts the next run), checked against the
// bit-by-bit model on random frames and the Python model's vectors in tests/host/report/test_bus_stats.cpp.
#include <array>
#include <cstdint>

#include "saulproto/host/report/bus_stats.hpp"

namespace saul::host {
namespace {

// ---- CRC-15 (polynomial 0x4599, MSB first, initial 0) ------------------------------------------------------------

constexpr std::uint16_t crc_bit(std::uint16_t crc, unsigned bit) noexcept {
  const bool next = (bit != 0) != (((crc >> 14) & 1U) != 0);
  crc = static_cast<std::uint16_t>((crc << 1) & 0x7FFF);
  return next ? static_cast<std::uint16_t>(crc ^ 0x4599) : crc;
}

constexpr std::array<std::uint16_t, 256> kCrcTable = [] {
  std::array<std::uint16_t, 256> t{};
  for (unsigned b = 0; b < 256; ++b) {
    std::uint16_t crc = 0;
    // the register's top 8 bits are XORed with the byte: start from the byte as the register's top bits
    crc = static_cast<std::uint16_t>(b << 7);
    for (int i = 0; i < 8; ++i) crc = crc_bit(crc, 0);
    t[b] = crc;
  }
  return t;
}();

// ---- stuffing state machine -----------------------------------------------------------------------------------

// State: 0 = no bit yet; 1 + 2 * (run - 1) + last for run 1..4 and last 0/1 (states 1..8).
struct Step {
  std::uint8_t state;
  std::uint8_t stuff;
};

constexpr Step stuff_bit(std::uint8_t state, unsigned bit) noexcept {
  unsigned last = state == 0 ? 2 : (state - 1U) % 2;
  unsigned run = state == 0 ? 0 : (state - 1U) / 2 + 1;
  if (bit == last) {
    ++run;
  } else {
    last = bit;
    run = 1;
  }
  std::uint8_t stuff = 0;
  if (run == 5) {
    stuff = 1;
    last = 1 - bit;
    run = 1;
  }
  return {static_cast<std::uint8_t>(1 + 2 * (run - 1) + last), stuff};
}

/// The machine stepped over `Bits` bits at once (most significant first), from each of the 9 states.
template <unsigned Bits>
constexpr std::array<std::array<Step, 1U << Bits>, 9> stuff_table() {
  std::array<std::array<Step, 1U << Bits>, 9> t{};
  for (std::uint8_t s = 0; s < 9; ++s)
    for (unsigned b = 0; b < (1U << Bits); ++b) {
      Step step{s, 0};
      for (unsigned i = Bits; i-- > 0;) {
        const Step next = stuff_bit(step.state, (b >> i) & 1U);
        step.state = next.state;
        step.stuff = static_cast<std::uint8_t>(step.stuff + next.stuff);
      }
      t[s][b] = step;
    }
  return t;
}
constexpr auto kStuffTable = stuff_table<8>();   // a byte
constexpr auto kStuffTable7 = stuff_table<7>();  // the CRC's last 7 bits (15 = 8 + 7)

}  // namespace

unsigned can_stuff_bits(const CanFrame& f) noexcept {
  // The header (SOF, arbitration, control: 19 bits, or 39 with a 29-bit id) padded at the front to whole bytes,
  // so that the data bytes follow as they are: 3 or 5 header bytes, most significant first.
  std::uint64_t header;
  unsigned header_bytes;
  const std::uint64_t dlc = f.dlc > 8 ? 8 : f.dlc;
  const std::uint64_t rtr = f.remote ? 1 : 0;
  if (f.extended) {
    // SOF 0, base id 11, SRR 1, IDE 1, id extension 18, RTR, r1 r0, DLC 4
    header = (std::uint64_t{f.id >> 18 & 0x7FF} << 27) | (std::uint64_t{3} << 25) |
             (std::uint64_t{f.id & 0x3FFFF} << 7) | (rtr << 6) | dlc;
    header_bytes = 5;  // 39 bits + 1 pad bit
  } else {
    // SOF 0, id 11, RTR, IDE 0, r0 0, DLC 4
    header = (std::uint64_t{f.id & 0x7FF} << 7) | (rtr << 6) | dlc;
    header_bytes = 3;  // 19 bits + 5 pad bits
  }
  const unsigned pad = header_bytes * 8 - (f.extended ? 39U : 19U);
  const auto payload = f.payload();

  // CRC over the bits a byte at a time: zeros in front leave a zero register zero, so the padding is zeros here.
  std::uint16_t crc = 0;
  auto crc_byte = [&crc](std::uint8_t byte) {
    crc = static_cast<std::uint16_t>(((crc << 8) & 0x7FFF) ^ kCrcTable[((crc >> 7) ^ byte) & 0xFF]);
  };
  // Stuffing a byte at a time: padded at the front with alternating bits ending in 1, which never make a run of
  // five and after which SOF (0) starts a run of one, as it does first on the bus.
  const std::uint64_t stuffed_header = header | ((std::uint64_t{0x55} & ((std::uint64_t{1} << pad) - 1)) << (header_bytes * 8 - pad));
  unsigned stuff = 0;
  std::uint8_t state = 0;
  auto stuff_byte = [&](std::uint8_t byte) {
    const Step st = kStuffTable[state][byte];
    state = st.state;
    stuff += st.stuff;
  };
  for (unsigned k = header_bytes; k-- > 0;) {
    crc_byte(static_cast<std::uint8_t>(header >> (8 * k)));
    stuff_byte(static_cast<std::uint8_t>(stuffed_header >> (8 * k)));
  }
  for (std::uint8_t byte : payload) {
    crc_byte(byte);
    stuff_byte(byte);
  }
  // then the CRC's 15 bits, the last to be stuffed
  stuff_byte(static_cast<std::uint8_t>(crc >> 7));
  const Step last = kStuffTable7[state][crc & 0x7F];
  return stuff + last.stuff;
}

}  // namespace saul::host
