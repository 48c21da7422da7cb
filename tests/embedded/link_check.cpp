// Linked for a Cortex-M4 by scripts/embedded-check.sh: proves the core needs nothing a microcontroller
// lacks (no exceptions, RTTI, heap or iostreams pulled in). Touches every codec so nothing is dropped early.
#include <cstdint>

#include "saulproto/core/console.hpp"
#include "saulproto/core/crsf.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/esp_loader.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/pid_stager.hpp"
#include "saulproto/core/pride.hpp"
#include "saulproto/core/rc_input.hpp"

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
  saul::pride::StreamDecoder pride;
  saul::pride::EchoFilter echo;
  std::uint8_t pbuf[saul::pride::kFrameSize];
  if (saul::pride::encode(saul::pride::VcuCommand{1, 10, -10}, pbuf).ok() && echo.sent(pbuf))
    for (std::uint8_t b : pbuf)
      if (auto kept = echo.push(b))
        if (auto m = pride.push(*kept)) g_sink = static_cast<std::uint8_t>(saul::pride::direction_of(*m));
  g_sink = static_cast<std::uint8_t>(saul::pride::check_layout(pbuf).headers[0].best_length);

  char reply[saul::console::kMaxKvLine];
  const auto cmd = saul::console::parse("tilt_limit 12.5");
  if (cmd) g_sink = static_cast<std::uint8_t>(saul::console::verb_of(cmd.command));
  if (auto n = saul::console::format_kv(saul::console::StatusReport{}, reply)) g_sink = static_cast<std::uint8_t>(*n);
  if (auto s = saul::console::parse_status(reply)) g_sink = static_cast<std::uint8_t>(s->speed_limit_pct);

  std::uint8_t cbuf[saul::crsf::kMaxFrameSize];
  saul::crsf::RcChannels rc;
  rc.ticks.fill(saul::crsf::kTicksMid);
  saul::crsf::StreamDecoder crsf;
  saul::rc::ReceiverSelector receivers;
  if (auto cn = saul::crsf::encode(rc, cbuf))
    crsf.push(std::span<const std::uint8_t>(cbuf, *cn), [&](const saul::crsf::Frame& frame) {
      if (auto m = saul::crsf::decode(frame))
        if (auto* ch = std::get_if<saul::crsf::RcChannels>(&m.value())) {
          receivers.on_frame(saul::rc::Source::crsf, 0);
          const auto rc_cmd = saul::rc::to_rc_cmd(saul::rc::map_channels(saul::crsf::channels_us(*ch)));
          g_sink = static_cast<std::uint8_t>(rc_cmd.flags | static_cast<std::uint8_t>(receivers.active()));
        }
    });
  if (auto cn = saul::crsf::encode(saul::crsf::Attitude{1, 2, 3}, cbuf)) g_sink = static_cast<std::uint8_t>(*cn);
  if (auto cn = saul::crsf::encode(saul::crsf::BatterySensor{1, 2, 3, 4}, cbuf)) g_sink = static_cast<std::uint8_t>(*cn);
  if (auto mode = saul::crsf::make_flight_mode("BAL"))
    if (auto cn = saul::crsf::encode(*mode, cbuf)) g_sink = static_cast<std::uint8_t>(*cn);
  std::uint8_t esp_packet[64];
  std::uint8_t esp_frame[2 * sizeof esp_packet + 2];
  std::uint8_t esp_storage[64];
  saul::esp::SlipDecoder slip(esp_storage);
  if (auto en = saul::esp::build_spi_flash_md5(0x10000, 0x1000, esp_packet))
    if (auto fn = saul::esp::slip_encode(std::span<const std::uint8_t>(esp_packet, *en), esp_frame))
      for (std::size_t i = 0; i < *fn; ++i)
        if (auto p = slip.push(esp_frame[i]))
          if (auto req = saul::esp::parse_request(*p)) g_sink = req->op;
  g_sink = static_cast<std::uint8_t>(saul::esp::parse_image_header(esp_packet).reason());
  return 0;
}
