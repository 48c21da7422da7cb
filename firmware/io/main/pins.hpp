// IO board pin map: bare ESP32-S3 devkit, as in the system reference's GPIO table ("ESP32-S3 IO", pin
// assignments). Plain GPIO numbers; only the glue (main.cpp) uses them.
#pragma once

namespace pins {

// TBS Crossfire RC - UART0 (primary), CRSF 420000 baud
inline constexpr int kCrsfRx = 44;  // CRSF frames from the Crossfire RX
inline constexpr int kCrsfTx = 43;  // telemetry to the Crossfire TX
inline constexpr int kCrsfBaud = 420000;

// ELRS failover - UART2 (active if CRSF absent > 100 ms)
inline constexpr int kElrsRx = 16;
inline constexpr int kElrsTx = 17;
inline constexpr int kElrsBaud = 420000;

// BTS7960 motor driver - left
inline constexpr int kLeftRpwm = 1;  // forward PWM
inline constexpr int kLeftLpwm = 2;  // reverse PWM
inline constexpr int kLeftREn = 3;
inline constexpr int kLeftLEn = 4;

// BTS7960 motor driver - right
inline constexpr int kRightRpwm = 5;
inline constexpr int kRightLpwm = 6;
inline constexpr int kRightREn = 7;
inline constexpr int kRightLEn = 8;
inline constexpr int kMotorPwmHz = 20000;

// I2C bus: NFC (PN532 or similar), barometer (BMP280/BMP388), ToF (VL53L0X/VL53L1X)
inline constexpr int kI2cSda = 11;
inline constexpr int kI2cScl = 12;

// WS2812B LEDs
inline constexpr int kLedData = 13;

// Outputs
inline constexpr int kHorn = 14;       // PWM tone
inline constexpr int kHeadlight = 15;  // PWM or digital
inline constexpr int kFan = 16;        // only if ELRS is not fitted on UART2 (same pin as ELRS RX)

// Inputs
inline constexpr int kArmButton = 9;   // active-low, hold 3 s to arm
inline constexpr int kKillSense = 10;  // hardware estop detect
// The kill sense must fail safe: wired through a normally-closed contact to GND with the internal pull-up, so
// the pin reads low while all is well and high when the switch opens OR the wire breaks. High = kill.
inline constexpr int kKillActiveLevel = 1;

// Inter-board UART to the BALANCE board, 460800 baud
inline constexpr int kLinkTx = 18;
inline constexpr int kLinkRx = 21;
inline constexpr int kLinkBaud = 460800;

// IO16 is either the ELRS receiver's TX line into UART2 or the fan output (system reference, outputs table).
inline constexpr bool kElrsFitted = true;

}  // namespace pins
