// The exact stuff-bit count of a classic CAN frame, table-driven: the header padded at the front to whole bytes, the
// CRC-15 a byte at a time, and the stuffing as a state machine over (last bit, run length) stepped a byte at a time.
// test_can_bits.cpp holds it to the bit-by-bit rule.
#include <array>
#include <cstddef>
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

/// The machine stepped over `Bits` bits at once (most significant first), from each of the 9 states: next[b][s] and
/// stuff[b][s]. Indexed by the bits first, so a step's address is the bits' row (known ahead) plus the state just
/// read: the chain of steps over a frame waits on one load per byte, no multiplication or unpacking between.
template <unsigned Bits>
struct StuffSteps {
  static constexpr std::size_t kRow = 16;  // the 9 states, a row padded to 16 bytes (the index a shift, not a multiply)
  std::array<std::array<std::uint8_t, kRow>, 1U << Bits> next{};
  std::array<std::array<std::uint8_t, kRow>, 1U << Bits> stuff{};
};
template <unsigned Bits>
constexpr StuffSteps<Bits> stuff_table() {
  StuffSteps<Bits> t{};
  for (std::uint8_t s = 0; s < 9; ++s)
    for (unsigned b = 0; b < (1U << Bits); ++b) {
      Step step{s, 0};
      for (unsigned i = Bits; i-- > 0;) {
        const Step next = stuff_bit(step.state, (b >> i) & 1U);
        step.state = next.state;
        step.stuff = static_cast<std::uint8_t>(step.stuff + next.stuff);
      }
      t.next[b][s] = step.state;
      t.stuff[b][s] = step.stuff;
    }
  return t;
}
constexpr auto kStuffTable = stuff_table<8>();   // a byte
constexpr auto kStuffTable7 = stuff_table<7>();  // the CRC's last 7 bits (15 = 8 + 7)

// The CRC is linear: the register after the header and the data is the register after the header and as many zero
// bytes (CanStuffStart::crc, once per id and DLC), XORed with each data byte's own share. kCrcAfter[k][b] is the
// register after byte b and then k zero bytes, from a zero register: the data's CRC is 8 independent lookups
// instead of a chain of 8 dependent ones. kCrcAfter[0] is the table of the CRC a byte at a time.
constexpr std::array<std::array<std::uint16_t, 256>, CanFrame::kMaxDlc> kCrcAfter = [] {
  std::array<std::array<std::uint16_t, 256>, CanFrame::kMaxDlc> t{};
  for (unsigned b = 0; b < 256; ++b) {
    std::uint16_t crc = 0;
    for (unsigned i = 8; i-- > 0;) crc = crc_bit(crc, (b >> i) & 1U);  // the byte b, bit by bit
    for (std::size_t k = 0; k < t.size(); ++k) {
      t[k][b] = crc;
      for (int i = 0; i < 8; ++i) crc = crc_bit(crc, 0);  // a zero byte
    }
  }
  return t;
}();

constexpr std::uint16_t crc_byte(std::uint16_t crc, std::uint8_t byte) noexcept {
  return static_cast<std::uint16_t>(((crc << 8) & 0x7FFF) ^ kCrcAfter[0][((crc >> 7) ^ byte) & 0xFF]);
}

/// The stuff bits of the CRC's 15 bits, the last to be stuffed, from the machine's state after the data.
inline unsigned crc_stuff_bits(std::uint8_t state, std::uint16_t crc) noexcept {
  const auto high = static_cast<std::uint8_t>(crc >> 7);
  return kStuffTable.stuff[high][state] + kStuffTable7.stuff[crc & 0x7F][kStuffTable.next[high][state]];
}

}  // namespace

CanStuffStart can_stuff_start(std::uint32_t id, bool extended, bool remote, std::uint8_t dlc) noexcept {
  // The header (SOF, arbitration, control: 19 bits, or 39 with a 29-bit id) padded at the front to whole bytes,
  // so that the data bytes follow as they are: 3 or 5 header bytes, most significant first.
  std::uint64_t header;
  unsigned header_bytes;
  const std::uint64_t code = dlc > CanFrame::kMaxDlc ? CanFrame::kMaxDlc : dlc;
  const std::uint64_t rtr = remote ? 1 : 0;
  if (extended) {
    // SOF 0, base id 11, SRR 1, IDE 1, id extension 18, RTR, r1 r0, DLC 4
    header = (std::uint64_t{id >> 18 & 0x7FF} << 27) | (std::uint64_t{3} << 25) | (std::uint64_t{id & 0x3FFFF} << 7) |
             (rtr << 6) | code;
    header_bytes = 5;  // 39 bits + 1 pad bit
  } else {
    // SOF 0, id 11, RTR, IDE 0, r0 0, DLC 4
    header = (std::uint64_t{id & 0x7FF} << 7) | (rtr << 6) | code;
    header_bytes = 3;  // 19 bits + 5 pad bits
  }
  const unsigned pad = header_bytes * 8 - (extended ? 39U : 19U);
  // Stuffing a byte at a time: padded at the front with alternating bits ending in 1, which never make a run of
  // five and after which SOF (0) starts a run of one, as it does first on the bus. For the CRC the padding is
  // zeros: zeros in front leave a zero register zero.
  const std::uint64_t stuffed_header =
      header | ((std::uint64_t{0x55} & ((std::uint64_t{1} << pad) - 1)) << (header_bytes * 8 - pad));
  CanStuffStart start;
  start.bytes = static_cast<std::uint8_t>(remote ? 0 : code);
  for (unsigned k = header_bytes; k-- > 0;) {
    start.crc = crc_byte(start.crc, static_cast<std::uint8_t>(header >> (8 * k)));
    const auto b = static_cast<std::uint8_t>(stuffed_header >> (8 * k));
    start.stuff = static_cast<std::uint8_t>(start.stuff + kStuffTable.stuff[b][start.state]);
    start.state = kStuffTable.next[b][start.state];
  }
  for (unsigned i = 0; i < start.bytes; ++i) start.crc = crc_byte(start.crc, 0);
  return start;
}

unsigned can_stuff_bits(const CanStuffStart& start, const std::uint8_t* data) noexcept {
  const unsigned n = start.bytes;
  std::uint16_t crc = start.crc;
  unsigned stuff = start.stuff;
  std::uint8_t state = start.state;
  for (unsigned i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ kCrcAfter[n - 1 - i][data[i]]);
    stuff += kStuffTable.stuff[data[i]][state];
    state = kStuffTable.next[data[i]][state];
  }
  return stuff + crc_stuff_bits(state, crc);
}

unsigned can_stuff_bits(const CanFrame& f) noexcept {
  return can_stuff_bits(can_stuff_start(f.id, f.extended, f.remote, f.dlc), f.data.data());
}

}  // namespace saul::host
