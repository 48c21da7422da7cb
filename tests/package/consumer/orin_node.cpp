// What an Orin node does with libsaulproto: encode a velocity command, decode telemetry. The expected bytes and
// values are written by hand from docs/protocol.md (section 3: little-endian int16 speed_mmps and steer_mrad in
// 0x300; int16 pitch_x100, int16 pid_out, int16 speed_mmps, uint8 state in 0x400). Exit 0 when all agree.
#include <array>
#include <cstdint>
#include <cstdio>

#include "saulproto/core/saul_can.hpp"

namespace sc = saul::saulcan;

int main() {
  int failures = 0;
  auto check = [&](bool ok, const char* what) {
    if (!ok) {
      std::printf("FAIL %s\n", what);
      ++failures;
    }
  };

  // 300 mm/s forward, turning right at 100 mrad: 300 = 0x012C, -100 = 0xFF9C.
  const saul::CanFrame cmd = sc::encode(sc::VelocityCmd{300, -100});
  const std::uint8_t want[] = {0x2C, 0x01, 0x9C, 0xFF};
  check(cmd.id == 0x300 && !cmd.extended && cmd.dlc == 4, "0x300 id, format and DLC");
  for (std::size_t i = 0; i < 4; ++i) check(cmd.data[i] == want[i], "0x300 payload byte");

  // Telemetry A: pitch +1.50 deg (150 = 0x0096), pid_out -75 (0xFFB5), speed 250 mm/s (0x00FA), state MANUAL (2).
  auto tele = saul::CanFrame::data_frame(0x400, false, std::array<std::uint8_t, 7>{0x96, 0x00, 0xB5, 0xFF, 0xFA, 0x00, 0x02});
  check(tele.ok(), "0x400 frame built");
  const auto a = sc::decode_telemetry_a(tele.value());
  check(a.ok(), "0x400 decodes");
  check(a->pitch_x100 == 150 && a->pid_out == -75 && a->speed_mmps == 250 && a->state == sc::RobotState::manual,
        "0x400 fields");

  // The same frame with DLC 6 is refused.
  auto shortf = saul::CanFrame::data_frame(0x400, false, std::array<std::uint8_t, 6>{0x96, 0x00, 0xB5, 0xFF, 0xFA, 0x00});
  check(sc::decode_telemetry_a(shortf.value()).reason() == saul::Reason::wrong_dlc, "0x400 with DLC 6 refused");

  std::printf("orin_node: %s\n", failures == 0 ? "ok" : "FAILED");
  return failures == 0 ? 0 : 1;
}
