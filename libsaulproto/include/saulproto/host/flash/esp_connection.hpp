// Reaching an ESP32-S3's ROM serial bootloader (core/esp_loader.hpp) over a SerialPort and leaving it again:
// resets, SLIP exchange, SYNC, chip check, registers, baud switch, and finding the IO board's port after its reset
// (docs/flashing.md: BALANCE resets through a CH343 bridge's DTR/RTS, IO through the S3's own USB-Serial/JTAG).
// Only the ROM loader is driven (no stub upload); a stub already running (SYNC value 0) is used as it is.
// Every failure is a FlashError whose one line says what to do. Time goes through an injectable sleeper.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "saulproto/core/esp_loader.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saul::host {

class FlashError : public std::runtime_error {
 public:
  enum class Kind {
    no_answer,      ///< no bootloader answered (exit code 3)
    wrong_chip,     ///< something that is not an ESP32-S3
    refused,        ///< the loader answered a command with a failure status
    protocol,       ///< answers that make no sense
    verify_failed,  ///< the flash MD5 differs from the file after writing
    port_gone,      ///< the port disappeared mid-way: what was being written is unverified
    input,          ///< a file or build folder that cannot be used
    too_large,      ///< an image that does not fit the flash
    unsupported,    ///< secure download mode and other states saulctl will not flash
    interrupted,    ///< the caller asked to stop (Ctrl-C): what was being written is unverified
  };
  FlashError(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  [[nodiscard]] Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

/// A loader's failure status as one phrase that ends with what to do ("... (error 0x07): a noisy line: ...").
std::string refusal_text(std::uint8_t error);

/// How the board's USB port reaches the chip's EN and GPIO0 (BOOT) pins.
enum class ResetStyle : std::uint8_t {
  usb_uart_bridge,  ///< BALANCE board: CH343 bridge, DTR -> GPIO0 and RTS -> EN through two transistors
  usb_serial_jtag,  ///< IO board: the ESP32-S3's own USB-Serial/JTAG, virtual DTR/RTS
};
const char* to_string(ResetStyle style);

/// One state of the two modem lines, held for `hold` before the next step.
struct LineStep {
  bool dtr = false;
  bool rts = false;
  std::chrono::milliseconds hold{0};
  bool operator==(const LineStep&) const = default;
};

/// Into the ROM bootloader. usb_uart_bridge, variant 0 (esptool ClassicReset): (DTR,RTS) = (0,1) EN low for
/// 100 ms, (1,0) GPIO0 low and EN released for 50 ms, (0,0). Variant 1 holds GPIO0 550 ms instead, for boards
/// whose EN capacitor is slow. usb_serial_jtag (esptool USBJTAGSerialReset): (0,0) 100 ms, (1,0) 100 ms, (1,1),
/// (0,1) 100 ms, (0,0): passes through (1,1), never (0,0), between "boot pin low" and "reset".
std::vector<LineStep> bootloader_reset_sequence(ResetStyle style, int variant = 0);
/// Out of the bootloader by the EN line: (0,1) for 100 ms (200 ms over USB), then (0,0) (+200 ms over USB).
std::vector<LineStep> hard_reset_sequence(ResetStyle style);

using Sleeper = std::function<void(std::chrono::milliseconds)>;
/// The real one: std::this_thread::sleep_for.
void sleep_real(std::chrono::milliseconds d);
/// Sets each step's lines with one set_modem_lines call, then sleeps its hold time.
void run_line_sequence(SerialPort& port, std::span<const LineStep> steps, const Sleeper& sleep);

struct ChipInfo {
  std::uint32_t chip_id = 0;
  std::string name;         ///< "ESP32-S3"
  std::string detected_by;  ///< "GET_SECURITY_INFO" or "READ_REG 0x40001000"
  esp::Loader loader = esp::Loader::rom;
  bool usb_serial_jtag = false;  ///< the loader talks over the S3's USB-Serial/JTAG
  bool boot_pin_held = false;    ///< strapping says GPIO0 was low at reset (BOOT held / download by hand)
  std::uint32_t security_flags = 0;
};

struct ConnectOptions {
  ResetStyle reset = ResetStyle::usb_uart_bridge;
  bool reset_before = true;  ///< false: the board is already in download mode, leave DTR/RTS alone
  int connect_attempts = 4;  ///< resets tried; each sends up to 5 SYNCs
  std::chrono::milliseconds sync_timeout{100};
  Sleeper sleep = sleep_real;
  std::function<void(const std::string&)> note;  ///< one-line status messages ("connected: ESP32-S3 ...")
  std::function<bool()> cancelled;               ///< polled between SYNCs and blocks (Ctrl-C)
};

class EspConnection {
 public:
  EspConnection(SerialPort& port, ConnectOptions options);

  /// Resets into the bootloader (unless reset_before is off), syncs, identifies the chip and refuses anything
  /// but an ESP32-S3 (FlashError wrong_chip naming what it is). Over USB-Serial/JTAG it then disables the RTC
  /// watchdog and lets the super watchdog feed itself, which would otherwise reset the chip mid-write.
  const ChipInfo& connect();
  /// CHANGE_BAUDRATE, then the port follows. No-op when already at that rate.
  void change_baud(std::uint32_t baud);
  /// Leaves download mode into the application. Bridge: RTS pulse. USB-Serial/JTAG: clears the forced
  /// download flag and arms the RTC watchdog for a system reset (re-samples GPIO0; an RTS reset would not).
  void reset_to_app();

  // Single commands (tests, diagnostics).
  std::uint32_t read_reg(std::uint32_t address);
  void write_reg(std::uint32_t address, std::uint32_t value, std::uint32_t mask = 0xFFFFFFFF);

  [[nodiscard]] const ChipInfo& chip() const { return chip_; }
  [[nodiscard]] std::uint64_t bytes_sent() const { return bytes_sent_; }

  /// How long a command that needs no more than a message's round trip may take.
  static constexpr std::chrono::milliseconds kCommandTimeout{3000};

 protected:
  /// Sends the request an esp::build_* call just wrote to packet_ (`built`: its length) and waits for the answer to
  /// op; nullopt when none came in time.
  std::optional<esp::Response> transact(esp::Op op, const Result<std::size_t>& built,
                                        std::chrono::milliseconds timeout);
  /// transact(), with no answer and a failure status as FlashError(no_answer / refused).
  esp::Response command(esp::Op op, const Result<std::size_t>& built, std::chrono::milliseconds timeout);
  [[nodiscard]] bool cancelled() const { return options_.cancelled && options_.cancelled(); }

  SerialPort& port_;
  ConnectOptions options_;
  ChipInfo chip_;
  std::vector<std::uint8_t> packet_;  ///< request being built
  std::uint64_t bytes_sent_ = 0;
  bool connected_ = false;

 private:
  bool try_sync();
  std::optional<esp::Response> await(esp::Op op, std::chrono::milliseconds timeout, esp::Loader loader);
  void send(std::span<const std::uint8_t> packet);
  void drain(std::chrono::milliseconds quiet);
  /// Feeds one received byte to the SLIP decoder; returns the frame it completed, if any.
  std::optional<std::span<const std::uint8_t>> take(std::uint8_t byte);
  void detect_chip();
  [[nodiscard]] std::string diagnose_silence() const;

  std::vector<std::uint8_t> storage_;  ///< SLIP decoder storage
  esp::SlipDecoder decoder_;
  std::vector<std::uint8_t> rx_;  ///< bytes read but not yet fed to the decoder
  std::size_t rx_pos_ = 0;
  std::vector<std::uint8_t> frame_;  ///< the request's SLIP frame
  std::string noise_;                ///< last bytes seen outside frames (boot messages), for diagnosis
  std::uint32_t echoes_ = 0;         ///< our own requests read back (a loopback, not a chip)
};

/// USB identity of a board's port: IO = 303A:1001, BALANCE = 1A86:55D3 or 55D4.
bool is_board_port(const PortInfo& port, ResetStyle style);
/// Waits for a USB serial port with this serial number (and VID) to leave and come back, as the IO board does
/// after a reset over USB-Serial/JTAG. Returns its path, or "" on timeout. `list` is injectable for tests.
std::string wait_for_usb_port(const std::string& serial_number, int usb_vid, const std::string& old_path,
                              std::chrono::milliseconds timeout, const Sleeper& sleep,
                              const std::function<std::vector<PortInfo>()>& list = list_serial_ports);

}  // namespace saul::host
