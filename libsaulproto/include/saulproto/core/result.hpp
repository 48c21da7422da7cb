// Results that carry a reason on failure, for code that may not throw.
//
// Every decoder and encoder in the core returns Result<T>: either a value, or one Reason saying why not.
// Reasons are a closed enum (not strings) so firmware can count them and send them in an acknowledgement.
#pragma once

#include <cstdint>

namespace saul {

enum class Reason : std::uint8_t {
  ok = 0,
  // CAN frame shape
  wrong_dlc,         ///< data length code differs from the one this message id requires
  extended_id,       ///< an 11-bit message arrived with a 29-bit id
  standard_id,       ///< a 29-bit message arrived with an 11-bit id
  remote_frame,      ///< a remote (RTR) frame where data was expected
  error_frame,       ///< a SocketCAN error frame, not a message
  unknown_id,        ///< no message with this id is known
  invalid_frame,     ///< id out of range for its format, or DLC > 8
  // values
  out_of_range,      ///< a field is outside the range the protocol allows
  not_finite,        ///< a float is NaN or infinite
  negative,          ///< a quantity that must not be negative is
  // byte streams
  buffer_too_small,  ///< the caller's output buffer cannot hold the encoding
  bad_crc,           ///< checksum mismatch
  bad_length,        ///< a length field disagrees with the message type
  unknown_type,      ///< a type byte no decoder knows
  truncated,         ///< input ended inside a field
  // text
  syntax,            ///< text that does not follow the grammar
  // command lines (console.hpp)
  unknown_command,   ///< the first word of a command line names no command
  missing_argument,  ///< a command line has fewer arguments than its command takes
  extra_argument,    ///< a command line has more arguments than its command takes
  not_a_number,      ///< an argument that must be a number is not one
};

/// A short, stable, lower-case name for a reason ("wrong_dlc"), for logs, JSON and tests.
const char* to_string(Reason reason) noexcept;

/// A value or a reason. T must be default-constructible (all core message types are plain structs).
/// Cost: sizeof(T) + 1 byte; no allocation.
template <class T>
class [[nodiscard]] Result {
 public:
  constexpr Result(const T& value) noexcept : value_(value), reason_(Reason::ok) {}  // NOLINT: implicit by design
  constexpr Result(Reason reason) noexcept : value_{}, reason_(reason) {}            // NOLINT: implicit by design

  [[nodiscard]] constexpr bool ok() const noexcept { return reason_ == Reason::ok; }
  constexpr explicit operator bool() const noexcept { return ok(); }
  [[nodiscard]] constexpr Reason reason() const noexcept { return reason_; }

  /// The value. Only meaningful when ok(); on failure it is a default-constructed T.
  [[nodiscard]] constexpr const T& value() const noexcept { return value_; }
  constexpr const T& operator*() const noexcept { return value_; }
  constexpr const T* operator->() const noexcept { return &value_; }

 private:
  T value_;
  Reason reason_;
};

/// Of a decoded message, only its name: what a counter of frames keeps (saulctl stats, through the codecs'
/// decode_name() and decode_bus_name()). Made from any message type.
struct DecodedName {
  const char* name = nullptr;
  DecodedName() = default;
  template <class Message>
  constexpr DecodedName(const Message&) noexcept : name(Message::kName) {}  // NOLINT: implicit, as a variant's
};

/// The Result of one message type as the Result of a variant that holds that type (the codecs' decode_as()).
template <class Variant, class T>
constexpr Result<Variant> widen_to(const Result<T>& r) noexcept {
  if (!r) return r.reason();
  return Variant{r.value()};
}

}  // namespace saul
