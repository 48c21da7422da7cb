// What a bench tool does with libsaulproto's host library: open a capture file (any format), decode every frame,
// count the telemetry and add up the 0x400 pitches. tests/package/consumer.sh compares the counts with
// grep's on the same candump file.
#include <cstdio>
#include <string>
#include <variant>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/capture/capture.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: capture_tool FILE\n");
    return 2;
  }
  auto reader = saul::host::open_capture_reader(argv[1]);
  long frames = 0, telemetry_a = 0, telemetry_b = 0;
  long pitch_sum = 0;
  saul::host::FrameBatch batch;
  while (reader->next_batch(batch)) {
    for (const saul::CanFrame& frame : batch.frames) {
      ++frames;
      const auto m = saul::decode_bus_frame(frame);
      if (!m) continue;
      if (const auto* a = std::get_if<saul::saulcan::TelemetryA>(&m.value())) {
        ++telemetry_a;
        pitch_sum += a->pitch_x100;
      }
      if (std::holds_alternative<saul::saulcan::TelemetryB>(m.value())) ++telemetry_b;
    }
  }
  std::printf("frames=%ld telemetry_a=%ld telemetry_b=%ld pitch_x100_sum=%ld\n", frames, telemetry_a, telemetry_b,
              pitch_sum);
  return 0;
}
