// IO board glue: ESP-IDF v5 drivers behind the interfaces of firmware/logic/include/saulfw/hal.hpp, and a 1 kHz
// task that calls IoBoard::step().
//
// Nothing here decides anything about the robot: every rule (ESTOP first, arming, drivers, messages) is
// saul::fw::IoBoard, which tests/firmware covers on the host. This file only moves bytes, duty cycles and pixels.
// It cannot be built in this repository's CI (no ESP-IDF there); see firmware/README.md.
#include <cstdint>

#include "driver/gpio.h"
#include "driver/i2c.h"
#include "driver/ledc.h"
#include "driver/uart.h"
#include "esp_system.h"
#include "esp_task_wdt.h"
#include "esp_timer.h"
#include "freertos/FreeRTOS.h"
#include "freertos/task.h"
#include "led_strip.h"
#include "pins.hpp"
#include "saul_esp_ports.hpp"
#include "saulfw/io.hpp"

namespace {

using namespace saul;
using namespace saul::fw;
using esp::Uart;
using esp::UsbConsole;

// Byte streams (UARTs, the USB console): saul_esp_ports.hpp, shared with the other board.

// ---- PWM (LEDC), GPIO, horn -------------------------------------------------------------------------------------

class Outputs final : public Pwm, public Gpio, public Horn {
 public:
  static constexpr ledc_mode_t kMode = LEDC_LOW_SPEED_MODE;
  static constexpr ledc_timer_bit_t kBits = LEDC_TIMER_10_BIT;
  static constexpr std::uint32_t kMaxDuty = 1023;

  void init() {
    // Enables first, low: the BTS7960 half bridges stay off whatever the PWM pins do while booting.
    const int outs[] = {pins::kLeftREn, pins::kLeftLEn, pins::kRightREn, pins::kRightLEn};
    for (int pin : outs) output(pin);
    if (!pins::kElrsFitted) output(pins::kFan);
    timer(LEDC_TIMER_0, pins::kMotorPwmHz);
    timer(LEDC_TIMER_1, 2000);  // the horn's tone timer; its frequency changes per tone
    const int pwm_pins[kPwmChannelCount] = {pins::kLeftRpwm, pins::kLeftLpwm, pins::kRightRpwm, pins::kRightLpwm,
                                            pins::kHeadlight};
    for (std::size_t i = 0; i < kPwmChannelCount; ++i) channel(static_cast<ledc_channel_t>(i), pwm_pins[i], LEDC_TIMER_0);
    channel(kHornChannel, pins::kHorn, LEDC_TIMER_1);
    gpio_config_t in{};
    in.pin_bit_mask = (1ULL << pins::kArmButton) | (1ULL << pins::kKillSense);
    in.mode = GPIO_MODE_INPUT;
    in.pull_up_en = GPIO_PULLUP_ENABLE;
    gpio_config(&in);
  }

  void set(PwmChannel c, std::uint16_t permille) override {
    const auto ch = static_cast<ledc_channel_t>(c);
    ledc_set_duty(kMode, ch, static_cast<std::uint32_t>(permille > 1000 ? 1000 : permille) * kMaxDuty / 1000U);
    ledc_update_duty(kMode, ch);
  }
  void write(OutputPin p, bool on) override {
    static constexpr int kPins[kOutputPinCount] = {pins::kLeftREn, pins::kLeftLEn, pins::kRightREn, pins::kRightLEn,
                                                   pins::kFan};
    if (p == OutputPin::fan && pins::kElrsFitted) return;  // IO16 is ELRS's line then
    gpio_set_level(static_cast<gpio_num_t>(kPins[static_cast<std::size_t>(p)]), on ? 1 : 0);
  }
  bool read(InputPin p) override {
    if (p == InputPin::arm_button) return gpio_get_level(static_cast<gpio_num_t>(pins::kArmButton)) == 0;  // active low
    return gpio_get_level(static_cast<gpio_num_t>(pins::kKillSense)) == pins::kKillActiveLevel;
  }
  void tone(std::uint16_t hz) override {
    if (hz == 0) {
      ledc_set_duty(kMode, kHornChannel, 0);
    } else {
      ledc_set_freq(kMode, LEDC_TIMER_1, hz);
      ledc_set_duty(kMode, kHornChannel, kMaxDuty / 2);
    }
    ledc_update_duty(kMode, kHornChannel);
  }

 private:
  static constexpr ledc_channel_t kHornChannel = LEDC_CHANNEL_5;
  static void output(int pin) {
    gpio_set_level(static_cast<gpio_num_t>(pin), 0);
    gpio_set_direction(static_cast<gpio_num_t>(pin), GPIO_MODE_OUTPUT);
  }
  static void timer(ledc_timer_t t, std::uint32_t hz) {
    ledc_timer_config_t c{};
    c.speed_mode = kMode;
    c.duty_resolution = kBits;
    c.timer_num = t;
    c.freq_hz = hz;
    c.clk_cfg = LEDC_AUTO_CLK;
    ledc_timer_config(&c);
  }
  static void channel(ledc_channel_t ch, int pin, ledc_timer_t t) {
    ledc_channel_config_t c{};
    c.gpio_num = pin;
    c.speed_mode = kMode;
    c.channel = ch;
    c.timer_sel = t;
    c.duty = 0;
    ledc_channel_config(&c);
  }
};

// ---- WS2812B ----------------------------------------------------------------------------------------------------

class Strip final : public LedStrip {
 public:
  bool init() {
    led_strip_config_t strip{};
    strip.strip_gpio_num = pins::kLedData;
    strip.max_leds = IoBoard::kMaxLeds;
    strip.led_pixel_format = LED_PIXEL_FORMAT_GRB;
    strip.led_model = LED_MODEL_WS2812;
    led_strip_rmt_config_t rmt{};
    rmt.clk_src = RMT_CLK_SRC_DEFAULT;
    rmt.resolution_hz = 10 * 1000 * 1000;
    return led_strip_new_rmt_device(&strip, &rmt, &handle_) == ESP_OK;
  }
  void show(std::span<const Rgb> pixels) override {
    if (handle_ == nullptr) return;
    for (std::size_t i = 0; i < pixels.size(); ++i)
      led_strip_set_pixel(handle_, static_cast<std::uint32_t>(i), pixels[i].r, pixels[i].g, pixels[i].b);
    led_strip_refresh(handle_);
  }

 private:
  led_strip_handle_t handle_ = nullptr;
};

// ---- I2C sensors --------------------------------------------------------------------------------------------------

/// The reference leaves the parts open (BMP280 or BMP388, VL53L0X or VL53L1X, "PN532 or similar"), so no part
/// driver is written yet: the bus is set up and every reading is reported invalid, which the logic forwards as
/// "no reading" (ToF 65535, barometer delta 0, no NFC). firmware/README.md, what is missing.
class I2cSensors final : public Sensors {
 public:
  bool init() {
    i2c_config_t c{};
    c.mode = I2C_MODE_MASTER;
    c.sda_io_num = pins::kI2cSda;
    c.scl_io_num = pins::kI2cScl;
    c.sda_pullup_en = GPIO_PULLUP_ENABLE;
    c.scl_pullup_en = GPIO_PULLUP_ENABLE;
    c.master.clk_speed = 400000;
    return i2c_param_config(I2C_NUM_0, &c) == ESP_OK && i2c_driver_install(I2C_NUM_0, c.mode, 0, 0, 0) == ESP_OK;
  }
  SensorReadings read() override { return {}; }
};

class TaskWatchdog final : public Watchdog {
 public:
  void feed() override { esp_task_wdt_reset(); }
};

Uart g_crsf;
Uart g_elrs;
Uart g_link;
UsbConsole g_console;
Outputs g_outputs;
Strip g_strip;
I2cSensors g_sensors;
TaskWatchdog g_watchdog;

[[noreturn]] void loop_task(void* arg) {
  auto& board = *static_cast<IoBoard*>(arg);
  esp_task_wdt_add(nullptr);
  TickType_t wake = xTaskGetTickCount();
  for (;;) {
    board.step(static_cast<TimeUs>(esp_timer_get_time()));  // feeds the watchdog at the end of every iteration
    if (board.reboot_requested()) {
      vTaskDelay(pdMS_TO_TICKS(50));
      esp_restart();
    }
    vTaskDelayUntil(&wake, 1);  // 1 kHz with CONFIG_FREERTOS_HZ=1000
  }
}

}  // namespace

extern "C" void app_main() {
  g_outputs.init();  // drivers off before anything else
  g_crsf.init(UART_NUM_0, pins::kCrsfTx, pins::kCrsfRx, pins::kCrsfBaud);
  if (pins::kElrsFitted) g_elrs.init(UART_NUM_2, pins::kElrsTx, pins::kElrsRx, pins::kElrsBaud);
  g_link.init(UART_NUM_1, pins::kLinkTx, pins::kLinkRx, pins::kLinkBaud);
  g_console.init();
  g_strip.init();
  g_sensors.init();

  esp_task_wdt_config_t wdt{};
  wdt.timeout_ms = CONFIG_SAUL_WDT_TIMEOUT_MS;
  wdt.idle_core_mask = 0;
  wdt.trigger_panic = true;
  esp_task_wdt_reconfigure(&wdt);

  IoConfig config;
  config.elrs_fitted = pins::kElrsFitted;
  static IoBoard board({g_crsf, g_elrs, g_link, g_console, g_outputs, g_outputs, g_outputs, g_strip, g_sensors,
                        g_watchdog},
                       config);
  xTaskCreatePinnedToCore(loop_task, "io", 8192, &board, configMAX_PRIORITIES - 2, nullptr, 1);
}
