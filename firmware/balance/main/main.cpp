// BALANCE board glue: ESP-IDF v5 drivers behind the interfaces of firmware/logic/include/saulfw/hal.hpp, and a
// control task that calls BalanceBoard::step() on every QMI8658 data-ready interrupt (1 kHz).
//
// Nothing here decides anything about the robot: every rule is saul::fw::BalanceBoard, which tests/firmware covers
// on the host. This file only moves bytes, frames, samples and pixels. It cannot be built in this repository's CI
// (no ESP-IDF there); firmware/README.md says how to build it and what to check at bring-up.
#include <cstdint>
#include <cstring>

#include "driver/gpio.h"
#include "driver/ledc.h"
#include "driver/spi_master.h"
#include "driver/twai.h"
#include "driver/uart.h"
#include "esp_attr.h"
#include "esp_lcd_gc9a01.h"
#include "esp_lcd_panel_io.h"
#include "esp_lcd_panel_ops.h"
#include "esp_system.h"
#include "esp_task_wdt.h"
#include "esp_timer.h"
#include "freertos/FreeRTOS.h"
#include "freertos/semphr.h"
#include "freertos/task.h"
#include "pins.hpp"
#include "saul_esp_ports.hpp"
#include "saulfw/balance.hpp"

namespace {

using namespace saul;
using namespace saul::fw;
using esp::Uart;
using esp::UsbConsole;

constexpr spi_host_device_t kSpiHost = SPI2_HOST;  // shared by the IMU and the LCD
constexpr uart_port_t kLinkUart = UART_NUM_1;

TaskHandle_t g_control_task = nullptr;

void IRAM_ATTR on_imu_ready(void*) {
  BaseType_t woken = pdFALSE;
  if (g_control_task != nullptr) vTaskNotifyGiveFromISR(g_control_task, &woken);
  portYIELD_FROM_ISR(woken);
}

// ---- QMI8658 over SPI -------------------------------------------------------------------------------------------

class Qmi8658 final : public Imu {
 public:
  static constexpr std::uint8_t kWhoAmI = 0x00;  // reads 0x05
  static constexpr std::uint8_t kCtrl1 = 0x02;
  static constexpr std::uint8_t kCtrl2 = 0x03;   // accelerometer full scale and rate
  static constexpr std::uint8_t kCtrl3 = 0x04;   // gyroscope full scale and rate
  static constexpr std::uint8_t kCtrl7 = 0x08;   // sensor enable
  static constexpr std::uint8_t kStatus0 = 0x2E; // bit 0 accelerometer ready, bit 1 gyroscope ready
  static constexpr std::uint8_t kAxL = 0x35;     // AX_L .. GZ_H: six little-endian int16
  static constexpr std::uint8_t kReset = 0x60;
  static constexpr float kLsbPerG = 4096.0F;     // +-8 g
  static constexpr float kLsbPerDps = 64.0F;     // +-512 dps

  bool init() {
    spi_device_interface_config_t dev{};
    dev.clock_speed_hz = 8 * 1000 * 1000;
    dev.mode = 0;
    dev.spics_io_num = pins::kImuCs;
    dev.queue_size = 1;
    if (spi_bus_add_device(kSpiHost, &dev, &dev_) != ESP_OK) return false;
    write(kReset, 0xB0);
    vTaskDelay(pdMS_TO_TICKS(20));
    if (read_reg(kWhoAmI) != 0x05) return false;
    write(kCtrl1, 0x40 | 0x08);  // register address auto-increment; INT1 output enabled (data ready, bring-up list)
    write(kCtrl2, 0x23);         // accelerometer +-8 g, 1 kHz
    write(kCtrl3, 0x53);         // gyroscope +-512 dps, 1 kHz
    write(kCtrl7, 0x03);         // accelerometer and gyroscope on
    return true;
  }

  /// Reads a new sample if the chip has one (called after INT1, or after a 2 ms wait without it).
  void poll(TimeUs now) {
    if ((read_reg(kStatus0) & 0x03) != 0x03) return;
    std::uint8_t raw[12];
    read_regs(kAxL, raw, sizeof raw);
    float a[3];
    float g[3];
    for (int i = 0; i < 3; ++i) {
      a[i] = static_cast<float>(static_cast<std::int16_t>(raw[2 * i] | (raw[2 * i + 1] << 8))) / kLsbPerG;
      g[i] = static_cast<float>(static_cast<std::int16_t>(raw[6 + 2 * i] | (raw[7 + 2 * i] << 8))) / kLsbPerDps;
    }
    const auto body = [](const float* v, pins::Axis axis) { return static_cast<float>(axis.sign) * v[axis.chip_axis]; };
    sample_ = ImuSample{now, body(a, pins::kBodyX), body(a, pins::kBodyY), body(a, pins::kBodyZ),
                        body(g, pins::kBodyX), body(g, pins::kBodyY), body(g, pins::kBodyZ)};
    pending_ = true;
  }

  bool read(ImuSample& out) override {
    if (!pending_) return false;
    pending_ = false;
    out = sample_;
    return true;
  }

 private:
  void write(std::uint8_t reg, std::uint8_t value) {
    spi_transaction_t t{};
    t.length = 16;
    t.flags = SPI_TRANS_USE_TXDATA;
    t.tx_data[0] = reg & 0x7F;
    t.tx_data[1] = value;
    spi_device_polling_transmit(dev_, &t);
  }
  std::uint8_t read_reg(std::uint8_t reg) {
    std::uint8_t v = 0;
    read_regs(reg, &v, 1);
    return v;
  }
  void read_regs(std::uint8_t reg, std::uint8_t* out, std::size_t n) {
    std::uint8_t tx[16]{};
    std::uint8_t rx[16]{};
    tx[0] = static_cast<std::uint8_t>(0x80 | reg);  // bit 7 = read
    spi_transaction_t t{};
    t.length = 8 * (n + 1);
    t.tx_buffer = tx;
    t.rx_buffer = rx;
    spi_device_polling_transmit(dev_, &t);
    std::memcpy(out, rx + 1, n);
  }

  spi_device_handle_t dev_ = nullptr;
  ImuSample sample_{};
  bool pending_ = false;
};

// ---- TWAI -------------------------------------------------------------------------------------------------------

class Twai final : public CanPort {
 public:
  bool init() {
    twai_general_config_t g = TWAI_GENERAL_CONFIG_DEFAULT(static_cast<gpio_num_t>(pins::kCanTx),
                                                          static_cast<gpio_num_t>(pins::kCanRx), TWAI_MODE_NORMAL);
    g.rx_queue_len = 32;
    g.tx_queue_len = 16;
    g.alerts_enabled = TWAI_ALERT_BUS_OFF | TWAI_ALERT_BUS_RECOVERED;
    const twai_timing_config_t timing = TWAI_TIMING_CONFIG_500KBITS();
    const twai_filter_config_t filter = TWAI_FILTER_CONFIG_ACCEPT_ALL();
    return twai_driver_install(&g, &timing, &filter) == ESP_OK && twai_start() == ESP_OK;
  }

  /// Bus-off: start the recovery (128 x 11 recessive bits), then start again once recovered. The VESCs stop
  /// getting SET_RPM meanwhile and release their motors after their own timeout.
  void service() {
    std::uint32_t alerts = 0;
    if (twai_read_alerts(&alerts, 0) != ESP_OK) return;
    if (alerts & TWAI_ALERT_BUS_OFF) {
      ++busoff_;
      twai_initiate_recovery();
    }
    if (alerts & TWAI_ALERT_BUS_RECOVERED) twai_start();
  }

  bool receive(CanFrame& out) override {
    twai_message_t m{};
    if (twai_receive(&m, 0) != ESP_OK) return false;
    out = CanFrame{};
    out.id = m.identifier;
    out.extended = m.extd != 0;
    out.remote = m.rtr != 0;
    out.dlc = m.data_length_code > 8 ? 8 : m.data_length_code;
    std::memcpy(out.data.data(), m.data, out.dlc);
    ++rx_;
    return true;
  }

  bool send(const CanFrame& f) override {
    twai_message_t m{};
    m.identifier = f.id;
    m.extd = f.extended ? 1 : 0;
    m.rtr = f.remote ? 1 : 0;
    m.data_length_code = f.dlc;
    std::memcpy(m.data, f.data.data(), f.dlc > 8 ? 8 : f.dlc);
    if (twai_transmit(&m, 0) != ESP_OK) return false;
    ++tx_;
    return true;
  }

  console::CanStats stats() override {
    twai_status_info_t s{};
    twai_get_status_info(&s);
    console::CanStats c;
    c.tx = tx_;
    c.rx = rx_;
    c.errors = s.bus_error_count;
    c.busoff = busoff_;
    c.tx_failed = s.tx_failed_count;
    c.rx_missed = s.rx_missed_count + s.rx_overrun_count;
    c.arb_lost = s.arb_lost_count;
    c.tec = static_cast<std::uint16_t>(s.tx_error_counter);
    c.rec = static_cast<std::uint16_t>(s.rx_error_counter);
    return c;
  }

 private:
  std::uint32_t tx_ = 0;
  std::uint32_t rx_ = 0;
  std::uint32_t busoff_ = 0;
};

// Byte streams (UARTs, the USB console): saul_esp_ports.hpp, shared with the other board.

class TaskWatchdog final : public Watchdog {
 public:
  void feed() override { esp_task_wdt_reset(); }
};

// ---- GC9A01: the view as plain shapes (no font: see firmware/README.md) ------------------------------------------

class Lcd final : public Display {
 public:
  static constexpr int kSize = 240;
  static constexpr int kChunkRows = 8;

  bool init() {
    done_ = xSemaphoreCreateBinary();
    xSemaphoreGive(done_);
    esp_lcd_panel_io_spi_config_t io{};
    io.cs_gpio_num = pins::kLcdCs;
    io.dc_gpio_num = pins::kLcdDc;
    io.spi_mode = 0;
    io.pclk_hz = 40 * 1000 * 1000;
    io.trans_queue_depth = 1;
    io.lcd_cmd_bits = 8;
    io.lcd_param_bits = 8;
    io.on_color_trans_done = [](esp_lcd_panel_io_handle_t, esp_lcd_panel_io_event_data_t*, void* ctx) -> bool {
      BaseType_t woken = pdFALSE;
      xSemaphoreGiveFromISR(static_cast<SemaphoreHandle_t>(ctx), &woken);
      return woken == pdTRUE;
    };
    io.user_ctx = done_;
    if (esp_lcd_new_panel_io_spi((esp_lcd_spi_bus_handle_t)kSpiHost, &io, &io_) != ESP_OK) return false;
    esp_lcd_panel_dev_config_t panel{};
    panel.reset_gpio_num = pins::kLcdRst;
    panel.rgb_ele_order = LCD_RGB_ELEMENT_ORDER_BGR;
    panel.bits_per_pixel = 16;
    if (esp_lcd_new_panel_gc9a01(io_, &panel, &panel_) != ESP_OK) return false;
    esp_lcd_panel_reset(panel_);
    esp_lcd_panel_init(panel_);
    esp_lcd_panel_invert_color(panel_, true);
    esp_lcd_panel_disp_on_off(panel_, true);
    ledc_timer_config_t timer{};
    timer.speed_mode = LEDC_LOW_SPEED_MODE;
    timer.duty_resolution = LEDC_TIMER_10_BIT;
    timer.timer_num = LEDC_TIMER_0;
    timer.freq_hz = 5000;
    timer.clk_cfg = LEDC_AUTO_CLK;
    ledc_timer_config(&timer);
    ledc_channel_config_t ch{};
    ch.gpio_num = pins::kLcdBacklight;
    ch.speed_mode = LEDC_LOW_SPEED_MODE;
    ch.channel = LEDC_CHANNEL_0;
    ch.timer_sel = LEDC_TIMER_0;
    ch.duty = 800;
    ledc_channel_config(&ch);
    return true;
  }

  /// Called by the control loop at 10 Hz: only copies the view.
  void show(const LcdView& view) override {
    portENTER_CRITICAL(&lock_);
    view_ = view;
    fresh_ = true;
    portEXIT_CRITICAL(&lock_);
  }

  /// The LCD task: draws the latest view, at low priority, outside the control loop.
  [[noreturn]] void run() {
    bool first = true;
    LcdView drawn{};
    for (;;) {
      vTaskDelay(pdMS_TO_TICKS(100));
      LcdView v;
      portENTER_CRITICAL(&lock_);
      const bool fresh = fresh_;
      v = view_;
      fresh_ = false;
      portEXIT_CRITICAL(&lock_);
      if (!fresh || (!first && v == drawn)) continue;
      if (first || v.state != drawn.state) fill(0, 0, kSize, kSize, background(v.state));
      const std::uint16_t bg = background(v.state);
      // pitch: a bar from the centre, 4 px per degree (+-25 degrees fill the width)
      bar(60, v.pitch_x100 / 25, 0xFFFF, bg);
      // speed: a bar from the centre, full width at the current cap
      const int cap = v.speed_limit_pct * 20;  // mm/s at hard_max_speed_mmps 2000
      bar(110, cap > 0 ? v.speed_mmps * 100 / cap : 0, 0x07FF, bg);
      // battery: a bar from the left, green above 30 %, red below
      fill(20, 160, 200, 16, bg);
      if (v.battery_known) fill(20, 160, v.battery_pct * 2, 16, v.battery_pct > 30 ? 0x07E0 : 0xF800);
      // the 0x401 fault bits, bit 0 on the left: lit squares; below them the FAULT reason as that many marks
      // (1 no IMU, 2 IMU silent, 3 no IO board, 4 IO link lost, 5 RC lost, 6 motor, 7 hang, 8 watchdog reset)
      for (int bit = 0; bit < 8; ++bit) fill(40 + bit * 20, 184, 14, 14, (v.faults >> bit) & 1U ? 0xF800 : 0x4208);
      fill(40, 204, 160, 8, bg);
      for (int mark = 0; mark < static_cast<int>(v.fault_reason); ++mark) fill(40 + mark * 20, 204, 14, 8, 0xFFFF);
      drawn = v;
      first = false;
    }
  }

 private:
  static std::uint16_t background(saulcan::RobotState s) {
    switch (s) {
      case saulcan::RobotState::off: return 0x0010;          // dark blue
      case saulcan::RobotState::balance: return 0x0320;      // dark green
      case saulcan::RobotState::manual: return 0x0330;       // dark cyan
      case saulcan::RobotState::estop: return 0xA000;        // red
      case saulcan::RobotState::tilt_cutoff: return 0xA300;  // amber
      case saulcan::RobotState::fault: return 0x8010;        // magenta
    }
    return 0;
  }
  void bar(int y, int offset, std::uint16_t color, std::uint16_t bg) {
    offset = offset > 100 ? 100 : (offset < -100 ? -100 : offset);
    fill(20, y, 200, 16, bg);
    if (offset >= 0) fill(120, y, offset, 16, color);
    else fill(120 + offset, y, -offset, 16, color);
  }
  void fill(int x, int y, int w, int h, std::uint16_t color) {
    if (w <= 0 || h <= 0) return;
    const std::uint16_t swapped = static_cast<std::uint16_t>((color >> 8) | (color << 8));  // the panel wants BE
    for (int row = 0; row < h; row += kChunkRows) {
      const int rows = h - row < kChunkRows ? h - row : kChunkRows;
      xSemaphoreTake(done_, portMAX_DELAY);  // the previous chunk has left the buffer
      for (int i = 0; i < w * rows; ++i) pixels_[i] = swapped;
      esp_lcd_panel_draw_bitmap(panel_, x, y + row, x + w, y + row + rows, pixels_);
    }
  }

  esp_lcd_panel_io_handle_t io_ = nullptr;
  esp_lcd_panel_handle_t panel_ = nullptr;
  SemaphoreHandle_t done_ = nullptr;
  portMUX_TYPE lock_ = portMUX_INITIALIZER_UNLOCKED;
  LcdView view_{};
  bool fresh_ = false;
  static std::uint16_t pixels_[kSize * kChunkRows];  // DMA-capable RAM: DMA_ATTR on the definition, once
};
DMA_ATTR std::uint16_t Lcd::pixels_[Lcd::kSize * Lcd::kChunkRows];

// ---- the board ----------------------------------------------------------------------------------------------------

Qmi8658 g_imu;
Twai g_can;
Uart g_link;
UsbConsole g_console;
TaskWatchdog g_watchdog;
Lcd g_lcd;

// The limits the Orin tightened survive a reset here (not a power cycle): see RetainedLimits in hal.hpp.
RTC_NOINIT_ATTR RetainedLimits g_retained;

ResetReason reset_reason() {
  switch (esp_reset_reason()) {
    case ESP_RST_TASK_WDT:
    case ESP_RST_INT_WDT:
    case ESP_RST_WDT:
    case ESP_RST_PANIC: return ResetReason::watchdog;  // a hang or a crash: start in FAULT
    case ESP_RST_SW: return ResetReason::software;
    default: return ResetReason::power_on;
  }
}

[[noreturn]] void control_task(void* arg) {
  auto& board = *static_cast<BalanceBoard*>(arg);
  esp_task_wdt_add(nullptr);  // this task, and only this task, keeps the watchdog quiet
  for (;;) {
    ulTaskNotifyTake(pdTRUE, pdMS_TO_TICKS(2));  // INT1, or 2 ms: a dead IMU must not stop the loop
    const auto now = static_cast<TimeUs>(esp_timer_get_time());
    g_imu.poll(now);
    g_can.service();
    board.step(now);  // feeds the watchdog at the end of every loop; a silent IMU is a FAULT in the logic (step 9)
    if (board.reboot_requested()) {
      vTaskDelay(pdMS_TO_TICKS(50));  // let the console's "ok" leave
      esp_restart();
    }
  }
}

}  // namespace

extern "C" void app_main() {
  const ResetReason reset = reset_reason();

  spi_bus_config_t bus{};
  bus.sclk_io_num = pins::kImuSck;
  bus.mosi_io_num = pins::kImuMosi;
  bus.miso_io_num = pins::kImuMiso;
  bus.quadwp_io_num = -1;
  bus.quadhd_io_num = -1;
  bus.max_transfer_sz = Lcd::kSize * Lcd::kChunkRows * 2 + 16;
  ESP_ERROR_CHECK(spi_bus_initialize(kSpiHost, &bus, SPI_DMA_CH_AUTO));
  // A missing part is not fatal here, and not a reboot loop: the logic sees no IMU samples and latches FAULT
  // (watchdog_reset in 0x401, why on the console and the LCD) while the loop keeps running on the 2 ms timeout and
  // feeding the watchdog, or no CAN (telemetry missing, VESCs idle); the console still answers.
  g_imu.init();
  g_can.init();
  g_link.init(kLinkUart, pins::kLinkTx, pins::kLinkRx, pins::kLinkBaud);
  g_console.init();
  g_lcd.init();

  esp_task_wdt_config_t wdt{};
  wdt.timeout_ms = CONFIG_SAUL_WDT_TIMEOUT_MS;
  wdt.idle_core_mask = 0;  // only the control task is watched
  wdt.trigger_panic = true;
  esp_task_wdt_reconfigure(&wdt);

  static BalanceBoard board({g_imu, g_can, g_link, g_console, g_watchdog, g_lcd, g_retained}, BalanceConfig{}, reset);

  xTaskCreatePinnedToCore([](void*) { g_lcd.run(); }, "lcd", 4096, nullptr, 2, nullptr, 0);
  xTaskCreatePinnedToCore(control_task, "control", 8192, &board, configMAX_PRIORITIES - 2, &g_control_task, 1);

  gpio_config_t irq{};
  irq.pin_bit_mask = 1ULL << pins::kImuInt1;
  irq.mode = GPIO_MODE_INPUT;
  irq.intr_type = GPIO_INTR_POSEDGE;
  gpio_config(&irq);
  gpio_install_isr_service(0);
  gpio_isr_handler_add(static_cast<gpio_num_t>(pins::kImuInt1), on_imu_ready, nullptr);
}
