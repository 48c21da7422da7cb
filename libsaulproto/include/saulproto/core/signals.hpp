// One description of every message's signals, as constant data: where each value sits in the bytes, how wide it
// is, how to turn the wire integer into a physical value, its unit, its valid range and its value names.
//
// The typed structs and codecs (saul_can.hpp, vesc.hpp, crsf.hpp, interboard.hpp, pride.hpp) stay what firmware uses; this
// is what everything generic reads: the DBC writer, the plot, saulctl's text and JSON, and whatever is written
// from it later (physical units in decode, a Wireshark dissector). tests/unit/test_signals.cpp drives every
// signal through both the typed codec and the generic reader below and requires that they agree.
//
// The data is one header per protocol (signals_saul.hpp, signals_vesc.hpp, signals_crsf.hpp,
// signals_interboard.hpp, signals_pride.hpp), each an array of MessageDesc; messages(protocol) and find() walk them. Everything is
// constexpr or O(message size), no heap, no exceptions: firmware may use it.
//
// Bit numbering is DBC's, so a DBC line is the description written out:
// - little_endian (DBC @1, Intel): start_bit is the least significant bit, numbered 8 * byte + bit; bit i of the
//   value is at start_bit + i, and a value may cross bytes upwards (the CRSF RC channel stream).
// - big_endian (DBC @0, Motorola): start_bit is the MOST significant bit in the same numbering; the next less
//   significant bit is one lower in the same byte, or bit 7 of the next byte after bit 0. A big-endian field that
//   starts at a byte boundary therefore has start_bit 8 * byte + 7.
// Positions count from the first payload byte (CAN: data[0]; UART and CRSF: the byte after TYPE; Pride: the byte
// after the two header bytes), from bit 0 of
// the CAN id (Place::can_id: the VESC controller id), or from the byte after the NUL of the message's string
// (Place::after_string: the CRSF DEVICE_INFO numbers that follow the device name).
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace saul::signals {

enum class Protocol : std::uint8_t { saul_can, vesc_can, crsf, interboard, pride };
inline constexpr Protocol kProtocols[] = {Protocol::saul_can, Protocol::vesc_can, Protocol::crsf,
                                          Protocol::interboard, Protocol::pride};
/// "saul_can", "vesc_can", "crsf", "interboard", "pride".
const char* to_string(Protocol protocol) noexcept;

enum class Kind : std::uint8_t {
  unsigned_int,
  signed_int,    ///< two's complement
  float32,       ///< IEEE-754 binary32; the raw value is its bit pattern
  string,        ///< NUL-terminated ASCII; length is the most characters (NUL not counted)
};
enum class ByteOrder : std::uint8_t { little_endian, big_endian };
/// Where a signal's bits are: see the numbering above. by_header: where the frame's own first byte puts them (the
/// CRSF 0x17 subset RC channels: its first channel and resolution), so only the typed codec finds them and read()
/// gives nullopt; the description holds the signal's name, unit and physical value.
enum class Place : std::uint8_t { payload, can_id, after_string, by_header };

/// How saulctl's text and JSON show the value (under SignalDesc::name), except for the scaled wire integers that
/// text_in_unit() picks out: those show their physical value, and JSON also the wire integer (docs/cli.md).
enum class Text : std::uint8_t {
  raw,           ///< the wire integer (a float32 as its float)
  name,          ///< the value's name from SignalDesc::values
  physical,      ///< raw_to_physical(), a decimal ("{:g}" in text, a JSON number)
  physical_int,  ///< raw_to_physical(), exact and integral for this signal (CRSF -dBm as dBm, altitude - 1000)
};

/// Who enforces the valid range [min, max].
enum class Check : std::uint8_t {
  advisory,  ///< the codec passes any value both ways; the range documents the meaning or a receiver's policy
  decoder,   ///< the typed decoder rejects a value outside it (out_of_range)
  encoder,   ///< the typed encoder refuses a value outside it (out_of_range); the decoder passes it through
};

enum class Mux : std::uint8_t {
  none,
  multiplexer,  ///< its value says which multiplexed signals the frame carries
  multiplexed,  ///< present only when the multiplexer equals mux_value
};

struct ValueName {
  std::int64_t value = 0;  ///< the raw value, or the bit number when SignalDesc::value_bits
  const char* name = "";
};

/// The most and least a signal of this kind and width can carry.
constexpr std::int64_t lowest_raw(Kind kind, unsigned bits) noexcept {
  return kind == Kind::signed_int ? -(std::int64_t{1} << (bits - 1)) : 0;
}
constexpr std::int64_t highest_raw(Kind kind, unsigned bits) noexcept {
  return kind == Kind::signed_int ? (std::int64_t{1} << (bits - 1)) - 1 : (std::int64_t{1} << bits) - 1;
}

struct SignalDesc {
  /// The signal's one name in every output: text, JSON, CSV, DBC, Python, dissector, MCAP, plot ("pitch").
  const char* name = "";
  /// The typed struct's field (saul_can.hpp, vesc.hpp, ...: firmware's name for the wire value, "pitch_x100"):
  /// code only, never an output name; test_signals.cpp pairs the struct's fields() with the signals by it.
  const char* field = "";
  const char* unit = "";  ///< ASCII: "deg", "V", "mm/s", "us"; "" for none
  Place place = Place::payload;
  std::uint16_t start_bit = 0;
  std::uint8_t length = 0;  ///< bits; for a string, the most characters
  Kind kind = Kind::unsigned_int;
  ByteOrder order = ByteOrder::little_endian;
  std::int32_t scale_num = 1;  ///< physical = raw * scale_num / scale_den + offset
  std::int32_t scale_den = 1;
  double offset = 0;
  std::int64_t min = 0;  ///< valid raw range (float32: unused)
  std::int64_t max = 0;
  Check check = Check::advisory;
  Text text = Text::raw;
  Mux mux = Mux::none;
  std::uint8_t mux_value = 0;
  std::span<const ValueName> values{};  ///< value names, or bit names when value_bits
  bool value_bits = false;

  // Builders, so the data files read as one line per signal.
  [[nodiscard]] constexpr SignalDesc as_field(const char* f) const noexcept { auto s = *this; s.field = f; return s; }
  [[nodiscard]] constexpr SignalDesc in(const char* u) const noexcept { auto s = *this; s.unit = u; return s; }
  [[nodiscard]] constexpr SignalDesc scaled(std::int32_t num, std::int32_t den) const noexcept {
    auto s = *this;
    s.scale_num = num;
    s.scale_den = den;
    return s;
  }
  [[nodiscard]] constexpr SignalDesc offset_by(double o) const noexcept { auto s = *this; s.offset = o; return s; }
  [[nodiscard]] constexpr SignalDesc valid(std::int64_t lo, std::int64_t hi, Check c = Check::advisory) const noexcept {
    auto s = *this;
    s.min = lo;
    s.max = hi;
    s.check = c;
    return s;
  }
  [[nodiscard]] constexpr SignalDesc shown(Text t) const noexcept { auto s = *this; s.text = t; return s; }
  [[nodiscard]] constexpr SignalDesc named(std::span<const ValueName> v) const noexcept {
    auto s = *this;
    s.values = v;
    return s;
  }
  [[nodiscard]] constexpr SignalDesc bits_named(std::span<const ValueName> v) const noexcept {
    auto s = named(v);
    s.value_bits = true;
    return s;
  }
  [[nodiscard]] constexpr SignalDesc multiplexer() const noexcept { auto s = *this; s.mux = Mux::multiplexer; return s; }
  [[nodiscard]] constexpr SignalDesc when(std::uint8_t mux_equals) const noexcept {
    auto s = *this;
    s.mux = Mux::multiplexed;
    s.mux_value = mux_equals;
    return s;
  }
  [[nodiscard]] constexpr SignalDesc at(Place p) const noexcept { auto s = *this; s.place = p; return s; }
};

/// A number field: `bits` wide from `start_bit` (see the numbering above), field = name, unit none, scale 1, the
/// whole encodable range valid.
constexpr SignalDesc number(const char* name, ByteOrder order, unsigned start_bit, unsigned bits,
                            Kind kind) noexcept {
  SignalDesc s;
  s.name = name;
  s.field = name;
  s.order = order;
  s.start_bit = static_cast<std::uint16_t>(start_bit);
  s.length = static_cast<std::uint8_t>(bits);
  s.kind = kind;
  s.min = lowest_raw(kind, bits);
  s.max = highest_raw(kind, bits);
  return s;
}
/// Byte-aligned integers: little-endian from byte `byte`, big-endian with its most significant byte at `byte`.
constexpr SignalDesc le_u(const char* name, unsigned byte, unsigned bits) noexcept {
  return number(name, ByteOrder::little_endian, byte * 8, bits, Kind::unsigned_int);
}
constexpr SignalDesc le_i(const char* name, unsigned byte, unsigned bits) noexcept {
  return number(name, ByteOrder::little_endian, byte * 8, bits, Kind::signed_int);
}
constexpr SignalDesc be_u(const char* name, unsigned byte, unsigned bits) noexcept {
  return number(name, ByteOrder::big_endian, byte * 8 + 7, bits, Kind::unsigned_int);
}
constexpr SignalDesc be_i(const char* name, unsigned byte, unsigned bits) noexcept {
  return number(name, ByteOrder::big_endian, byte * 8 + 7, bits, Kind::signed_int);
}
constexpr SignalDesc le_f32(const char* name, unsigned byte) noexcept {
  SignalDesc s = number(name, ByteOrder::little_endian, byte * 8, 32, Kind::float32);
  s.min = s.max = 0;
  return s;
}
/// A NUL-terminated string at `byte` of at most max_chars characters.
constexpr SignalDesc text_field(const char* name, unsigned byte, unsigned max_chars) noexcept {
  SignalDesc s;
  s.name = name;
  s.field = name;
  s.start_bit = static_cast<std::uint16_t>(byte * 8);
  s.length = static_cast<std::uint8_t>(max_chars);
  s.kind = Kind::string;
  return s;
}

struct MessageDesc {
  Protocol protocol = Protocol::saul_can;
  /// saul_can: the 11-bit id; vesc_can: the command (id bits 15..8, the controller is the signal in bits 7..0);
  /// crsf and interboard: the TYPE byte; pride: the two header bytes, the first one high (0xFE54).
  std::uint32_t id = 0;
  const char* name = "";      ///< the typed struct's kName ("telemetry_a", "vesc_status_1", "rc_channels")
  std::uint8_t length = 0;    ///< payload bytes: CAN DLC, UART LEN; CRSF: the fewest (longer payloads are read)
  bool exact_length = true;   ///< false: `length` is a minimum (CRSF; strings make DEVICE_INFO longer)
  /// node names: "Orin", "BALANCE", "IO", "VESC", "RX" (the RC receiver), "VCU" and "PRIDE" (the Pride controller)
  const char* sender = "";
  const char* receiver = "";
  std::span<const SignalDesc> signals{};
};

/// The description of typed message M, named by its kName (for the data files).
template <class M>
constexpr MessageDesc describe(Protocol protocol, std::uint32_t id, std::size_t length, bool exact_length,
                               const char* sender, const char* receiver, std::span<const SignalDesc> s) noexcept {
  return {protocol, id, M::kName, static_cast<std::uint8_t>(length), exact_length, sender, receiver, s};
}

// ---- values ----------------------------------------------------------------------------------------------------

/// physical = raw * scale_num / scale_den + offset, in double (raw / 10 exactly as the VESC structs' own
/// raw / 10.0, since scale_num is 1 there). A float32 signal gives its float.
constexpr double raw_to_physical(const SignalDesc& s, std::int64_t raw) noexcept {
  if (s.kind == Kind::float32) return static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(raw)));
  double v = static_cast<double>(raw * s.scale_num) / static_cast<double>(s.scale_den);
  if (s.offset != 0) v += s.offset;
  return v;
}

/// The inverse, rounded to the nearest integer (halves away from zero); float32 gives the float's bit pattern.
constexpr std::int64_t physical_to_raw(const SignalDesc& s, double physical) noexcept {
  if (s.kind == Kind::float32) return std::bit_cast<std::uint32_t>(static_cast<float>(physical));
  const double x = (physical - s.offset) * static_cast<double>(s.scale_den) / static_cast<double>(s.scale_num);
  return x >= 0 ? static_cast<std::int64_t>(x + 0.5) : -static_cast<std::int64_t>(-x + 0.5);
}

/// Whether saulctl's text shows the signal as its physical value with its unit under its name (pitch=12.34°,
/// battery=39.876V, ch1=1500µs) instead of the wire integer: a scaled integer with a unit and Text::raw. JSON
/// has the physical value under the name and the wire integer under name + "_raw" ("pitch_raw"): scripts, the Python
/// module and the Wireshark dissector read them.
constexpr bool text_in_unit(const SignalDesc& s) noexcept {
  return s.text == Text::raw && (s.kind == Kind::signed_int || s.kind == Kind::unsigned_int) && s.unit[0] != '\0' &&
         (s.scale_num != 1 || s.scale_den != 1 || s.offset != 0);
}

/// The digits after the point that show a signal's physical value exactly: k when its resolution
/// scale_num / scale_den is a whole multiple of 10^-k (pitch, 1/100 deg: 2; battery, 1/1000 V: 3), up to 9; -1
/// when it is no decimal fraction (the CRSF RC channels' 1024/1639 us), which text shows in whole units rounded
/// down, as the receivers map ticks to microseconds (crsf::ticks_to_us).
constexpr int text_decimals(const SignalDesc& s) noexcept {
  std::int64_t ten_k = 1;
  for (int k = 0; k <= 9; ++k, ten_k *= 10)
    if ((std::int64_t{s.scale_num} * ten_k) % s.scale_den == 0) return k;
  return -1;
}

constexpr bool in_valid_range(const SignalDesc& s, std::int64_t raw) noexcept {
  return s.kind == Kind::float32 || s.kind == Kind::string || (raw >= s.min && raw <= s.max);
}
constexpr std::int64_t lowest_raw(const SignalDesc& s) noexcept { return lowest_raw(s.kind, s.length); }
constexpr std::int64_t highest_raw(const SignalDesc& s) noexcept {
  return s.kind == Kind::float32 ? 0xFFFFFFFF : highest_raw(s.kind, s.length);
}

/// The name of a value (or of bit number `value`, for value_bits), or nullptr.
constexpr const char* value_name(const SignalDesc& s, std::int64_t value) noexcept {
  for (const auto& v : s.values)
    if (v.value == value) return v.name;
  return nullptr;
}

/// Whether a signal is in a frame whose multiplexer reads `mux` (nullopt: the message has none).
constexpr bool present(const SignalDesc& s, std::optional<std::int64_t> mux) noexcept {
  return s.mux != Mux::multiplexed || (mux && *mux == s.mux_value);
}

// ---- bits --------------------------------------------------------------------------------------------------------

namespace detail {
/// Calls at(position, significance) for every bit of the signal, most significant first. O(length).
template <class F>
constexpr void each_bit(const SignalDesc& s, F&& at) noexcept {
  std::size_t p = s.order == ByteOrder::little_endian ? std::size_t{s.start_bit} + s.length - 1 : s.start_bit;
  for (unsigned i = s.length; i-- > 0;) {
    at(p, i);
    if (s.order == ByteOrder::little_endian) --p;
    else p = (p % 8 == 0) ? p + 15 : p - 1;  // Motorola: down the byte, then bit 7 of the next one
  }
}
/// The number of bytes from the base that the signal's bits need.
constexpr std::size_t bytes_needed(const SignalDesc& s) noexcept {
  if (s.length == 0) return 0;
  if (s.order == ByteOrder::little_endian) return (std::size_t{s.start_bit} + s.length - 1) / 8 + 1;
  const std::size_t in_first = s.start_bit % 8 + 1u;  // bits of the first (most significant) byte
  const std::size_t rest = s.length > in_first ? s.length - in_first : 0;
  return s.start_bit / 8 + (rest + 7) / 8 + 1;
}
/// The bits of a number signal whose bytes `bytes` holds from its base on (sign-extended for signed_int).
constexpr std::int64_t bits_of(const SignalDesc& s, const std::uint8_t* bytes) noexcept {
  std::uint64_t u = 0;
  const bool le = s.order == ByteOrder::little_endian;
  if (s.length % 8 == 0 && s.start_bit % 8 == (le ? 0 : 7)) {  // whole bytes (most signals): a byte at a time
    const std::size_t first = s.start_bit / 8, n = s.length / 8u;
    for (std::size_t i = 0; i < n; ++i) u |= std::uint64_t{bytes[first + i]} << (8 * (le ? i : n - 1 - i));
  } else {
    each_bit(s, [&](std::size_t p, unsigned i) { u |= static_cast<std::uint64_t>((bytes[p / 8] >> (p % 8)) & 1U) << i; });
  }
  if (s.kind == Kind::signed_int && ((u >> (s.length - 1)) & 1U) != 0) u |= ~std::uint64_t{0} << s.length;
  return static_cast<std::int64_t>(u);
}
}  // namespace detail

/// The raw value of a number signal in `bytes`, its bit numbering starting at byte `base` (sign-extended for
/// signed_int, the bit pattern for float32); nullopt when the bytes are too short. O(length).
constexpr std::optional<std::int64_t> read_raw(const SignalDesc& s, std::span<const std::uint8_t> bytes,
                                               std::size_t base = 0) noexcept {
  if (s.kind == Kind::string || s.length == 0 || s.length > 63) return std::nullopt;
  if (base + detail::bytes_needed(s) > bytes.size()) return std::nullopt;
  return detail::bits_of(s, bytes.data() + base);
}

/// Writes the low `length` bits of raw into `bytes` (other bits untouched); false when they do not fit.
constexpr bool write_raw(const SignalDesc& s, std::int64_t raw, std::span<std::uint8_t> bytes,
                         std::size_t base = 0) noexcept {
  if (s.kind == Kind::string || s.length == 0 || s.length > 63) return false;
  if (base + detail::bytes_needed(s) > bytes.size()) return false;
  const auto u = static_cast<std::uint64_t>(raw);
  detail::each_bit(s, [&](std::size_t p, unsigned i) {
    const auto mask = static_cast<std::uint8_t>(1U << (p % 8));
    std::uint8_t& b = bytes[base + p / 8];
    b = ((u >> i) & 1U) != 0 ? static_cast<std::uint8_t>(b | mask) : static_cast<std::uint8_t>(b & ~mask);
  });
  return true;
}

/// A string signal's characters (up to its NUL) at byte start_bit / 8 + base; nullopt without a NUL within
/// length + 1 bytes (and within the payload).
constexpr std::optional<std::string_view> read_string(const SignalDesc& s, std::span<const std::uint8_t> bytes,
                                                      std::size_t base = 0) noexcept {
  if (s.kind != Kind::string) return std::nullopt;
  const std::size_t first = base + s.start_bit / 8;
  for (std::size_t i = first; i < bytes.size() && i <= first + s.length; ++i)
    if (bytes[i] == 0) return std::string_view(reinterpret_cast<const char*>(bytes.data()) + first, i - first);
  return std::nullopt;
}

/// What a message arrived in: the CAN id (for Place::can_id) and the payload.
struct Wire {
  std::uint32_t id = 0;
  std::span<const std::uint8_t> payload{};
};

/// Where the bit numbering of signal s starts in the payload: 0, or the byte after the message's string's NUL
/// (Place::after_string); nullopt when that string has no NUL.
constexpr std::optional<std::size_t> base_of(const MessageDesc& m, const SignalDesc& s,
                                             std::span<const std::uint8_t> payload) noexcept {
  if (s.place != Place::after_string) return std::size_t{0};
  for (const auto& t : m.signals)
    if (t.kind == Kind::string) {
      const auto chars = read_string(t, payload);
      if (!chars) return std::nullopt;
      return t.start_bit / 8 + chars->size() + 1;
    }
  return std::nullopt;
}

/// The raw value of a number signal of message m as it arrived (nullopt for Place::by_header). O(length).
constexpr std::optional<std::int64_t> read(const MessageDesc& m, const SignalDesc& s, const Wire& w) noexcept {
  if (s.place == Place::by_header) return std::nullopt;
  if (s.place == Place::can_id) {
    const std::uint8_t id_bytes[4] = {static_cast<std::uint8_t>(w.id), static_cast<std::uint8_t>(w.id >> 8),
                                      static_cast<std::uint8_t>(w.id >> 16), static_cast<std::uint8_t>(w.id >> 24)};
    return read_raw(s, id_bytes);
  }
  const auto base = base_of(m, s, w.payload);
  if (!base) return std::nullopt;
  return read_raw(s, w.payload, *base);
}

/// The multiplexer's value in a frame of m, or nullopt when m has no multiplexer (or the frame is too short).
constexpr std::optional<std::int64_t> mux_of(const MessageDesc& m, const Wire& w) noexcept {
  for (const auto& s : m.signals)
    if (s.mux == Mux::multiplexer) return read(m, s, w);
  return std::nullopt;
}

// ---- lookup (signals.cpp) --------------------------------------------------------------------------------------

/// Every described message of a protocol, in the order of the codec's Message variant.
std::span<const MessageDesc> messages(Protocol protocol) noexcept;
/// The message with this id (see MessageDesc::id), or nullptr.
const MessageDesc* find(Protocol protocol, std::uint32_t id) noexcept;
/// The message a CAN frame with this id and format carries (11-bit: SAUL, 29-bit: VESC), or nullptr.
const MessageDesc* find_can(std::uint32_t can_id, bool extended) noexcept;
/// The message of that name, or nullptr.
const MessageDesc* find_named(Protocol protocol, std::string_view name) noexcept;
/// The signal of m whose name or struct field is `name_or_field`, or nullptr.
const SignalDesc* find_signal(const MessageDesc& m, std::string_view name_or_field) noexcept;

}  // namespace saul::signals
