// The ESP-IDF side of the firmware's SerialPort (firmware/logic/include/saulfw/hal.hpp) for both boards: a UART
// (the inter-board link, CRSF, the Pride ES wire) and the USB Serial/JTAG console. Neither call blocks: the control
// loop polls them every tick, and what a full transmit buffer does not take is dropped (hal.hpp says why).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "driver/uart.h"
#include "driver/usb_serial_jtag.h"
#include "saulfw/hal.hpp"

namespace saul::fw::esp {

class Uart final : public SerialPort {
 public:
  /// 8N1 at `baud` on pins tx/rx, 1 KiB buffers each way. A port whose init failed (or never ran) reads and
  /// writes nothing, so an optional link (ELRS not fitted) needs no checks at its callers.
  bool init(uart_port_t port, int tx, int rx, int baud) {
    port_ = port;
    uart_config_t c{};
    c.baud_rate = baud;
    c.data_bits = UART_DATA_8_BITS;
    c.parity = UART_PARITY_DISABLE;
    c.stop_bits = UART_STOP_BITS_1;
    c.flow_ctrl = UART_HW_FLOWCTRL_DISABLE;
    c.source_clk = UART_SCLK_DEFAULT;
    return uart_driver_install(port_, 1024, 1024, 0, nullptr, 0) == ESP_OK && uart_param_config(port_, &c) == ESP_OK &&
           uart_set_pin(port_, tx, rx, UART_PIN_NO_CHANGE, UART_PIN_NO_CHANGE) == ESP_OK;
  }
  std::size_t read(std::span<std::uint8_t> out) override {
    if (!installed()) return 0;
    const int n = uart_read_bytes(port_, out.data(), out.size(), 0);
    return n > 0 ? static_cast<std::size_t>(n) : 0;
  }
  std::size_t write(std::span<const std::uint8_t> data) override {
    if (!installed()) return 0;
    const int n = uart_write_bytes(port_, data.data(), data.size());
    return n > 0 ? static_cast<std::size_t>(n) : 0;
  }

 private:
  bool installed() const { return port_ != UART_NUM_MAX && uart_is_driver_installed(port_); }
  uart_port_t port_ = UART_NUM_MAX;
};

/// The console on the ESP32-S3's own USB port (USB Serial/JTAG): 512 B in, 2 KiB out.
class UsbConsole final : public SerialPort {
 public:
  bool init() {
    usb_serial_jtag_driver_config_t c = USB_SERIAL_JTAG_DRIVER_CONFIG_DEFAULT();
    c.rx_buffer_size = 512;
    c.tx_buffer_size = 2048;
    return usb_serial_jtag_driver_install(&c) == ESP_OK;
  }
  std::size_t read(std::span<std::uint8_t> out) override {
    const int n = usb_serial_jtag_read_bytes(out.data(), out.size(), 0);
    return n > 0 ? static_cast<std::size_t>(n) : 0;
  }
  std::size_t write(std::span<const std::uint8_t> data) override {
    const int n = usb_serial_jtag_write_bytes(data.data(), data.size(), 0);
    return n > 0 ? static_cast<std::size_t>(n) : 0;
  }
};

}  // namespace saul::fw::esp
