// CRSF, the serial protocol of TBS Crossfire and ExpressLRS receivers (UART0 Crossfire, UART2 ELRS on the IO
// board; 420000 baud 8N1 non-inverted by default, 416666 for TBS hardware: docs/protocol.md, CRSF).
//
// Frame: [SYNC][LEN][TYPE][PAYLOAD x (LEN - 2)][CRC8]
//   SYNC  0xC8 on a receiver's serial port (the flight controller's address); see is_sync_byte();
//   LEN   bytes after itself = TYPE + PAYLOAD + CRC, 2..62, so a frame is 4..64 bytes;
//   CRC8  CRC-8/DVB-S2 (poly 0xD5) over TYPE and PAYLOAD, not over SYNC or LEN.
// Payload fields are big-endian, except the RC channel bit stream (little-endian bit order). Types >= 0x28
// have an extended header: the payload starts with destination and origin addresses.
//
// A frame may be longer than this code expects (a newer protocol revision appends fields): every decoder
// reads the fields it knows and ignores the rest. Shorter than the known fields is bad_length.
//
// Everything here is O(frame size) or better, allocation-free and exception-free; the StreamDecoder holds
// one 64-byte frame buffer, a running CRC and its counters (96 bytes in all).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <variant>

#include "saulproto/core/result.hpp"
#include "saulproto/core/stream_framer.hpp"

namespace saul::crsf {

/// Device addresses (tbs-crsf-spec, device addresses). The first byte of a frame is one of them.
namespace address {
inline constexpr std::uint8_t kBroadcast = 0x00;
inline constexpr std::uint8_t kFlightController = 0xC8;  ///< also "the" sync byte: what receivers send us
inline constexpr std::uint8_t kRadio = 0xEA;             ///< handset
inline constexpr std::uint8_t kReceiver = 0xEC;
inline constexpr std::uint8_t kTransmitter = 0xEE;       ///< TX module
}  // namespace address

inline constexpr std::uint8_t kSyncByte = address::kFlightController;

/// The first bytes the decoder accepts as the start of a frame. The spec says a receiver must accept 0xC8,
/// 0x00 and "any device address"; we accept the five that occur on the links we can see: 0xC8 (what every
/// receiver writes to its flight controller, ELRS always), 0x00 (broadcast; Betaflight's captured frames start
/// with it) and the radio, receiver and TX-module addresses (frames on a handset <-> TX-module wire, so a
/// capture of that wire decodes too). Each extra accepted value makes a noise byte a little more likely to
/// open a false candidate; that costs latency, never a frame, because of the resync rule.
constexpr bool is_sync_byte(std::uint8_t b) noexcept {
  return b == address::kFlightController || b == address::kBroadcast || b == address::kRadio ||
         b == address::kReceiver || b == address::kTransmitter;
}

inline constexpr std::uint8_t kMinLength = 2;                  ///< LEN: TYPE + CRC, empty payload
inline constexpr std::uint8_t kMaxLength = 62;                 ///< LEN: frame of 64 bytes
inline constexpr std::size_t kMaxFrameSize = kMaxLength + 2;   ///< 64, SYNC and LEN included
inline constexpr std::size_t kMaxPayload = kMaxLength - 2;     ///< 60, extended header included
inline constexpr std::size_t kOverhead = 4;                    ///< SYNC, LEN, TYPE, CRC

/// Frame types this code decodes. Any other type still comes out of the StreamDecoder as a raw Frame.
enum class Type : std::uint8_t {
  gps = 0x02,
  battery_sensor = 0x08,
  heartbeat = 0x0B,
  link_statistics = 0x14,
  rc_channels_packed = 0x16,
  subset_rc_channels_packed = 0x17,
  attitude = 0x1E,
  flight_mode = 0x21,
  device_ping = 0x28,  ///< extended header
  device_info = 0x29,  ///< extended header
};
const char* to_string(Type type) noexcept;

/// True for a type byte decode() knows.
constexpr bool is_known_type(std::uint8_t type) noexcept {
  switch (static_cast<Type>(type)) {
    case Type::gps:
    case Type::battery_sensor:
    case Type::heartbeat:
    case Type::link_statistics:
    case Type::rc_channels_packed:
    case Type::subset_rc_channels_packed:
    case Type::attitude:
    case Type::flight_mode:
    case Type::device_ping:
    case Type::device_info: return true;
  }
  return false;
}

/// Types from 0x28 on carry [destination][origin] before their payload.
constexpr bool is_extended(std::uint8_t type) noexcept { return type >= 0x28; }

/// One frame whose CRC checked, as the StreamDecoder delivers it: the payload is copied (bytes past
/// payload_size are zero), so the Frame stays valid after the decoder moves on. 63 bytes.
struct Frame {
  std::uint8_t address = 0;       ///< the SYNC byte (0xC8 from a receiver)
  std::uint8_t type = 0;
  std::uint8_t payload_size = 0;  ///< LEN - 2; for extended types this includes destination and origin
  std::array<std::uint8_t, kMaxPayload> data{};
  [[nodiscard]] constexpr std::span<const std::uint8_t> payload() const noexcept {
    return {data.data(), payload_size};
  }
  constexpr bool operator==(const Frame&) const = default;
};

// ---------------------------------------------------------------------------------------------------------
// Messages. Each is a plain struct with kType, kName, fields(visitor) and ==, like every core message.

/// Channel names for fields(): CRSF channel i (0-based) is the handset's CH(i+1).
inline constexpr const char* kChannelNames[16] = {"ch1",  "ch2",  "ch3",  "ch4",  "ch5",  "ch6",  "ch7",  "ch8",
                                                  "ch9",  "ch10", "ch11", "ch12", "ch13", "ch14", "ch15", "ch16"};

/// 0x16 RC_CHANNELS_PACKED: 16 channels x 11 bits in 22 bytes, one little-endian bit stream (channel i is
/// stream bits 11i..11i+10, LSB first; stream bit k is bit k%8 of byte k/8). Values are ticks 0..2047:
/// 172 = 988 us, 992 = 1500 us, 1811 = 2012 us (ticks_to_us). ELRS sends unset channels as 0 and, unless in
/// 16-channel full-resolution mode, puts uplink LQ in ch15 and RSSI in ch16. ELRS may append a status byte
/// after the 22 (its "extended" frame); it is ignored.
struct RcChannels {
  static constexpr Type kType = Type::rc_channels_packed;
  static constexpr const char* kName = "rc_channels";
  static constexpr std::size_t kCount = 16;
  static constexpr std::size_t kPayloadSize = 22;
  std::array<std::uint16_t, kCount> ticks{};
  template <class V> constexpr void fields(V&& v) const {
    for (std::size_t i = 0; i < kCount; ++i) v(kChannelNames[i], ticks[i]);
  }
  constexpr bool operator==(const RcChannels&) const = default;
};

/// Channel names for the subset frame, which can address CH1..CH32.
inline constexpr const char* kChannelNames32[32] = {
    "ch1",  "ch2",  "ch3",  "ch4",  "ch5",  "ch6",  "ch7",  "ch8",  "ch9",  "ch10", "ch11",
    "ch12", "ch13", "ch14", "ch15", "ch16", "ch17", "ch18", "ch19", "ch20", "ch21", "ch22",
    "ch23", "ch24", "ch25", "ch26", "ch27", "ch28", "ch29", "ch30", "ch31", "ch32"};

/// 0x17 SUBSET_RC_CHANNELS_PACKED (tbs-crsf-spec; the spec marks it "discouraged", but some TX modules and
/// receivers send it). Byte 0: starting channel in bits 0-4 (0-based: 0 = CH1), the resolution in bits 5-6
/// (0..3 = 10, 11, 12, 13 bits per channel) and a digital-switch flag in bit 7. Then as many channels as the
/// rest of the payload holds, packed LSB first as in 0x16. The spec's receiver conversion is
/// us = value * S + 988 with S = 1, 1/2, 1/4, 1/8 for 10..13 bits, so values are exact in eighths of a us.
/// Channels past CH32 are ignored. With the digital-switch flag set the spec appends 10-bit switch channels
/// of unstated count after the analogue ones; we cannot tell them apart, so they read as channels (the flag
/// is reported, so a reader knows).
struct SubsetRcChannels {
  static constexpr Type kType = Type::subset_rc_channels_packed;
  static constexpr const char* kName = "rc_channels_subset";
  static constexpr std::size_t kMaxChannels = 32;
  /// Its channels' places depend on byte 0: core/signals describes them as Place::by_header, and fields() gives
  /// the channels this frame carries, so the fields differ frame to frame.
  static constexpr bool kVariableLayout = true;
  std::uint8_t first_channel = 0;  ///< 0-based: 0 = CH1
  std::uint8_t resolution_bits = 11;  ///< 10..13
  bool digital_switch = false;
  std::uint8_t count = 0;  ///< channels present, first_channel + count <= 32
  std::array<std::uint16_t, kMaxChannels> value{};  ///< raw values; value[i] is CH(first_channel + i + 1)
  /// Channel i of this frame in microseconds: value * 2^(10 - resolution_bits) + 988. O(1).
  [[nodiscard]] constexpr double us(std::size_t i) const noexcept {
    return static_cast<double>(value[i]) / static_cast<double>(1U << (resolution_bits - 10U)) + 988.0;
  }
  template <class V> constexpr void fields(V&& v) const {
    v("first_channel", static_cast<std::uint8_t>(first_channel + 1));
    v("resolution_bits", resolution_bits);
    v("digital_switch", digital_switch);
    for (std::size_t i = 0; i < count; ++i) v(kChannelNames32[first_channel + i], us(i));
  }
  constexpr bool operator==(const SubsetRcChannels&) const = default;
};

/// 0x14 LINK_STATISTICS, 10 bytes. The wire carries RSSI as a positive byte meaning -dBm; here it is dBm
/// (negative). rf_mode is TBS's enum (0 = 4 fps, 1 = 50, 2 = 150) on Crossfire but ELRS's own rate index on
/// ELRS: do not interpret it without knowing the transmitter. uplink_tx_power is an index (tx_power_mw()).
struct LinkStatistics {
  static constexpr Type kType = Type::link_statistics;
  static constexpr const char* kName = "link_statistics";
  static constexpr std::size_t kPayloadSize = 10;
  std::int16_t uplink_rssi_1_dbm = 0;
  std::int16_t uplink_rssi_2_dbm = 0;
  std::uint8_t uplink_link_quality = 0;  ///< %
  std::int8_t uplink_snr_db = 0;
  std::uint8_t active_antenna = 0;       ///< 0 = antenna 1, 1 = antenna 2
  std::uint8_t rf_mode = 0;
  std::uint8_t uplink_tx_power = 0;      ///< index: 0 0 mW, 1 10, 2 25, 3 100, 4 500, 5 1000, 6 2000, 7 250, 8 50
  std::int16_t downlink_rssi_dbm = 0;
  std::uint8_t downlink_link_quality = 0;  ///< %
  std::int8_t downlink_snr_db = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("uplink_rssi_1_dbm", uplink_rssi_1_dbm); v("uplink_rssi_2_dbm", uplink_rssi_2_dbm);
    v("uplink_link_quality", uplink_link_quality); v("uplink_snr_db", uplink_snr_db);
    v("active_antenna", active_antenna); v("rf_mode", rf_mode); v("uplink_tx_power", uplink_tx_power);
    v("downlink_rssi_dbm", downlink_rssi_dbm); v("downlink_link_quality", downlink_link_quality);
    v("downlink_snr_db", downlink_snr_db);
  }
  constexpr bool operator==(const LinkStatistics&) const = default;
};

/// Transmit power in mW of a LINK_STATISTICS uplink_tx_power index, or nullopt for an index no one defined.
constexpr std::optional<std::uint16_t> tx_power_mw(std::uint8_t index) noexcept {
  constexpr std::uint16_t table[] = {0, 10, 25, 100, 500, 1000, 2000, 250, 50};
  if (index >= sizeof(table) / sizeof(table[0])) return std::nullopt;
  return table[index];
}

/// 0x08 BATTERY_SENSOR, 8 bytes: u16 voltage, u16 current, u24 capacity used, u8 remaining, big-endian.
/// Units as Betaflight, ExpressLRS and EdgeTX implement them: 0.1 V and 0.1 A. (The TBS spec text says
/// 10 uV / 10 uA and int16; that contradicts all three implementations and is taken to be a typo.)
struct BatterySensor {
  static constexpr Type kType = Type::battery_sensor;
  static constexpr const char* kName = "battery_sensor";
  static constexpr std::size_t kPayloadSize = 8;
  static constexpr std::uint32_t kMaxCapacity = 0xFFFFFF;  ///< 24 bits on the wire
  std::uint16_t voltage_x10 = 0;   ///< V x 10 (168 = 16.8 V)
  std::uint16_t current_x10 = 0;   ///< A x 10
  std::uint32_t capacity_mah = 0;  ///< used, 0..kMaxCapacity
  std::uint8_t remaining_pct = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("voltage_x10", voltage_x10); v("current_x10", current_x10); v("capacity_mah", capacity_mah);
    v("remaining_pct", remaining_pct);
  }
  constexpr bool operator==(const BatterySensor&) const = default;
};

/// 0x02 GPS, 15 bytes, big-endian. groundspeed in 0.1 km/h as Betaflight and ExpressLRS send it (the TBS
/// spec says km/h / 100; we follow the implementations). altitude is sent as metres + 1000; here in metres.
struct Gps {
  static constexpr Type kType = Type::gps;
  static constexpr const char* kName = "gps";
  static constexpr std::size_t kPayloadSize = 15;
  std::int32_t latitude_e7 = 0;       ///< degrees x 1e7, + north
  std::int32_t longitude_e7 = 0;      ///< degrees x 1e7, + east
  std::uint16_t groundspeed_x10 = 0;  ///< km/h x 10
  std::uint16_t heading_x100 = 0;     ///< degrees x 100
  std::int32_t altitude_m = 0;        ///< wire value - 1000, so -1000..64535
  std::uint8_t satellites = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("latitude_e7", latitude_e7); v("longitude_e7", longitude_e7); v("groundspeed_x10", groundspeed_x10);
    v("heading_x100", heading_x100); v("altitude_m", altitude_m); v("satellites", satellites);
  }
  constexpr bool operator==(const Gps&) const = default;
};

/// 0x1E ATTITUDE, 6 bytes: pitch, roll, yaw as int16 big-endian radians x 10000 (in that order), each within
/// +-pi (+-31416). The IO board sends the robot's pitch in it as telemetry.
struct Attitude {
  static constexpr Type kType = Type::attitude;
  static constexpr const char* kName = "attitude";
  static constexpr std::size_t kPayloadSize = 6;
  static constexpr std::int16_t kLimit = 31416;  ///< pi x 10000, rounded up
  std::int16_t pitch_rad_x10000 = 0;
  std::int16_t roll_rad_x10000 = 0;
  std::int16_t yaw_rad_x10000 = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("pitch_rad_x10000", pitch_rad_x10000); v("roll_rad_x10000", roll_rad_x10000);
    v("yaw_rad_x10000", yaw_rad_x10000);
  }
  constexpr bool operator==(const Attitude&) const = default;
};

/// 0x21 FLIGHT_MODE: a NUL-terminated ASCII string ("ACRO", "!FS!"). Up to 59 characters fit a frame; the
/// decoder requires the NUL (truncated without it) and ignores bytes after it. Unused chars are zero.
struct FlightMode {
  static constexpr Type kType = Type::flight_mode;
  static constexpr const char* kName = "flight_mode";
  static constexpr std::size_t kMaxChars = kMaxPayload - 1;  ///< 59
  std::array<char, kMaxChars + 1> text{};
  [[nodiscard]] std::string_view view() const noexcept;
  template <class V> constexpr void fields(V&& v) const { v("mode", static_cast<const char*>(text.data())); }
  constexpr bool operator==(const FlightMode&) const = default;
};

/// A FlightMode holding text; out_of_range if text is longer than 59 characters or contains a NUL.
Result<FlightMode> make_flight_mode(std::string_view text) noexcept;

/// 0x0B HEARTBEAT, 2 bytes: the sender's address as a big-endian 16-bit value (Betaflight sends 00 C8).
struct Heartbeat {
  static constexpr Type kType = Type::heartbeat;
  static constexpr const char* kName = "heartbeat";
  static constexpr std::size_t kPayloadSize = 2;
  std::uint16_t origin = 0;
  template <class V> constexpr void fields(V&& v) const { v("origin", origin); }
  constexpr bool operator==(const Heartbeat&) const = default;
};

/// 0x28 DEVICE_PING (extended header, no payload of its own). destination 0x00 pings every device.
struct DevicePing {
  static constexpr Type kType = Type::device_ping;
  static constexpr const char* kName = "device_ping";
  static constexpr std::size_t kPayloadSize = 2;
  std::uint8_t destination = 0;
  std::uint8_t origin = 0;
  template <class V> constexpr void fields(V&& v) const { v("destination", destination); v("origin", origin); }
  constexpr bool operator==(const DevicePing&) const = default;
};

/// 0x29 DEVICE_INFO (extended header): NUL-terminated name, u32 serial number, u32 hardware id, u32 firmware
/// id, u8 parameter count, u8 parameter protocol version, big-endian. ELRS devices send serial 'ELRS'
/// (0x454C5253). The name takes at most 43 characters (60 payload bytes - 2 addresses - NUL - 14).
struct DeviceInfo {
  static constexpr Type kType = Type::device_info;
  static constexpr const char* kName = "device_info";
  static constexpr std::size_t kFixedSize = 14;  ///< the fields after the name's NUL
  static constexpr std::size_t kMaxNameChars = kMaxPayload - 2 - 1 - kFixedSize;  ///< 43
  static constexpr std::uint32_t kElrsSerial = 0x454C5253;                         ///< "ELRS"
  std::uint8_t destination = 0;
  std::uint8_t origin = 0;
  std::array<char, kMaxNameChars + 1> name{};
  std::uint32_t serial_number = 0;
  std::uint32_t hardware_id = 0;
  std::uint32_t firmware_id = 0;
  std::uint8_t parameters_total = 0;
  std::uint8_t parameter_version = 0;
  template <class V> constexpr void fields(V&& v) const {
    v("destination", destination); v("origin", origin); v("name", static_cast<const char*>(name.data()));
    v("serial_number", serial_number); v("hardware_id", hardware_id); v("firmware_id", firmware_id);
    v("parameters_total", parameters_total); v("parameter_version", parameter_version);
  }
  constexpr bool operator==(const DeviceInfo&) const = default;
};

using Message = std::variant<RcChannels, LinkStatistics, BatterySensor, Gps, Attitude, FlightMode, Heartbeat,
                             DevicePing, DeviceInfo, SubsetRcChannels>;

Type type_of(const Message& message) noexcept;
const char* name_of(const Message& message) noexcept;

/// Decodes a frame's payload by its type. unknown_type for a type not in Type; bad_length when the payload
/// is shorter than the type's fields; truncated when a DEVICE_INFO / FLIGHT_MODE string has no NUL.
/// Longer payloads are accepted and the extra bytes ignored. O(payload), no allocation.
Result<Message> decode_payload(std::uint8_t type, std::span<const std::uint8_t> payload) noexcept;
inline Result<Message> decode(const Frame& frame) noexcept { return decode_payload(frame.type, frame.payload()); }

// ---------------------------------------------------------------------------------------------------------
// Encoders. Each writes one whole frame (SYNC..CRC) into out and returns its size, or buffer_too_small /
// out_of_range. kMaxFrameSize bytes always suffice. O(frame size).

/// Any frame: [address][payload.size() + 2][type][payload][CRC]. out_of_range if payload > 60 bytes.
Result<std::size_t> encode_frame(std::uint8_t address, std::uint8_t type, std::span<const std::uint8_t> payload,
                                 std::span<std::uint8_t> out) noexcept;

/// For simulation: a receiver's RC frame (26 bytes). out_of_range if a channel exceeds 2047.
Result<std::size_t> encode(const RcChannels& m, std::span<std::uint8_t> out,
                           std::uint8_t address = kSyncByte) noexcept;
/// IO-board telemetry (12 bytes). out_of_range if capacity_mah exceeds 24 bits or remaining_pct 100.
Result<std::size_t> encode(const BatterySensor& m, std::span<std::uint8_t> out,
                           std::uint8_t address = kSyncByte) noexcept;
/// IO-board telemetry (10 bytes). out_of_range if an angle is outside +-kLimit.
Result<std::size_t> encode(const Attitude& m, std::span<std::uint8_t> out,
                           std::uint8_t address = kSyncByte) noexcept;
/// IO-board telemetry (5 + length of the text bytes). out_of_range if text has no NUL.
Result<std::size_t> encode(const FlightMode& m, std::span<std::uint8_t> out,
                           std::uint8_t address = kSyncByte) noexcept;

// ---------------------------------------------------------------------------------------------------------
// Channel value conversion, as ExpressLRS (CRSF_to_US) and Betaflight compute it: a rounded linear map with
// 172 -> 988 us, 992 -> 1500 us, 1811 -> 2012 us, in integers with C's truncating division:
//     us = ((ticks - 172) * 1024 * 2 / 1639 + 988 * 2 + 1) / 2
// It gives 0 -> 881 and 2047 -> 2159. The TBS spec's (ticks - 992) * 5 / 8 + 1500 differs by up to 1 us
// (2011 at 1811); we follow the receivers. O(1).

inline constexpr std::uint16_t kTicksMin = 172;   ///< 988 us
inline constexpr std::uint16_t kTicksMid = 992;   ///< 1500 us
inline constexpr std::uint16_t kTicksMax = 1811;  ///< 2012 us
inline constexpr std::uint16_t kTicksLimit = 2047;

constexpr std::uint16_t ticks_to_us(std::uint16_t ticks) noexcept {
  const std::int32_t d = (static_cast<std::int32_t>(ticks) - 172) * 1024 * 2 / 1639;
  return static_cast<std::uint16_t>((d + 988 * 2 + 1) / 2);
}

/// The inverse: the tick value whose ticks_to_us() is us, for every us in 881..2159 (so
/// ticks_to_us(us_to_ticks(us)) == us); below that 0, above it 2047. 988 -> 172, 1500 -> 992, 2012 -> 1811,
/// 1000 -> 191 (the spec's integer inverse says 192). A rounded linear estimate, then at most one step of
/// correction (the truncation in ticks_to_us shifts values below 988 us by one). O(1).
constexpr std::uint16_t us_to_ticks(std::uint16_t us) noexcept {
  if (us <= 881) return 0;
  if (us >= 2159) return kTicksLimit;
  std::int32_t t = ((static_cast<std::int32_t>(us) - 988) * 1639 * 2 + 1024);
  t = (t >= 0 ? t / 2048 : -((-t + 2047) / 2048)) + 172;  // floor division: nearest tick
  while (t < kTicksLimit && ticks_to_us(static_cast<std::uint16_t>(t)) < us) ++t;
  while (t > 0 && ticks_to_us(static_cast<std::uint16_t>(t)) > us) --t;
  return static_cast<std::uint16_t>(t);
}

/// All 16 channels of an RC frame in microseconds (index 0 = CH1), for rc::map_channels().
std::array<std::uint16_t, RcChannels::kCount> channels_us(const RcChannels& m) noexcept;

// ---------------------------------------------------------------------------------------------------------
// Streaming decoder.

/// What the decoder has seen since construction or reset(). Every byte pushed ends up in exactly one of:
/// a delivered frame, bytes_skipped, or pending().
struct Counters {
  std::uint32_t frames = 0;         ///< frames delivered (CRC good), unknown types included
  std::uint32_t crc_errors = 0;     ///< candidates whose CRC did not match
  std::uint32_t length_errors = 0;  ///< LEN outside 2..62
  std::uint32_t unknown_types = 0;  ///< delivered frames whose type decode() does not know (also in frames)
  std::uint32_t bytes_skipped = 0;  ///< bytes in no frame: noise, and the SYNC byte of every rejected candidate
  std::uint32_t incomplete = 0;     ///< unfinished candidates given up by flush()
  constexpr bool operator==(const Counters&) const = default;
};

/// Feed bytes as they arrive; every valid frame is handed to on_frame(const Frame&).
///
/// 1. Hunt for a SYNC byte (is_sync_byte); other bytes are skipped.
/// 2. LEN must be 2..62 (length error).
/// 3. After LEN bytes, the CRC-8/DVB-S2 of TYPE and PAYLOAD must equal the last byte (CRC error). The CRC is
///    folded in as bytes arrive, so checking it costs nothing extra.
/// 4. After any rejection the hunt resumes at the byte right after the rejected SYNC byte: the rest of the
///    candidate is scanned again, so a real frame that began inside a false candidate (a noise 0xC8 with a
///    large LEN swallowing real frames) is still found (framing::StreamFramer, stream_framer.hpp). A rescan
///    can find several frames, which is why the decoder calls back rather than returning one frame per byte.
/// Cost: a byte is scanned again only by candidates that start before it, at most 63 bytes earlier and each
/// later than the last, so at most 64 times: O(1) amortised per byte (O(64^2) for the worst single push).
/// No allocation; safe in an ISR if the caller owns the object; not thread-safe.
class StreamDecoder {
 public:
  /// Feeds one byte; calls on_frame(const Frame&) for every frame it completes (usually none or one). The
  /// Frame reference is valid during the call only; copy it to keep it.
  template <class F>
  void push(std::uint8_t byte, F&& on_frame) noexcept {
    framer_.push(byte, rules_, deliver(on_frame));
  }

  /// Feeds many bytes. O(n).
  template <class F>
  void push(std::span<const std::uint8_t> input, F&& on_frame) noexcept {
    for (std::uint8_t b : input) push(b, on_frame);
  }

  /// Gives up the unfinished candidate (counted in incomplete, its SYNC byte skipped) and rescans what
  /// followed it, until nothing is pending; frames found on the way are delivered. For the end of a capture,
  /// or when the line has been idle for longer than a frame takes (Betaflight resets after 1748 us), since
  /// a receiver sends each frame back to back. O(pending^2) at worst.
  template <class F>
  void flush(F&& on_frame) noexcept {
    while (framer_.pending() > 0) {
      ++rules_.counters.incomplete;
      framer_.abandon(rules_, deliver(on_frame));
    }
  }

  [[nodiscard]] const Counters& counters() const noexcept { return rules_.counters; }
  /// Bytes held: an unfinished candidate (after a push, everything held has been scanned).
  [[nodiscard]] std::size_t pending() const noexcept { return framer_.pending(); }
  /// Forgets everything, counters included.
  void reset() noexcept { *this = StreamDecoder{}; }

 private:
  // SYNC, LEN, then the CRC-8/DVB-S2 folded in byte by byte and compared with the last byte.
  struct Rules : framing::CountedRules<Counters> {
    std::uint8_t crc = 0;  // over TYPE and the payload checked so far; restarts at LEN
    framing::Verdict check(std::span<const std::uint8_t> candidate) noexcept;
  };
  // A frame's bytes (SYNC..CRC) as a Frame, which stays valid after the framer drops them.
  static Frame to_frame(std::span<const std::uint8_t> bytes) noexcept;
  template <class F>
  static auto deliver(F& on_frame) noexcept {
    return [&on_frame](std::span<const std::uint8_t> bytes) {
      const Frame frame = to_frame(bytes);
      on_frame(frame);
    };
  }

  framing::StreamFramer<kMaxFrameSize> framer_;
  Rules rules_;
};

}  // namespace saul::crsf
