// Linked for a Cortex-M4 by scripts/embedded-check.sh: proves the core needs nothing a microcontroller
// lacks (no exceptions, RTTI, heap or iostreams pulled in). Touches every codec so nothing is dropped early.
#include <cstdint>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/pid_stager.hpp"

volatile std::uint8_t g_sink;

int main() {
  saul::interboard::StreamDecoder uart;
  std::uint8_t buf[saul::interboard::kMaxFrameSize];
  auto n = saul::interboard::encode(saul::interboard::Fault{1}, buf);
  for (std::size_t i = 0; i < *n; ++i)
    if (auto m = uart.push(buf[i])) g_sink = static_cast<std::uint8_t>(saul::interboard::type_of(*m));

  saul::saulcan::PidStager stager;
  const saul::CanFrame f = saul::saulcan::encode(saul::saulcan::PidGain{saul::saulcan::Gain::kp, 1, 1.0F});
  if (auto r = saul::decode_bus_frame(f)) {
    if (auto* g = std::get_if<saul::saulcan::PidGain>(&r.value())) g_sink = static_cast<std::uint8_t>(stager.accept(*g, 0).kind);
  }
  const saul::CanFrame v = saul::encode_bus_message(saul::vesc::SetRpm{saul::vesc::kLeftId, 1500});
  if (auto r = saul::decode_bus_frame(v)) g_sink = static_cast<std::uint8_t>(r.value().index());
  g_sink = static_cast<std::uint8_t>(*saul::to_string(saul::Reason::bad_crc));
  return 0;
}
