// The VESC motor controllers' own CAN protocol ("VESC" CAN mode), as BALANCE and the robot's two VESCs use it.
//
//   29-bit extended ids only:  eid = (command << 8) | controller_id
//     bits 28..16  0 (a frame with any of them set is not a VESC frame: unknown_id)
//     bits 15..8   command (CAN_PACKET_ID of the VESC firmware, enum Command below)
//     bits  7..0   the target controller for set commands and PING, the sender for STATUS frames,
//                  the addressee (the pinger) for PONG; 255 addresses every VESC
//   Payloads are big-endian two's complement. A "scaled" field carries trunc(value × scale) as an integer.
//
//   command            id  DLC  payload                                   scale
//   SET_DUTY            0   4   int32 duty cycle, -1..1                   100000
//   SET_CURRENT         1   4   int32 motor current, A                    1000
//   SET_CURRENT_BRAKE   2   4   int32 brake current, A                    1000
//   SET_RPM             3   4   int32 electrical RPM (ERPM)               1
//   SET_POS             4   4   int32 position, degrees                   1000000
//   SET_CURRENT_REL    10   4   int32 fraction of the current limit       100000
//   STATUS (_1)         9   8   int32 ERPM, int16 current A ×10, int16 duty ×1000
//   STATUS_2           14   8   int32 Ah used ×10000, int32 Ah charged ×10000
//   STATUS_3           15   8   int32 Wh used ×10000, int32 Wh charged ×10000
//   STATUS_4           16   8   int16 FET °C ×10, motor °C ×10, input current A ×10, PID position deg ×50
//   STATUS_5           27   8   int32 tachometer, int16 input voltage V ×10, 2 reserved bytes (0)
//   STATUS_6           58   8   int16 ADC1 V ×1000, ADC2 ×1000, ADC3 ×1000, PPM input ×1000 (-1..1)
//   PING               17   1   uint8 sender's controller id
//   PONG               18   2   uint8 responder's controller id, uint8 hardware type
//
// Every message is a plain struct holding the integers exactly as they are on the wire (so encode(decode(f))
// gives f back bit for bit and == compares wire content), with float accessors that scale them the way the
// VESC firmware itself does on receipt ((float)raw / scale). The set commands also have a from() that converts
// a physical value with the firmware's truncation; see to_fixed_i32().
//
// Decoders accept only the exact DLC of the table. That rejects the optional 6-byte SET_CURRENT and
// SET_CURRENT_REL forms (an int16 off-delay appended): the VESC firmware changed which end of SET_CURRENT the
// off-delay sits at (docs/sections/vesc.md, open questions), so a 6-byte frame cannot be read unambiguously.
// Other VESC commands (buffer transfers, CONF_*, BMS_*, ...) are reported as unknown_id.
//
// All functions are O(1), allocation-free and never throw. Sources: vedderb/bldc comm/comm_can.c,
// datatypes.h, util/buffer.c (facts, not code).
#pragma once

#include <cstdint>
#include <variant>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/result.hpp"

namespace saul::vesc {

/// The robot's controllers (set in VESC Tool, App Settings -> General -> VESC ID).
inline constexpr std::uint8_t kLeftId = 68;    ///< 0x44
inline constexpr std::uint8_t kRightId = 56;   ///< 0x38
inline constexpr std::uint8_t kBroadcastId = 255;  ///< every VESC on the bus acts on a command sent to 255

/// CAN_PACKET_ID values this codec knows (bldc datatypes.h). The enum names the command byte of the id.
enum class Command : std::uint8_t {
  set_duty = 0,
  set_current = 1,
  set_current_brake = 2,
  set_rpm = 3,
  set_pos = 4,
  status_1 = 9,  ///< CAN_PACKET_STATUS
  set_current_rel = 10,
  status_2 = 14,
  status_3 = 15,
  status_4 = 16,
  ping = 17,
  pong = 18,
  status_5 = 27,
  status_6 = 58,
};

/// "set_rpm", "status_1", ...; "?" for a value outside the enum. Found by ADL from saul::vesc.
const char* to_string(Command command) noexcept;

/// PONG hardware type byte (bldc HW_TYPE).
namespace hw_type {
inline constexpr std::uint8_t kVesc = 0;
inline constexpr std::uint8_t kVescBms = 1;
inline constexpr std::uint8_t kCustomModule = 2;
}  // namespace hw_type

/// The 29-bit id of a command to (or a status from) one controller.
constexpr std::uint32_t make_eid(Command command, std::uint8_t controller_id) noexcept {
  return (static_cast<std::uint32_t>(command) << 8) | controller_id;
}
/// Bits 7..0 of an id.
constexpr std::uint8_t controller_of(std::uint32_t eid) noexcept { return static_cast<std::uint8_t>(eid & 0xFFU); }
/// Bits 28..8 of an id: the command, or a value above 255 when one of the unused bits 28..16 is set.
constexpr std::uint32_t command_of(std::uint32_t eid) noexcept { return eid >> 8; }

/// trunc(value × scale) as an int32, computed in double: what the VESC firmware's own senders do
/// (comm_can.c: `(int32_t)(duty * 100000.0)` with a float duty, i.e. a float widened to double and multiplied by
/// a double constant; buffer.c buffer_append_float32 is the same cast). Truncation is toward zero, not rounding:
/// 0.29F (= 0.2899999917) × 100000 gives 28999. For a float argument the double product is exact (24-bit by at
/// most 20-bit mantissas), so the result does not depend on the FPU. NaN or infinity: not_finite; a product
/// outside int32: out_of_range (the firmware's cast is undefined there). O(1); soft-float double on an FPU-less
/// or single-precision core, which is why the hot path (SetRpm, raw fields) never needs it.
constexpr Result<std::int32_t> to_fixed_i32(double value, double scale) noexcept {
  if (value - value != 0.0) return Reason::not_finite;  // NaN or +-inf: inf - inf is NaN
  const double x = value * scale;
  if (!(x > -2147483649.0 && x < 2147483648.0)) return Reason::out_of_range;
  return static_cast<std::int32_t>(x);
}
/// Same for an int16 field (bldc buffer_append_float16; status frames).
constexpr Result<std::int16_t> to_fixed_i16(double value, double scale) noexcept {
  if (value - value != 0.0) return Reason::not_finite;
  const double x = value * scale;
  if (!(x > -32769.0 && x < 32768.0)) return Reason::out_of_range;
  return static_cast<std::int16_t>(x);
}

namespace detail {
/// raw / scale in double, for printing: text and JSON then show the decimal the integer stands for (0.1, not the
/// float 0.100000001). Only the host formatters instantiate fields(), so firmware never pulls in double maths.
constexpr double unscale(std::int32_t raw, double scale) noexcept { return static_cast<double>(raw) / scale; }

template <class T>
constexpr Result<T> with_fixed(std::uint8_t id, double value, double scale) noexcept {
  const auto raw = to_fixed_i32(value, scale);
  if (!raw) return raw.reason();
  return T{id, raw.value()};
}
}  // namespace detail

// ---- set commands (to controller_id), DLC 4 ----

/// SET_DUTY: duty cycle -1..1 (the VESC clamps to its configured limits).
struct SetDuty {
  static constexpr Command kCommand = Command::set_duty;
  static constexpr std::uint8_t kDlc = 4;
  static constexpr const char* kName = "vesc_set_duty";
  static constexpr double kScale = 100000.0;
  std::uint8_t controller_id = 0;
  std::int32_t duty_x100000 = 0;
  [[nodiscard]] constexpr float duty() const noexcept { return static_cast<float>(duty_x100000) / 100000.0F; }
  /// From a duty cycle, truncated like the firmware (to_fixed_i32).
  static constexpr Result<SetDuty> from(std::uint8_t id, double value) noexcept {
    return detail::with_fixed<SetDuty>(id, value, kScale);
  }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("duty", detail::unscale(duty_x100000, kScale));
  }
  constexpr bool operator==(const SetDuty&) const = default;
};

/// SET_CURRENT: motor current in A (negative = reverse torque).
struct SetCurrent {
  static constexpr Command kCommand = Command::set_current;
  static constexpr std::uint8_t kDlc = 4;
  static constexpr const char* kName = "vesc_set_current";
  static constexpr double kScale = 1000.0;
  std::uint8_t controller_id = 0;
  std::int32_t current_x1000 = 0;  ///< mA
  [[nodiscard]] constexpr float current() const noexcept { return static_cast<float>(current_x1000) / 1000.0F; }
  static constexpr Result<SetCurrent> from(std::uint8_t id, double amps) noexcept {
    return detail::with_fixed<SetCurrent>(id, amps, kScale);
  }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("current_a", detail::unscale(current_x1000, kScale));
  }
  constexpr bool operator==(const SetCurrent&) const = default;
};

/// SET_CURRENT_BRAKE: braking current in A.
struct SetCurrentBrake {
  static constexpr Command kCommand = Command::set_current_brake;
  static constexpr std::uint8_t kDlc = 4;
  static constexpr const char* kName = "vesc_set_current_brake";
  static constexpr double kScale = 1000.0;
  std::uint8_t controller_id = 0;
  std::int32_t current_x1000 = 0;  ///< mA
  [[nodiscard]] constexpr float current() const noexcept { return static_cast<float>(current_x1000) / 1000.0F; }
  static constexpr Result<SetCurrentBrake> from(std::uint8_t id, double amps) noexcept {
    return detail::with_fixed<SetCurrentBrake>(id, amps, kScale);
  }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("current_a", detail::unscale(current_x1000, kScale));
  }
  constexpr bool operator==(const SetCurrentBrake&) const = default;
};

/// SET_RPM: electrical RPM = mechanical RPM × motor pole pairs (scale 1, so no conversion is needed).
struct SetRpm {
  static constexpr Command kCommand = Command::set_rpm;
  static constexpr std::uint8_t kDlc = 4;
  static constexpr const char* kName = "vesc_set_rpm";
  std::uint8_t controller_id = 0;
  std::int32_t erpm = 0;
  template <class V> constexpr void fields(V&& v) const { v("controller_id", controller_id); v("erpm", erpm); }
  constexpr bool operator==(const SetRpm&) const = default;
};

/// SET_POS: position in degrees 0..360 (position PID).
struct SetPos {
  static constexpr Command kCommand = Command::set_pos;
  static constexpr std::uint8_t kDlc = 4;
  static constexpr const char* kName = "vesc_set_pos";
  static constexpr double kScale = 1000000.0;
  std::uint8_t controller_id = 0;
  std::int32_t pos_x1000000 = 0;  ///< micro-degrees
  [[nodiscard]] constexpr float pos() const noexcept { return static_cast<float>(pos_x1000000) / 1000000.0F; }
  static constexpr Result<SetPos> from(std::uint8_t id, double degrees) noexcept {
    return detail::with_fixed<SetPos>(id, degrees, kScale);
  }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("pos_deg", detail::unscale(pos_x1000000, kScale));
  }
  constexpr bool operator==(const SetPos&) const = default;
};

/// SET_CURRENT_REL: current as a fraction -1..1 of the configured current limits.
struct SetCurrentRel {
  static constexpr Command kCommand = Command::set_current_rel;
  static constexpr std::uint8_t kDlc = 4;
  static constexpr const char* kName = "vesc_set_current_rel";
  static constexpr double kScale = 100000.0;
  std::uint8_t controller_id = 0;
  std::int32_t current_rel_x100000 = 0;
  [[nodiscard]] constexpr float current_rel() const noexcept {
    return static_cast<float>(current_rel_x100000) / 100000.0F;
  }
  /// Note: the firmware's own sender for this command multiplies in float (buffer_append_float32 with a float
  /// scale), which can round a product just below an integer up to it before truncating; from() uses the exact
  /// product, like the other set commands. The two differ by at most one unit (1e-5) and only in such cases.
  static constexpr Result<SetCurrentRel> from(std::uint8_t id, double fraction) noexcept {
    return detail::with_fixed<SetCurrentRel>(id, fraction, kScale);
  }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("current_rel", detail::unscale(current_rel_x100000, kScale));
  }
  constexpr bool operator==(const SetCurrentRel&) const = default;
};

// ---- status frames (from controller_id), DLC 8; off by default on a VESC, enabled per frame in VESC Tool ----

/// STATUS (1): ERPM, filtered total motor current, duty cycle now.
struct Status1 {
  static constexpr Command kCommand = Command::status_1;
  static constexpr std::uint8_t kDlc = 8;
  static constexpr const char* kName = "vesc_status_1";
  std::uint8_t controller_id = 0;
  std::int32_t erpm = 0;
  std::int16_t current_x10 = 0;  ///< A × 10
  std::int16_t duty_x1000 = 0;
  [[nodiscard]] constexpr float current() const noexcept { return static_cast<float>(current_x10) / 10.0F; }
  [[nodiscard]] constexpr float duty() const noexcept { return static_cast<float>(duty_x1000) / 1000.0F; }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("erpm", erpm); v("current_a", detail::unscale(current_x10, 10.0));
    v("duty", detail::unscale(duty_x1000, 1000.0));
  }
  constexpr bool operator==(const Status1&) const = default;
};

/// STATUS_2: charge drawn from and returned to the battery since power-on.
struct Status2 {
  static constexpr Command kCommand = Command::status_2;
  static constexpr std::uint8_t kDlc = 8;
  static constexpr const char* kName = "vesc_status_2";
  std::uint8_t controller_id = 0;
  std::int32_t ah_used_x10000 = 0;
  std::int32_t ah_charged_x10000 = 0;
  [[nodiscard]] constexpr float ah_used() const noexcept { return static_cast<float>(ah_used_x10000) / 10000.0F; }
  [[nodiscard]] constexpr float ah_charged() const noexcept {
    return static_cast<float>(ah_charged_x10000) / 10000.0F;
  }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("ah_used", detail::unscale(ah_used_x10000, 10000.0));
    v("ah_charged", detail::unscale(ah_charged_x10000, 10000.0));
  }
  constexpr bool operator==(const Status2&) const = default;
};

/// STATUS_3: energy drawn from and returned to the battery since power-on.
struct Status3 {
  static constexpr Command kCommand = Command::status_3;
  static constexpr std::uint8_t kDlc = 8;
  static constexpr const char* kName = "vesc_status_3";
  std::uint8_t controller_id = 0;
  std::int32_t wh_used_x10000 = 0;
  std::int32_t wh_charged_x10000 = 0;
  [[nodiscard]] constexpr float wh_used() const noexcept { return static_cast<float>(wh_used_x10000) / 10000.0F; }
  [[nodiscard]] constexpr float wh_charged() const noexcept {
    return static_cast<float>(wh_charged_x10000) / 10000.0F;
  }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("wh_used", detail::unscale(wh_used_x10000, 10000.0));
    v("wh_charged", detail::unscale(wh_charged_x10000, 10000.0));
  }
  constexpr bool operator==(const Status3&) const = default;
};

/// STATUS_4: temperatures, filtered input (battery) current, PID position.
struct Status4 {
  static constexpr Command kCommand = Command::status_4;
  static constexpr std::uint8_t kDlc = 8;
  static constexpr const char* kName = "vesc_status_4";
  std::uint8_t controller_id = 0;
  std::int16_t temp_fet_x10 = 0;    ///< °C × 10
  std::int16_t temp_motor_x10 = 0;  ///< °C × 10
  std::int16_t current_in_x10 = 0;  ///< A × 10
  std::int16_t pid_pos_x50 = 0;     ///< degrees × 50
  [[nodiscard]] constexpr float temp_fet() const noexcept { return static_cast<float>(temp_fet_x10) / 10.0F; }
  [[nodiscard]] constexpr float temp_motor() const noexcept { return static_cast<float>(temp_motor_x10) / 10.0F; }
  [[nodiscard]] constexpr float current_in() const noexcept { return static_cast<float>(current_in_x10) / 10.0F; }
  [[nodiscard]] constexpr float pid_pos() const noexcept { return static_cast<float>(pid_pos_x50) / 50.0F; }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("temp_fet_c", detail::unscale(temp_fet_x10, 10.0));
    v("temp_motor_c", detail::unscale(temp_motor_x10, 10.0)); v("current_in_a", detail::unscale(current_in_x10, 10.0));
    v("pid_pos_deg", detail::unscale(pid_pos_x50, 50.0));
  }
  constexpr bool operator==(const Status4&) const = default;
};

/// STATUS_5: tachometer and filtered input voltage. The tachometer counts 6 steps per electrical revolution
/// (mechanical revolutions = tachometer / (6 × pole pairs)). Bytes 6..7 are reserved: sent 0, ignored on receipt.
struct Status5 {
  static constexpr Command kCommand = Command::status_5;
  static constexpr std::uint8_t kDlc = 8;
  static constexpr const char* kName = "vesc_status_5";
  std::uint8_t controller_id = 0;
  std::int32_t tachometer = 0;
  std::int16_t voltage_in_x10 = 0;  ///< V × 10
  [[nodiscard]] constexpr float voltage_in() const noexcept { return static_cast<float>(voltage_in_x10) / 10.0F; }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("tachometer", tachometer);
    v("voltage_in_v", detail::unscale(voltage_in_x10, 10.0));
  }
  constexpr bool operator==(const Status5&) const = default;
};

/// STATUS_6: the three ADC inputs in volts and the decoded PPM (servo) input -1..1.
struct Status6 {
  static constexpr Command kCommand = Command::status_6;
  static constexpr std::uint8_t kDlc = 8;
  static constexpr const char* kName = "vesc_status_6";
  std::uint8_t controller_id = 0;
  std::int16_t adc1_x1000 = 0;  ///< mV
  std::int16_t adc2_x1000 = 0;  ///< mV
  std::int16_t adc3_x1000 = 0;  ///< mV
  std::int16_t ppm_x1000 = 0;
  [[nodiscard]] constexpr float adc1() const noexcept { return static_cast<float>(adc1_x1000) / 1000.0F; }
  [[nodiscard]] constexpr float adc2() const noexcept { return static_cast<float>(adc2_x1000) / 1000.0F; }
  [[nodiscard]] constexpr float adc3() const noexcept { return static_cast<float>(adc3_x1000) / 1000.0F; }
  [[nodiscard]] constexpr float ppm() const noexcept { return static_cast<float>(ppm_x1000) / 1000.0F; }
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("adc1_v", detail::unscale(adc1_x1000, 1000.0));
    v("adc2_v", detail::unscale(adc2_x1000, 1000.0)); v("adc3_v", detail::unscale(adc3_x1000, 1000.0));
    v("ppm", detail::unscale(ppm_x1000, 1000.0));
  }
  constexpr bool operator==(const Status6&) const = default;
};

// ---- PING / PONG ----

/// PING to controller_id; the payload names the sender, which the target answers with a PONG within ~10 ms.
struct Ping {
  static constexpr Command kCommand = Command::ping;
  static constexpr std::uint8_t kDlc = 1;
  static constexpr const char* kName = "vesc_ping";
  std::uint8_t controller_id = 0;  ///< the controller asked
  std::uint8_t sender_id = 0;
  template <class V> constexpr void fields(V&& v) const { v("controller_id", controller_id); v("sender_id", sender_id); }
  constexpr bool operator==(const Ping&) const = default;
};

/// PONG addressed to controller_id (the pinger). hw_type: namespace hw_type.
struct Pong {
  static constexpr Command kCommand = Command::pong;
  static constexpr std::uint8_t kDlc = 2;
  static constexpr const char* kName = "vesc_pong";
  std::uint8_t controller_id = 0;  ///< the pinger
  std::uint8_t responder_id = 0;
  std::uint8_t hw_type = hw_type::kVesc;
  template <class V> constexpr void fields(V&& v) const {
    v("controller_id", controller_id); v("responder_id", responder_id); v("hw_type", hw_type);
  }
  constexpr bool operator==(const Pong&) const = default;
};

using Message = std::variant<SetDuty, SetCurrent, SetCurrentBrake, SetRpm, SetPos, SetCurrentRel, Status1, Status2,
                             Status3, Status4, Status5, Status6, Ping, Pong>;

// Encoders: the frame to put on the bus (extended id, data frame, exact DLC, reserved bytes zero).
CanFrame encode(const SetDuty& m) noexcept;
CanFrame encode(const SetCurrent& m) noexcept;
CanFrame encode(const SetCurrentBrake& m) noexcept;
CanFrame encode(const SetRpm& m) noexcept;
CanFrame encode(const SetPos& m) noexcept;
CanFrame encode(const SetCurrentRel& m) noexcept;
CanFrame encode(const Status1& m) noexcept;
CanFrame encode(const Status2& m) noexcept;
CanFrame encode(const Status3& m) noexcept;
CanFrame encode(const Status4& m) noexcept;
CanFrame encode(const Status5& m) noexcept;
CanFrame encode(const Status6& m) noexcept;
CanFrame encode(const Ping& m) noexcept;
CanFrame encode(const Pong& m) noexcept;
CanFrame encode(const Message& m) noexcept;

// Decoders. Each checks, in this order: error frame (error_frame), 11-bit id (standard_id), the command
// bits of the id (unknown_id, also when bits 28..16 are set), remote frame (remote_frame), DLC (wrong_dlc).
// Every field value is accepted: the VESC clamps commands to its own limits, and status values are reports.
Result<SetDuty> decode_set_duty(const CanFrame& f) noexcept;
Result<SetCurrent> decode_set_current(const CanFrame& f) noexcept;
Result<SetCurrentBrake> decode_set_current_brake(const CanFrame& f) noexcept;
Result<SetRpm> decode_set_rpm(const CanFrame& f) noexcept;
Result<SetPos> decode_set_pos(const CanFrame& f) noexcept;
Result<SetCurrentRel> decode_set_current_rel(const CanFrame& f) noexcept;
Result<Status1> decode_status_1(const CanFrame& f) noexcept;
Result<Status2> decode_status_2(const CanFrame& f) noexcept;
Result<Status3> decode_status_3(const CanFrame& f) noexcept;
Result<Status4> decode_status_4(const CanFrame& f) noexcept;
Result<Status5> decode_status_5(const CanFrame& f) noexcept;
Result<Status6> decode_status_6(const CanFrame& f) noexcept;
Result<Ping> decode_ping(const CanFrame& f) noexcept;
Result<Pong> decode_pong(const CanFrame& f) noexcept;

/// Any VESC frame by the command bits of its id; unknown_id for a command not in the table above.
Result<Message> decode(const CanFrame& f) noexcept;
/// decode() with only the message's name kept: the same checks and reasons (decode_bus_name()).
Result<DecodedName> decode_name(const CanFrame& f) noexcept;
/// decode() into any variant that holds the VESC messages (decode_bus_frame()'s BusMessage): the message is built
/// once, in the variant it is wanted in.
template <class Variant>
Result<Variant> decode_as(const CanFrame& f) noexcept {
  if (f.error) return Reason::error_frame;
  if (!f.extended) return Reason::standard_id;
  const std::uint32_t command = command_of(f.id);
  if (command > 0xFF) return Reason::unknown_id;  // bits 28..16 set: not a VESC id
  switch (static_cast<Command>(command)) {
    case Command::set_duty: return widen_to<Variant>(decode_set_duty(f));
    case Command::set_current: return widen_to<Variant>(decode_set_current(f));
    case Command::set_current_brake: return widen_to<Variant>(decode_set_current_brake(f));
    case Command::set_rpm: return widen_to<Variant>(decode_set_rpm(f));
    case Command::set_pos: return widen_to<Variant>(decode_set_pos(f));
    case Command::set_current_rel: return widen_to<Variant>(decode_set_current_rel(f));
    case Command::status_1: return widen_to<Variant>(decode_status_1(f));
    case Command::status_2: return widen_to<Variant>(decode_status_2(f));
    case Command::status_3: return widen_to<Variant>(decode_status_3(f));
    case Command::status_4: return widen_to<Variant>(decode_status_4(f));
    case Command::status_5: return widen_to<Variant>(decode_status_5(f));
    case Command::status_6: return widen_to<Variant>(decode_status_6(f));
    case Command::ping: return widen_to<Variant>(decode_ping(f));
    case Command::pong: return widen_to<Variant>(decode_pong(f));
  }
  return Reason::unknown_id;
}

}  // namespace saul::vesc
