// The exact stuff-bit count of a classic CAN frame, table-driven: the header padded at the front to whole bytes, the
// CRC-15 a byte at a time, and the stuffing as a state machine over (last bit, run length) stepped a byte at a time.
// With SSSE3 the data bytes' steps are composed with byte shuffles (can_stuff_bits_ssse3). test_can_bits.cpp holds
// both to the bit-by-bit rule.
#include <array>
#include <cstddef>
#include <cstdint>

#include "saulproto/host/report/bus_stats.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
#define SAUL_STUFF_SSSE3 1
#include <tmmintrin.h>
#else
#define SAUL_STUFF_SSSE3 0
#endif

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
    // the register's top 8 bits are XORed with the byte: start from the byte as the register's top bits
    auto crc = static_cast<std::uint16_t>(b << 7);
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

constexpr std::uint16_t crc_byte(std::uint16_t crc, std::uint8_t byte) noexcept {
  return static_cast<std::uint16_t>(((crc << 8) & 0x7FFF) ^ kCrcTable[((crc >> 7) ^ byte) & 0xFF]);
}

// The CRC is linear: the register after the header and the data is the register after the header and as many zero
// bytes (CanStuffStart::crc, once per id and DLC), XORed with each data byte's own share. kCrcAfter[k][b] is the
// register after byte b and then k zero bytes, from a zero register: the data's CRC is 8 independent lookups
// instead of a chain of 8 dependent ones.
constexpr std::array<std::array<std::uint16_t, 256>, CanFrame::kMaxDlc> kCrcAfter = [] {
  std::array<std::array<std::uint16_t, 256>, CanFrame::kMaxDlc> t{};
  for (unsigned b = 0; b < 256; ++b) {
    std::uint16_t crc = crc_byte(0, static_cast<std::uint8_t>(b));
    for (std::size_t k = 0; k < t.size(); ++k) {
      t[k][b] = crc;
      crc = crc_byte(crc, 0);
    }
  }
  return t;
}();

/// The stuff bits of the CRC's 15 bits, the last to be stuffed, from the machine's state after the data.
inline unsigned crc_stuff_bits(std::uint8_t state, std::uint16_t crc) noexcept {
  const Step high = kStuffTable[state][static_cast<std::uint8_t>(crc >> 7)];
  return high.stuff + kStuffTable7[high.state][crc & 0x7F].stuff;
}

#if SAUL_STUFF_SSSE3
// kStuffTable as maps for can_stuff_bits_ssse3(): for byte b, next[b][s] and stuff[b][s] are kStuffTable[s][b]'s
// (lanes 9..15 unused, 0); the entry kIdentity leaves every state as it is, for the bytes after the last.
constexpr unsigned kIdentity = 256;
struct StuffMaps {
  alignas(16) std::array<std::array<std::uint8_t, 16>, 257> next;
  alignas(16) std::array<std::array<std::uint8_t, 16>, 257> stuff;
  alignas(16) std::array<std::array<std::uint8_t, 16>, 128> next7;  // kStuffTable7's: the CRC's last 7 bits
  alignas(16) std::array<std::array<std::uint8_t, 16>, 128> stuff7;
};
constexpr StuffMaps kStuffMaps = [] {
  StuffMaps maps{};
  for (unsigned b = 0; b < 256; ++b)
    for (unsigned s = 0; s < 9; ++s) {
      maps.next[b][s] = kStuffTable[s][b].state;
      maps.stuff[b][s] = kStuffTable[s][b].stuff;
      if (b < 128) {
        maps.next7[b][s] = kStuffTable7[s][b].state;
        maps.stuff7[b][s] = kStuffTable7[s][b].stuff;
      }
    }
  for (unsigned s = 0; s < 16; ++s) maps.next[kIdentity][s] = static_cast<std::uint8_t>(s);
  return maps;
}();
/// Byte b's map (kIdentity: none).
[[gnu::always_inline]] inline void map_of(unsigned b, __m128i& next, __m128i& stuff) noexcept {
  next = _mm_load_si128(reinterpret_cast<const __m128i*>(kStuffMaps.next[b].data()));
  stuff = _mm_load_si128(reinterpret_cast<const __m128i*>(kStuffMaps.stuff[b].data()));
}
/// Map a then map b (in place of a): from state s, b's step from a's next state; a's stuff bits and then b's.
[[gnu::target("ssse3"), gnu::always_inline]] inline void compose(__m128i& next_a, __m128i& stuff_a, __m128i next_b,
                                                               __m128i stuff_b) noexcept {
  stuff_a = _mm_add_epi8(stuff_a, _mm_shuffle_epi8(stuff_b, next_a));
  next_a = _mm_shuffle_epi8(next_b, next_a);
}
// Whether this CPU has SSSE3 (nearly every x86-64 since 2006; the Debian baseline does not promise it).
const bool kHaveSsse3 = [] {
  __builtin_cpu_init();
  return __builtin_cpu_supports("ssse3") != 0;
}();
#endif

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
    const Step st = kStuffTable[start.state][static_cast<std::uint8_t>(stuffed_header >> (8 * k))];
    start.state = st.state;
    start.stuff = static_cast<std::uint8_t>(start.stuff + st.stuff);
  }
  for (unsigned i = 0; i < start.bytes; ++i) start.crc = crc_byte(start.crc, 0);
  return start;
}

namespace detail {

unsigned can_stuff_bits_table(const CanStuffStart& start, const std::uint8_t* data) noexcept {
  const unsigned n = start.bytes;
  std::uint16_t crc = start.crc;
  unsigned stuff = start.stuff;
  std::uint8_t state = start.state;
  for (unsigned i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ kCrcAfter[n - 1 - i][data[i]]);
    const Step st = kStuffTable[state][data[i]];
    state = st.state;
    stuff += st.stuff;
  }
  return stuff + crc_stuff_bits(state, crc);
}

#if SAUL_STUFF_SSSE3
// The data bytes' steps composed as maps rather than taken one after another: step k is a map from the 9 states to
// the next (and the stuff bits it inserts from each), and maps compose with a byte shuffle. Eight maps in a tree of
// three levels take a few cycles where the chain of 8 dependent table lookups takes ~50 (each waits for the state
// the one before found).
[[gnu::target("ssse3")]] unsigned can_stuff_bits_ssse3(const CanStuffStart& start, const std::uint8_t* data) noexcept {
  const unsigned n = start.bytes;
  // Named, not an array indexed in loops: GCC then kept the maps on the stack and the shuffles waited on it.
  const auto at = [&](unsigned i) { return i < n ? data[i] : kIdentity; };  // the bytes after the last change nothing
  __m128i n0, s0, n1, s1, n2, s2, n3, s3, n4, s4, n5, s5, n6, s6, n7, s7;
  map_of(at(0), n0, s0), map_of(at(1), n1, s1), map_of(at(2), n2, s2), map_of(at(3), n3, s3);
  map_of(at(4), n4, s4), map_of(at(5), n5, s5), map_of(at(6), n6, s6), map_of(at(7), n7, s7);
  std::uint16_t crc = start.crc;
  for (unsigned i = 0; i < n; ++i) crc = static_cast<std::uint16_t>(crc ^ kCrcAfter[n - 1 - i][data[i]]);
  // the CRC's 15 bits are two more maps: they wait for the CRC, not for the state after the data
  __m128i nh, sh, nl, sl;
  map_of(static_cast<std::uint8_t>(crc >> 7), nh, sh);
  nl = _mm_load_si128(reinterpret_cast<const __m128i*>(kStuffMaps.next7[crc & 0x7F].data()));
  sl = _mm_load_si128(reinterpret_cast<const __m128i*>(kStuffMaps.stuff7[crc & 0x7F].data()));
  compose(n0, s0, n1, s1), compose(n2, s2, n3, s3), compose(n4, s4, n5, s5), compose(n6, s6, n7, s7);
  compose(nh, sh, nl, sl);
  compose(n0, s0, n2, s2), compose(n4, s4, n6, s6);
  compose(n0, s0, n4, s4);
  compose(n0, s0, nh, sh);
  const __m128i from = _mm_set1_epi8(static_cast<char>(start.state));
  return start.stuff + (static_cast<unsigned>(_mm_cvtsi128_si32(_mm_shuffle_epi8(s0, from))) & 0xFF);
}

bool can_stuff_ssse3() noexcept { return kHaveSsse3; }
#else
unsigned can_stuff_bits_ssse3(const CanStuffStart& start, const std::uint8_t* data) noexcept {
  return can_stuff_bits_table(start, data);
}
bool can_stuff_ssse3() noexcept { return false; }
#endif

}  // namespace detail

unsigned can_stuff_bits(const CanStuffStart& start, const std::uint8_t* data) noexcept {
#if SAUL_STUFF_SSSE3
  if (kHaveSsse3) return detail::can_stuff_bits_ssse3(start, data);
#endif
  return detail::can_stuff_bits_table(start, data);
}

unsigned can_stuff_bits(const CanFrame& f) noexcept {
  return can_stuff_bits(can_stuff_start(f.id, f.extended, f.remote, f.dlc), f.data.data());
}

}  // namespace saul::host
