// Linked for a Cortex-M4 by scripts/embedded-check.sh: both boards' logic (firmware/logic) on stub hardware, to
// prove it needs nothing a microcontroller lacks (no exceptions, RTTI, heap or iostreams) and to measure it. The
// boards are static objects, as in the ESP-IDF glue: their RAM shows up as .bss.
#include <cstdint>

#include "saulfw/balance.hpp"
#include "saulfw/io.hpp"

namespace {

using namespace saul;
using namespace saul::fw;

volatile std::uint32_t g_sink;
volatile std::uint32_t g_time;

struct Port final : SerialPort {
  std::size_t read(std::span<std::uint8_t> out) override {
    if (!out.empty() && (g_time & 7U) == 0) {
      out[0] = static_cast<std::uint8_t>(g_time);
      return 1;
    }
    return 0;
  }
  std::size_t write(std::span<const std::uint8_t> data) override {
    for (auto b : data) g_sink = b;
    return data.size();
  }
};
struct Can final : CanPort {
  bool receive(CanFrame& out) override {
    out.id = g_time & 0x7FFU;
    out.dlc = 4;
    return (g_time & 3U) == 0;
  }
  bool send(const CanFrame& f) override {
    g_sink = f.id;
    return true;
  }
  console::CanStats stats() override { return {}; }
};
struct Accel final : Imu {
  bool read(ImuSample& s) override {
    s.t_us = g_time;
    s.az = 1.0F;
    return (g_time & 1U) == 0;
  }
};
struct Dog final : Watchdog {
  void feed() override { g_sink = 1; }
};
struct Lcd final : Display {
  void show(const LcdView& v) override { g_sink = static_cast<std::uint32_t>(v.pitch_x100); }
};
struct Pins final : Pwm, Gpio, Horn, LedStrip, Sensors {
  void set(PwmChannel c, std::uint16_t v) override { g_sink = static_cast<std::uint32_t>(c) + v; }
  void write(OutputPin p, bool on) override { g_sink = static_cast<std::uint32_t>(p) + on; }
  bool read(InputPin p) override { return ((g_time >> static_cast<unsigned>(p)) & 1U) != 0; }
  void tone(std::uint16_t hz) override { g_sink = hz; }
  void show(std::span<const Rgb> px) override { g_sink = px.empty() ? 0U : px[0].r; }
  SensorReadings read() override { return {}; }
};

Port link_a, link_b, console_a, console_b, crsf, elrs;
Can can;
Accel imu;
Dog dog;
Lcd lcd;
Pins pins;

RetainedLimits retained{};
BalanceBoard balance({imu, can, link_a, console_a, dog, lcd, retained}, BalanceConfig{}, ResetReason::power_on);
IoBoard io({crsf, elrs, link_b, console_b, pins, pins, pins, pins, pins, dog}, IoConfig{});

}  // namespace

int main() {
  for (std::uint32_t t = 1; t < 100000; ++t) {
    g_time = t * 1000U;
    balance.step(g_time);
    io.step(g_time);
  }
  g_sink = static_cast<std::uint32_t>(balance.state()) + (io.armed() ? 1U : 0U);
  return 0;
}
