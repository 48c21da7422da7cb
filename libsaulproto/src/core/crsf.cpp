#include "saulproto/core/crsf.hpp"

#include "saulproto/core/bytes.hpp"
#include "saulproto/core/crc.hpp"

namespace saul::crsf {
namespace {

// Copies a NUL-terminated string of at most max_chars characters from p (n bytes available) into out
// (max_chars + 1 chars, zero-filled first). Returns the bytes consumed including the NUL, or 0 when no NUL
// was found within the first max_chars + 1 bytes (and within n).
template <std::size_t N>
std::size_t copy_string(const std::uint8_t* p, std::size_t n, std::array<char, N>& out) noexcept {
  const std::size_t limit = n < N ? n : N;
  for (std::size_t i = 0; i < limit; ++i) {
    if (p[i] == 0) return i + 1;
    out[i] = static_cast<char>(p[i]);
  }
  return 0;
}

// Writes the frame around a payload already placed at out[3..3+len): SYNC, LEN, TYPE, CRC.
std::size_t finish_frame(std::uint8_t address, Type type, std::size_t len, std::span<std::uint8_t> out) noexcept {
  out[0] = address;
  out[1] = static_cast<std::uint8_t>(len + 2);
  out[2] = static_cast<std::uint8_t>(type);
  out[3 + len] = crc::crc8_dvb_s2(out.subspan(2, len + 1));
  return len + kOverhead;
}

Message decode_rc_channels(const std::uint8_t* p) noexcept {
  // Unpack the little-endian bit stream with a small accumulator: each byte adds 8 bits, each channel takes
  // 11. 22 bytes, 16 channels, at most 18 bits held.
  RcChannels m;
  std::uint32_t acc = 0;
  unsigned bits = 0;
  std::size_t ch = 0;
  for (std::size_t i = 0; i < RcChannels::kPayloadSize; ++i) {
    acc |= static_cast<std::uint32_t>(p[i]) << bits;
    bits += 8;
    while (bits >= 11 && ch < RcChannels::kCount) {
      m.ticks[ch++] = static_cast<std::uint16_t>(acc & 0x7FFU);
      acc >>= 11;
      bits -= 11;
    }
  }
  return m;
}

// 0x17: a header byte, then channels of 10..13 bits packed LSB first; at most 59 bytes, so the accumulator
// holds at most 13 + 7 bits.
Result<Message> decode_subset_rc_channels(const std::uint8_t* p, std::size_t n) noexcept {
  if (n < 1) return Reason::bad_length;
  SubsetRcChannels m;
  m.first_channel = static_cast<std::uint8_t>(p[0] & 0x1FU);
  m.resolution_bits = static_cast<std::uint8_t>(10U + ((p[0] >> 5) & 0x03U));
  m.digital_switch = (p[0] & 0x80U) != 0;
  const std::uint32_t mask = (1U << m.resolution_bits) - 1U;
  const std::size_t room = SubsetRcChannels::kMaxChannels - m.first_channel;
  std::uint32_t acc = 0;
  unsigned bits = 0;
  for (std::size_t i = 1; i < n && m.count < room; ++i) {
    acc |= static_cast<std::uint32_t>(p[i]) << bits;
    bits += 8;
    while (bits >= m.resolution_bits && m.count < room) {
      m.value[m.count++] = static_cast<std::uint16_t>(acc & mask);
      acc >>= m.resolution_bits;
      bits -= m.resolution_bits;
    }
  }
  return Message{m};
}

}  // namespace

const char* to_string(Type type) noexcept {
  switch (type) {
    case Type::gps: return "gps";
    case Type::battery_sensor: return "battery_sensor";
    case Type::heartbeat: return "heartbeat";
    case Type::link_statistics: return "link_statistics";
    case Type::rc_channels_packed: return "rc_channels_packed";
    case Type::subset_rc_channels_packed: return "subset_rc_channels_packed";
    case Type::attitude: return "attitude";
    case Type::flight_mode: return "flight_mode";
    case Type::device_ping: return "device_ping";
    case Type::device_info: return "device_info";
  }
  return "unknown";
}

std::string_view FlightMode::view() const noexcept {
  std::size_t n = 0;
  while (n < text.size() && text[n] != '\0') ++n;
  return {text.data(), n};
}

Result<FlightMode> make_flight_mode(std::string_view text) noexcept {
  if (text.size() > FlightMode::kMaxChars) return Reason::out_of_range;
  FlightMode m;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\0') return Reason::out_of_range;
    m.text[i] = text[i];
  }
  return m;
}

Type type_of(const Message& message) noexcept {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kType; }, message);
}

const char* name_of(const Message& message) noexcept {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kName; }, message);
}

Result<Message> decode_payload(std::uint8_t type, std::span<const std::uint8_t> payload) noexcept {
  if (!is_known_type(type)) return Reason::unknown_type;
  const std::uint8_t* p = payload.data();
  const std::size_t n = payload.size();
  switch (static_cast<Type>(type)) {
    case Type::rc_channels_packed:
      if (n < RcChannels::kPayloadSize) return Reason::bad_length;
      return decode_rc_channels(p);
    case Type::subset_rc_channels_packed: return decode_subset_rc_channels(p, n);
    case Type::link_statistics: {
      if (n < LinkStatistics::kPayloadSize) return Reason::bad_length;
      LinkStatistics m;
      m.uplink_rssi_1_dbm = static_cast<std::int16_t>(-p[0]);
      m.uplink_rssi_2_dbm = static_cast<std::int16_t>(-p[1]);
      m.uplink_link_quality = p[2];
      m.uplink_snr_db = static_cast<std::int8_t>(p[3]);
      m.active_antenna = p[4];
      m.rf_mode = p[5];
      m.uplink_tx_power = p[6];
      m.downlink_rssi_dbm = static_cast<std::int16_t>(-p[7]);
      m.downlink_link_quality = p[8];
      m.downlink_snr_db = static_cast<std::int8_t>(p[9]);
      return Message{m};
    }
    case Type::battery_sensor:
      if (n < BatterySensor::kPayloadSize) return Reason::bad_length;
      return Message{BatterySensor{bytes::get_u16be(p), bytes::get_u16be(p + 2), bytes::get_u24be(p + 4), p[7]}};
    case Type::gps:
      if (n < Gps::kPayloadSize) return Reason::bad_length;
      return Message{Gps{bytes::get_i32be(p), bytes::get_i32be(p + 4), bytes::get_u16be(p + 8),
                         bytes::get_u16be(p + 10), static_cast<std::int32_t>(bytes::get_u16be(p + 12)) - 1000,
                         p[14]}};
    case Type::attitude:
      if (n < Attitude::kPayloadSize) return Reason::bad_length;
      return Message{Attitude{bytes::get_i16be(p), bytes::get_i16be(p + 2), bytes::get_i16be(p + 4)}};
    case Type::flight_mode: {
      if (n < 1) return Reason::bad_length;
      FlightMode m;
      if (copy_string(p, n, m.text) == 0) return Reason::truncated;
      return Message{m};
    }
    case Type::heartbeat:
      if (n < Heartbeat::kPayloadSize) return Reason::bad_length;
      return Message{Heartbeat{bytes::get_u16be(p)}};
    case Type::device_ping:
      if (n < DevicePing::kPayloadSize) return Reason::bad_length;
      return Message{DevicePing{p[0], p[1]}};
    case Type::device_info: {
      if (n < 2 + 1 + DeviceInfo::kFixedSize) return Reason::bad_length;
      DeviceInfo m;
      m.destination = p[0];
      m.origin = p[1];
      const std::size_t used = copy_string(p + 2, n - 2, m.name);
      if (used == 0 || 2 + used + DeviceInfo::kFixedSize > n) return Reason::truncated;
      const std::uint8_t* f = p + 2 + used;
      m.serial_number = bytes::get_u32be(f);
      m.hardware_id = bytes::get_u32be(f + 4);
      m.firmware_id = bytes::get_u32be(f + 8);
      m.parameters_total = f[12];
      m.parameter_version = f[13];
      return Message{m};
    }
  }
  return Reason::unknown_type;
}

Result<std::size_t> encode_frame(std::uint8_t address, std::uint8_t type, std::span<const std::uint8_t> payload,
                                 std::span<std::uint8_t> out) noexcept {
  if (payload.size() > kMaxPayload) return Reason::out_of_range;
  if (out.size() < payload.size() + kOverhead) return Reason::buffer_too_small;
  for (std::size_t i = 0; i < payload.size(); ++i) out[3 + i] = payload[i];
  return finish_frame(address, static_cast<Type>(type), payload.size(), out);
}

Result<std::size_t> encode(const RcChannels& m, std::span<std::uint8_t> out, std::uint8_t address) noexcept {
  if (out.size() < RcChannels::kPayloadSize + kOverhead) return Reason::buffer_too_small;
  for (std::uint16_t t : m.ticks)
    if (t > kTicksLimit) return Reason::out_of_range;
  // Pack: the reverse of decode_rc_channels, emitting a byte whenever 8 bits are held.
  std::uint8_t* p = out.data() + 3;
  std::uint32_t acc = 0;
  unsigned bits = 0;
  std::size_t i = 0;
  for (std::uint16_t t : m.ticks) {
    acc |= static_cast<std::uint32_t>(t) << bits;
    bits += 11;
    while (bits >= 8) {
      p[i++] = static_cast<std::uint8_t>(acc);
      acc >>= 8;
      bits -= 8;
    }
  }
  return finish_frame(address, RcChannels::kType, RcChannels::kPayloadSize, out);  // 176 bits: bits ends at 0
}

Result<std::size_t> encode(const BatterySensor& m, std::span<std::uint8_t> out, std::uint8_t address) noexcept {
  if (m.capacity_mah > BatterySensor::kMaxCapacity || m.remaining_pct > 100) return Reason::out_of_range;
  if (out.size() < BatterySensor::kPayloadSize + kOverhead) return Reason::buffer_too_small;
  std::uint8_t* p = out.data() + 3;
  bytes::put_u16be(p, m.voltage_x10);
  bytes::put_u16be(p + 2, m.current_x10);
  bytes::put_u24be(p + 4, m.capacity_mah);
  p[7] = m.remaining_pct;
  return finish_frame(address, BatterySensor::kType, BatterySensor::kPayloadSize, out);
}

Result<std::size_t> encode(const Attitude& m, std::span<std::uint8_t> out, std::uint8_t address) noexcept {
  const auto outside = [](std::int16_t a) { return a > Attitude::kLimit || a < -Attitude::kLimit; };
  if (outside(m.pitch_rad_x10000) || outside(m.roll_rad_x10000) || outside(m.yaw_rad_x10000))
    return Reason::out_of_range;
  if (out.size() < Attitude::kPayloadSize + kOverhead) return Reason::buffer_too_small;
  std::uint8_t* p = out.data() + 3;
  bytes::put_i16be(p, m.pitch_rad_x10000);
  bytes::put_i16be(p + 2, m.roll_rad_x10000);
  bytes::put_i16be(p + 4, m.yaw_rad_x10000);
  return finish_frame(address, Attitude::kType, Attitude::kPayloadSize, out);
}

Result<std::size_t> encode(const FlightMode& m, std::span<std::uint8_t> out, std::uint8_t address) noexcept {
  std::size_t chars = 0;
  while (chars < m.text.size() && m.text[chars] != '\0') ++chars;
  if (chars == m.text.size()) return Reason::out_of_range;  // no NUL: cannot happen via make_flight_mode
  const std::size_t len = chars + 1;
  if (out.size() < len + kOverhead) return Reason::buffer_too_small;
  for (std::size_t i = 0; i < len; ++i) out[3 + i] = static_cast<std::uint8_t>(m.text[i]);
  return finish_frame(address, FlightMode::kType, len, out);
}

std::array<std::uint16_t, RcChannels::kCount> channels_us(const RcChannels& m) noexcept {
  std::array<std::uint16_t, RcChannels::kCount> us{};
  for (std::size_t i = 0; i < RcChannels::kCount; ++i) us[i] = ticks_to_us(m.ticks[i]);
  return us;
}

// ---------------------------------------------------------------------------------------------------------
// StreamDecoder

framing::Verdict StreamDecoder::Rules::check(std::span<const std::uint8_t> c) noexcept {
  using framing::Verdict;
  const std::uint8_t b = c.back();
  if (c.size() == 1) return is_sync_byte(b) ? Verdict::more : Verdict::reject;  // SYNC
  if (c.size() == 2) {                                                           // LEN
    if (b < kMinLength || b > kMaxLength) {
      ++counters.length_errors;
      return Verdict::reject;
    }
    crc = 0;
    return Verdict::more;
  }
  if (c.size() < c[1] + 2U) {  // TYPE or payload
    crc = crc::crc8_dvb_s2_update(crc, b);
    return Verdict::more;
  }
  if (b != crc) {  // the last byte is the CRC
    ++counters.crc_errors;
    return Verdict::reject;
  }
  ++counters.frames;
  if (!is_known_type(c[2])) ++counters.unknown_types;
  return Verdict::frame;
}

Frame StreamDecoder::to_frame(std::span<const std::uint8_t> bytes) noexcept {
  Frame f;  // zero-filled past the payload
  f.address = bytes[0];
  f.type = bytes[2];
  f.payload_size = static_cast<std::uint8_t>(bytes.size() - kOverhead);
  for (std::size_t i = 0; i < f.payload_size; ++i) f.data[i] = bytes[3 + i];
  return f;
}

}  // namespace saul::crsf
