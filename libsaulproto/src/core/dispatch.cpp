#include "saulproto/core/dispatch.hpp"

namespace saul {

Result<BusMessage> decode_bus_frame(const CanFrame& frame) noexcept {
  if (frame.error) return Reason::error_frame;
  if (!frame.valid()) return Reason::invalid_frame;
  if (!frame.extended) return saulcan::decode_as<BusMessage>(frame);
  return vesc::decode_as<BusMessage>(frame);
}

Result<DecodedName> decode_bus_name(const CanFrame& frame) noexcept {
  if (frame.error) return Reason::error_frame;
  if (!frame.valid()) return Reason::invalid_frame;
  if (!frame.extended) return saulcan::decode_name(frame);
  return vesc::decode_name(frame);
}

const char* name_of(const BusMessage& message) noexcept {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kName; }, message);
}

CanFrame encode_bus_message(const BusMessage& message) noexcept {
  // Unqualified on purpose: argument-dependent lookup picks saulcan::encode or vesc::encode by the message's
  // namespace, so a new codec only has to provide encode() next to its types.
  return std::visit([](const auto& m) { return encode(m); }, message);
}

}  // namespace saul
