// Flashing the boards (docs/flashing.md) over a SerialPort. Reaching an ESP32-S3's ROM serial bootloader
// (core/esp_loader.hpp) and leaving it again: resets, SLIP exchange, SYNC, chip check, registers, baud switch, and
// finding the IO board's port after its reset (BALANCE resets through a CH343 bridge's DTR/RTS, IO through the S3's
// own USB-Serial/JTAG); only the ROM loader is driven (no stub upload), a stub already running (SYNC value 0) is used
// as it is. What to write (files at offsets, or a build folder's flasher_args.json), the checks before the board is
// touched, and the region writer: skip a region whose flash MD5 matches, else compressed or plain blocks with
// retries, then verify the MD5. Every failure is a FlashError whose one line says what to do. Time goes through an
// injectable sleeper.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
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
  std::string name;         ///< "ESP32-S3"
  std::string detected_by;  ///< "GET_SECURITY_INFO" or "READ_REG 0x40001000"
  esp::Loader loader = esp::Loader::rom;
  bool usb_serial_jtag = false;  ///< the loader talks over the S3's USB-Serial/JTAG
  std::uint32_t security_flags = 0;
};

struct FlashImage {
  std::uint32_t offset = 0;
  std::vector<std::uint8_t> data;
  std::string name;  ///< the file as the user named it
};

struct FlashPlan {
  std::vector<FlashImage> images;
  std::uint32_t flash_size = 0;   ///< bytes; 0 = not known yet
  std::string flash_size_source;  ///< where flash_size came from ("--flash-size", "flasher_args.json", ...)
  /// flasher_args.json's flash_settings as written there ("dio", "8MB", "80m"), else empty: compared with the
  /// bootloader image's header, which esptool would rewrite to match them and saulctl writes as it is.
  std::string settings_mode, settings_size, settings_freq;
  std::vector<std::string> warnings;  ///< from check_plan: what does not stop the flash but should be read
};

/// Reads one file to write at offset. FlashError(input) for a missing, unreadable or empty file.
FlashImage load_image(std::uint32_t offset, const std::filesystem::path& path);
/// Reads an ESP-IDF build folder's flasher_args.json (or that file itself): flash_files and flash_settings; a build
/// whose extra_esptool_args.chip is not esp32s3 is FlashError(wrong_chip). File names in it are relative to the
/// folder. FlashError(input) when unusable.
FlashPlan load_build_dir(const std::filesystem::path& dir);
/// "4MB", "16MB", "512KB" -> bytes; 0 for "detect", "keep" or anything else.
std::uint32_t parse_flash_size(const std::string& text);
/// "0x10000", "65536" -> offset; nullopt when not a number.
std::optional<std::uint32_t> parse_offset(const std::string& text);

/// Sorts by offset and checks the plan before anything touches the board: offsets on 4 KiB sectors, no overlaps,
/// images built for the ESP32-S3 (an image header's chip id), and every image inside the flash. Fills flash_size
/// when unknown: from a bootloader image's header at 0x0, else 4 MB (the smallest ESP32-S3 module) with the source
/// saying so. FlashError(input / too_large / wrong_chip).
/// Like esptool, refuses what the ROM cannot boot at 0x0 (no image magic 0xE9) and an ELF file anywhere, unless
/// `force` (then they are warnings). Adds a warning when the bootloader header's flash mode, size or frequency
/// disagree with flasher_args.json's flash_settings.
void check_plan(FlashPlan& plan, bool force = false);

struct FlashProgress {
  enum class Stage : std::uint8_t { checking, writing, verifying };
  Stage stage = Stage::writing;
  std::size_t index = 0;  ///< which image of the plan
  const FlashImage* image = nullptr;
  std::uint64_t bytes_done = 0;  ///< image bytes (uncompressed) handed to the loader
  std::uint64_t bytes_total = 0;
  double seconds = 0;  ///< since this image's write began
  [[nodiscard]] double bytes_per_second() const { return seconds > 0 ? static_cast<double>(bytes_done) / seconds : 0; }
};

struct RegionOutcome {
  enum class State : std::uint8_t { pending, unchanged, written, unverified };
  std::uint32_t offset = 0;
  std::string name;
  std::uint64_t size = 0;
  State state = State::pending;
  bool compressed = false;
  std::uint64_t wire_bytes = 0;
  double seconds = 0;         ///< write + verify
  std::uint32_t retries = 0;  ///< data blocks sent again after a refused or lost answer
  std::string md5;            ///< hex
};

/// What to do on connecting, and how to write.
struct FlasherOptions {
  ResetStyle reset = ResetStyle::usb_uart_bridge;
  bool reset_before = true;  ///< false: the board is already in download mode, leave DTR/RTS alone
  int connect_attempts = 4;  ///< resets tried; each sends up to 5 SYNCs
  std::chrono::milliseconds sync_timeout{100};
  bool compress = true;
  bool skip_unchanged = true;  ///< compare the flash MD5 first and skip regions that already match
  Sleeper sleep = sleep_real;
  std::function<void(const std::string&)> note;  ///< one-line status messages ("connected: ESP32-S3 ...")
  std::function<bool()> cancelled;               ///< polled between SYNCs and blocks (Ctrl-C)
  std::function<void(const FlashProgress&)> progress;
};

class EspFlasher {
 public:
  EspFlasher(SerialPort& port, FlasherOptions options);

  /// Resets into the bootloader (unless reset_before is off), syncs, identifies the chip and refuses anything
  /// but an ESP32-S3 (FlashError wrong_chip naming what it is). Over USB-Serial/JTAG it then disables the RTC
  /// watchdog and lets the super watchdog feed itself, which would otherwise reset the chip mid-write.
  const ChipInfo& connect();
  /// CHANGE_BAUDRATE, then the port follows. No-op when already at that rate.
  void change_baud(std::uint32_t baud);
  /// SPI_ATTACH (default pins) and SPI_SET_PARAMS with the flash size.
  void attach_flash(std::uint32_t flash_size);
  /// Writes one image and verifies it; skips it when its flash MD5 already matches (skip_unchanged).
  /// FlashError(port_gone) leaves the outcome `unverified`; FlashError(verify_failed) when the MD5 differs.
  RegionOutcome write(const FlashImage& image, std::size_t index = 0);
  /// SPI_FLASH_MD5 of a flash range.
  esp::Md5 flash_md5(std::uint32_t offset, std::uint32_t size);
  /// Leaves download mode into the application. Bridge: RTS pulse. USB-Serial/JTAG: clears the forced
  /// download flag and arms the RTC watchdog for a system reset (re-samples GPIO0; an RTS reset would not).
  void reset_to_app();

  [[nodiscard]] const ChipInfo& chip() const { return chip_; }
  [[nodiscard]] std::uint64_t bytes_sent() const { return bytes_sent_; }
  /// Every write() so far, including one that ended in an exception (its state says how far it got).
  [[nodiscard]] const std::vector<RegionOutcome>& outcomes() const { return outcomes_; }

  /// How long a command that needs no more than a message's round trip may take.
  static constexpr std::chrono::milliseconds kCommandTimeout{3000};

 private:
  /// Sends the request an esp::build_* call just wrote to packet_ (`built`: its length) and returns the answer
  /// to its op (read with `loader`'s status layout); nullopt when none came in time.
  std::optional<esp::Response> exchange(const Result<std::size_t>& built, std::chrono::milliseconds timeout,
                                        esp::Loader loader);
  /// exchange() with the chip's loader, no answer and a failure status as FlashError(no_answer / refused).
  esp::Response command(const Result<std::size_t>& built, std::chrono::milliseconds timeout);
  [[nodiscard]] bool cancelled() const { return options_.cancelled && options_.cancelled(); }
  std::uint32_t read_reg(std::uint32_t address);
  void write_reg(std::uint32_t address, std::uint32_t value, std::uint32_t mask = 0xFFFFFFFF);
  /// Reads what comes within timeout into rx_, in place of what was there; false when nothing came.
  bool fill(std::chrono::milliseconds timeout);
  void drain(std::chrono::milliseconds quiet);
  /// Feeds one received byte to the SLIP decoder; returns the frame it completed, if any.
  std::optional<std::span<const std::uint8_t>> take(std::uint8_t byte);
  void detect_chip();
  [[nodiscard]] std::string diagnose_silence() const;
  void write_blocks(const FlashImage& image, std::uint32_t size, std::span<const std::uint8_t> payload, bool compressed,
                    std::size_t index, RegionOutcome& out);

  SerialPort& port_;
  FlasherOptions options_;
  ChipInfo chip_;
  std::vector<std::uint8_t> packet_;  ///< request being built
  std::uint64_t bytes_sent_ = 0;
  bool connected_ = false;
  std::vector<std::uint8_t> storage_;  ///< SLIP decoder storage
  esp::SlipDecoder decoder_;
  std::vector<std::uint8_t> rx_;  ///< bytes read but not yet fed to the decoder
  std::size_t rx_pos_ = 0;
  std::vector<std::uint8_t> frame_;  ///< the request's SLIP frame
  std::string noise_;                ///< last bytes seen outside frames (boot messages), for diagnosis
  std::uint32_t echoes_ = 0;         ///< our own requests read back (a loopback, not a chip)
  std::vector<RegionOutcome> outcomes_;
};

/// USB identity of a board's port: IO = 303A:1001, BALANCE = 1A86:55D3 or 55D4.
bool is_board_port(const PortInfo& port, ResetStyle style);
/// Waits for a USB serial port with this serial number (and VID) to leave and come back, as the IO board does
/// after a reset over USB-Serial/JTAG. Returns its path, or "" on timeout. `list` is injectable for tests.
std::string wait_for_usb_port(const std::string& serial_number, int usb_vid, const std::string& old_path,
                              std::chrono::milliseconds timeout, const Sleeper& sleep,
                              const std::function<std::vector<PortInfo>()>& list = list_serial_ports);

/// The MD5 of data (RFC 1321, computed by Debian's nettle), for comparing with SPI_FLASH_MD5.
esp::Md5 md5_of(std::span<const std::uint8_t> data);
std::string to_hex(const esp::Md5& md5);

/// Image bytes as written: padded with 0xFF to a multiple of 4 (what the MD5 is computed over).
std::vector<std::uint8_t> padded_for_flash(std::span<const std::uint8_t> data);

/// zlib stream of data (level 9), what FLASH_DEFL_DATA carries.
std::vector<std::uint8_t> deflate(std::span<const std::uint8_t> data);

}  // namespace saul::host
