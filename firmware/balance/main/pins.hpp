// BALANCE board pin map: Waveshare ESP32-S3 Touch LCD 1.28, as in the system reference's GPIO table
// ("ESP32-S3 BALANCE", pin assignments). Plain GPIO numbers; only the glue (main.cpp) uses them.
#pragma once

namespace pins {

// QMI8658 IMU (SPI)
inline constexpr int kImuSck = 39;
inline constexpr int kImuMosi = 38;
inline constexpr int kImuMiso = 40;
inline constexpr int kImuCs = 41;
inline constexpr int kImuInt1 = 42;  // data-ready interrupt

// GC9A01 LCD (shares the IMU's SPI bus)
inline constexpr int kLcdCs = 12;
inline constexpr int kLcdDc = 11;
inline constexpr int kLcdRst = 10;
inline constexpr int kLcdBacklight = 9;  // PWM backlight

// CST816S touch (I2C) - wired, not used by the firmware
inline constexpr int kTouchSda = 4;
inline constexpr int kTouchScl = 5;
inline constexpr int kTouchInt = 6;
inline constexpr int kTouchRst = 7;

// CAN: SN65HVD230 transceiver, 500 kbit/s
inline constexpr int kCanTx = 43;  // -> SN65HVD230 TXD
inline constexpr int kCanRx = 44;  // <- SN65HVD230 RXD

// Inter-board UART to the IO board, 460800 baud
inline constexpr int kLinkTx = 17;
inline constexpr int kLinkRx = 18;
inline constexpr int kLinkBaud = 460800;

// IO43/IO44 are UART0's pins, which this board wires to its CH343 USB-serial chip; the reference gives them to
// CAN. The console therefore runs on the ESP32-S3's own USB-Serial-JTAG port (firmware/README.md, open points).
inline constexpr bool kConsoleOnUsbJtag = true;

// How the QMI8658 sits on the board: body axis (REP-103: x forward, y left, z up) = sign * chip axis.
// Index 0, 1, 2 = chip x, y, z. Identity until measured on the robot (firmware/README.md, bring-up).
struct Axis {
  int chip_axis;
  int sign;
};
inline constexpr Axis kBodyX{0, 1};
inline constexpr Axis kBodyY{1, 1};
inline constexpr Axis kBodyZ{2, 1};

}  // namespace pins
