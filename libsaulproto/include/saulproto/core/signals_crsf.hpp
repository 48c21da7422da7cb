// The CRSF frame types the codec decodes (docs/protocol.md §7): big-endian fields, except the RC channel stream
// (little-endian bits). Positions count from the first payload byte after TYPE; the extended types (0x28 on)
// start with destination and origin. Payloads may be longer than described (extra bytes are ignored), so
// MessageDesc::length is a minimum. Codec in crsf.hpp.
#pragma once

#include "saulproto/core/crsf.hpp"
#include "saulproto/core/signals.hpp"

namespace saul::signals::of_crsf {

namespace detail {
/// RC channel i (0-based, CH i+1): stream bits 11i..11i+10, LSB first, in ticks. In microseconds the receivers'
/// map (crsf::ticks_to_us: 172 -> 988, 992 -> 1500, 1811 -> 2012) is the line (ticks - 172) * 1024 / 1639 + 988.5
/// truncated: exactly that for ticks 172..2047, and 1 us more below 172 (they truncate toward zero there). The
/// description holds the line; the test holds its truncation to ticks_to_us for every tick.
constexpr SignalDesc channel(unsigned i) noexcept {
  return number(saul::crsf::kChannelNames[i], ByteOrder::little_endian, 11 * i, 11, Kind::unsigned_int)
      .scaled(1024, 1639)
      .offset_by(988.5 - 172.0 * 1024.0 / 1639.0)
      .in("us");
}
/// A byte meaning -dBm on the wire, shown in dBm (negative).
constexpr SignalDesc rssi(const char* name, unsigned byte) noexcept {
  return be_u(name, byte, 8).scaled(-1, 1).in("dBm").shown(Text::physical_int);
}
}  // namespace detail

inline constexpr SignalDesc kRcChannels[] = {
    detail::channel(0),  detail::channel(1),  detail::channel(2),  detail::channel(3),
    detail::channel(4),  detail::channel(5),  detail::channel(6),  detail::channel(7),
    detail::channel(8),  detail::channel(9),  detail::channel(10), detail::channel(11),
    detail::channel(12), detail::channel(13), detail::channel(14), detail::channel(15),
};

/// rf_mode is TBS's enum on Crossfire, an ELRS rate index on ELRS; uplink_tx_power is an index (crsf::tx_power_mw).
inline constexpr SignalDesc kLinkStatistics[] = {
    detail::rssi("uplink_rssi_1_dbm", 0),
    detail::rssi("uplink_rssi_2_dbm", 1),
    be_u("uplink_link_quality", 2, 8).in("%").valid(0, 100),
    be_i("uplink_snr_db", 3, 8).in("dB"),
    be_u("active_antenna", 4, 8).valid(0, 1),
    be_u("rf_mode", 5, 8),
    be_u("uplink_tx_power", 6, 8).valid(0, 8),
    detail::rssi("downlink_rssi_dbm", 7),
    be_u("downlink_link_quality", 8, 8).in("%").valid(0, 100),
    be_i("downlink_snr_db", 9, 8).in("dB"),
};

/// 0.1 V and 0.1 A as Betaflight, ExpressLRS and EdgeTX send them (the TBS text's 10 uV is taken to be a typo).
inline constexpr SignalDesc kBatterySensor[] = {
    be_u("voltage", 0, 16).as_field("voltage_x10").scaled(1, 10).in("V"),
    be_u("current", 2, 16).as_field("current_x10").scaled(1, 10).in("A"),
    be_u("capacity_mah", 4, 24).in("mAh"),
    be_u("remaining_pct", 7, 8).in("%").valid(0, 100, Check::encoder),
};

/// Altitude travels as metres + 1000; saulctl shows metres.
inline constexpr SignalDesc kGps[] = {
    be_i("latitude", 0, 32).as_field("latitude_e7").scaled(1, 10000000).in("deg").valid(-900000000, 900000000),
    be_i("longitude", 4, 32).as_field("longitude_e7").scaled(1, 10000000).in("deg").valid(-1800000000, 1800000000),
    be_u("groundspeed", 8, 16).as_field("groundspeed_x10").scaled(1, 10).in("km/h"),
    be_u("heading", 10, 16).as_field("heading_x100").scaled(1, 100).in("deg").valid(0, 36000),
    be_u("altitude_m", 12, 16).offset_by(-1000).in("m").shown(Text::physical_int),
    be_u("satellites", 14, 8),
};

/// Radians x 10000 within +-pi; the encoder refuses more.
inline constexpr SignalDesc kAttitude[] = {
    be_i("pitch", 0, 16).as_field("pitch_rad_x10000").scaled(1, 10000).in("rad")
        .valid(-saul::crsf::Attitude::kLimit, saul::crsf::Attitude::kLimit, Check::encoder),
    be_i("roll", 2, 16).as_field("roll_rad_x10000").scaled(1, 10000).in("rad")
        .valid(-saul::crsf::Attitude::kLimit, saul::crsf::Attitude::kLimit, Check::encoder),
    be_i("yaw", 4, 16).as_field("yaw_rad_x10000").scaled(1, 10000).in("rad")
        .valid(-saul::crsf::Attitude::kLimit, saul::crsf::Attitude::kLimit, Check::encoder),
};

inline constexpr SignalDesc kFlightMode[] = {text_field("mode", 0, saul::crsf::FlightMode::kMaxChars)};

/// The sender's address as a 16-bit value (Betaflight sends 00 C8).
inline constexpr SignalDesc kHeartbeat[] = {be_u("origin", 0, 16)};

inline constexpr SignalDesc kDevicePing[] = {be_u("destination", 0, 8), be_u("origin", 1, 8)};

/// The numbers after the name start at the byte after its NUL.
inline constexpr SignalDesc kDeviceInfo[] = {
    be_u("destination", 0, 8),
    be_u("origin", 1, 8),
    text_field("name", 2, saul::crsf::DeviceInfo::kMaxNameChars),
    be_u("serial_number", 0, 32).at(Place::after_string),
    be_u("hardware_id", 4, 32).at(Place::after_string),
    be_u("firmware_id", 8, 32).at(Place::after_string),
    be_u("parameters_total", 12, 8).at(Place::after_string),
    be_u("parameter_version", 13, 8).at(Place::after_string),
};

namespace detail {
/// Subset channel i (CH i+1) where the frame's header puts it, in microseconds: value x 2^(10 - resolution) + 988
/// (crsf::SubsetRcChannels::us), a multiple of 1/8 us (13 bits), shown as that physical value. Its wire integer's
/// scale changes with the resolution, so none is kept under a _raw key.
constexpr SignalDesc subset_channel(unsigned i) noexcept {
  return number(saul::crsf::kChannelNames32[i], ByteOrder::little_endian, 0, 13, Kind::unsigned_int)
      .at(Place::by_header)
      .scaled(1, 8)
      .offset_by(988)
      .in("us")
      .shown(Text::physical);
}
}  // namespace detail

/// Byte 0: the first channel (bits 0-4, 0 = CH1, shown 1-based), the resolution (bits 5-6: 10..13 bits), the
/// digital-switch flag (bit 7); then the channels it carries, from the first one, as many as the payload holds.
inline constexpr SignalDesc kSubsetRcChannels[] = {
    number("first_channel", ByteOrder::little_endian, 0, 5, Kind::unsigned_int).offset_by(1).shown(Text::physical_int),
    number("resolution_bits", ByteOrder::little_endian, 5, 2, Kind::unsigned_int).offset_by(10)
        .shown(Text::physical_int),
    number("digital_switch", ByteOrder::little_endian, 7, 1, Kind::unsigned_int),
    detail::subset_channel(0),  detail::subset_channel(1),  detail::subset_channel(2),  detail::subset_channel(3),
    detail::subset_channel(4),  detail::subset_channel(5),  detail::subset_channel(6),  detail::subset_channel(7),
    detail::subset_channel(8),  detail::subset_channel(9),  detail::subset_channel(10), detail::subset_channel(11),
    detail::subset_channel(12), detail::subset_channel(13), detail::subset_channel(14), detail::subset_channel(15),
    detail::subset_channel(16), detail::subset_channel(17), detail::subset_channel(18), detail::subset_channel(19),
    detail::subset_channel(20), detail::subset_channel(21), detail::subset_channel(22), detail::subset_channel(23),
    detail::subset_channel(24), detail::subset_channel(25), detail::subset_channel(26), detail::subset_channel(27),
    detail::subset_channel(28), detail::subset_channel(29), detail::subset_channel(30), detail::subset_channel(31),
};

namespace detail {
/// The fewest payload bytes: the struct's kPayloadSize, or `least` for the types with a string.
template <class M>
constexpr MessageDesc message(const char* from, const char* to, std::span<const SignalDesc> s,
                              std::size_t least = 0) noexcept {
  if constexpr (requires { M::kPayloadSize; }) least = M::kPayloadSize;
  return describe<M>(Protocol::crsf, static_cast<std::uint32_t>(M::kType), least, false, from, to, s);
}
}  // namespace detail

/// In the order of crsf::Message. "RX" is the RC receiver (or TX module), "IO" the IO board.
inline constexpr MessageDesc kMessages[] = {
    detail::message<saul::crsf::RcChannels>("RX", "IO", kRcChannels),
    detail::message<saul::crsf::LinkStatistics>("RX", "IO", kLinkStatistics),
    detail::message<saul::crsf::BatterySensor>("IO", "RX", kBatterySensor),
    detail::message<saul::crsf::Gps>("IO", "RX", kGps),
    detail::message<saul::crsf::Attitude>("IO", "RX", kAttitude),
    detail::message<saul::crsf::FlightMode>("IO", "RX", kFlightMode, 1),  // the NUL of an empty mode
    detail::message<saul::crsf::Heartbeat>("RX", "IO", kHeartbeat),
    detail::message<saul::crsf::DevicePing>("RX", "IO", kDevicePing),
    detail::message<saul::crsf::DeviceInfo>("RX", "IO", kDeviceInfo,
                                            2 + 1 + saul::crsf::DeviceInfo::kFixedSize),  // empty name
    detail::message<saul::crsf::SubsetRcChannels>("RX", "IO", kSubsetRcChannels, 1),  // the header, no channel
};

}  // namespace saul::signals::of_crsf
