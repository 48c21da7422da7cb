// The exact stuff-bit count of a classic CAN frame, table-driven: the frame's bits (SOF to the end of the data) in
// one 128-bit word, its CRC-15 a byte at a time from a 256-entry table, then the bit stuffing as a state machine
// over (last bit, run length) stepped a byte at a time from a table of 9 states x 256 bytes. Exactly the bit-by-bit
// rule (after five equal bits the opposite bit is inserted, and it starts the next run), checked against the
// bit-by-bit model on random frames and the Python model's vectors in tests/host/report/test_bus_stats.cpp.
#include <array>
#include <cstdint>

#include "saulproto/host/report/bus_stats.hpp"

namespace saul::host {
namespace {

__extension__ typedef unsigned __int128 Word;

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

constexpr std::array<std::array<Step, 256>, 9> kStuffTable = [] {
  std::array<std::array<Step, 256>, 9> t{};
  for (std::uint8_t s = 0; s < 9; ++s)
    for (unsigned b = 0; b < 256; ++b) {
      Step step{s, 0};
      for (int i = 7; i >= 0; --i) {
        const Step next = stuff_bit(step.state, (b >> i) & 1U);
        step.state = next.state;
        step.stuff = static_cast<std::uint8_t>(step.stuff + next.stuff);
      }
      t[s][b] = step;
    }
  return t;
}();

/// The word's 16 bytes, most significant first (two byte swaps instead of 16 shifts of a 128-bit word).
void big_endian_bytes(Word w, std::uint8_t (&bytes)[16]) noexcept {
  const std::uint64_t hi = static_cast<std::uint64_t>(w >> 64);
  const std::uint64_t lo = static_cast<std::uint64_t>(w);
  for (int k = 0; k < 8; ++k) {
    bytes[k] = static_cast<std::uint8_t>(hi >> (56 - 8 * k));
    bytes[8 + k] = static_cast<std::uint8_t>(lo >> (56 - 8 * k));
  }
}

}  // namespace

unsigned can_stuff_bits(const CanFrame& f) noexcept {
  Word w = 0;
  unsigned n = 0;
  auto put = [&](std::uint64_t value, unsigned width) {
    w = (w << width) | value;
    n += width;
  };
  put(0, 1);  // SOF
  if (f.extended) {
    put(f.id >> 18 & 0x7FF, 11);
    put(3, 2);  // SRR, IDE
    put(f.id & 0x3FFFF, 18);
    put(f.remote ? 1 : 0, 1);
    put(0, 2);  // r1, r0
  } else {
    put(f.id & 0x7FF, 11);
    put(f.remote ? 1 : 0, 1);
    put(0, 2);  // IDE, r0
  }
  put(f.dlc > 8 ? 8 : f.dlc, 4);
  for (std::uint8_t byte : f.payload()) put(byte, 8);

  // CRC over the n bits, a byte at a time: zeros in front leave a zero register zero, so the bits are padded at
  // the front to whole bytes.
  std::uint8_t bytes[16];
  big_endian_bytes(w, bytes);
  const unsigned crc_bytes = (n + 7) / 8;
  std::uint16_t crc = 0;
  for (unsigned k = 16 - crc_bytes; k < 16; ++k)
    crc = static_cast<std::uint16_t>(((crc << 8) & 0x7FFF) ^ kCrcTable[((crc >> 7) ^ bytes[k]) & 0xFF]);
  put(crc, 15);

  // Stuffing over the n bits and the CRC, a byte at a time: padded at the front with alternating bits ending in 1,
  // which never make a run of five and after which SOF (0) starts a run of one, as it does first on the bus.
  const unsigned pad = (8 - n % 8) % 8;
  w |= (Word{0x55} & ((Word{1} << pad) - 1)) << n;
  big_endian_bytes(w, bytes);
  unsigned stuff = 0;
  std::uint8_t state = 0;
  for (unsigned k = 16 - (n + pad) / 8; k < 16; ++k) {
    const Step st = kStuffTable[state][bytes[k]];
    state = st.state;
    stuff += st.stuff;
  }
  return stuff;
}

}  // namespace saul::host
