// EspFlasher's connection: the DTR/RTS resets, the SLIP exchange with the ROM loader, SYNC, the chip check, register
// access and the reset into the application (see esp_flasher.hpp). Writing the flash is in esp_flasher.cpp.
#include "saulproto/host/flash/esp_flasher.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <thread>

namespace saul::host {

using namespace std::chrono;

namespace {

constexpr milliseconds kSecurityInfoTimeout{500};  // older ROMs do not know the command: do not wait long
constexpr std::size_t kNoiseKept = 200;

// Boot messages as one readable line: CR dropped, LF as " | ", control bytes as '.'.
std::string printable(const std::string& raw) {
  std::string out;
  for (char c : raw) {
    if (c == '\r') continue;
    if (c == '\n') {
      if (!out.empty() && out.back() != ' ') out += " | ";
      continue;
    }
    out += (c >= 0x20 && c < 0x7F) ? c : '.';
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == '|')) out.pop_back();
  return out;
}

}  // namespace

std::string refusal_text(std::uint8_t error) {
  const char* fix = nullptr;
  switch (error) {
    case 0x07:  // invalid checksum
    case 0xC1:
    case 0xC0:  // stub: bad data length
      fix = "a noisy line: run again with a lower --baud (e.g. 115200) or a shorter USB cable";
      break;
    case 0x08:  // flash write error
    case 0xC4:
    case 0xC5:
      fix = "the flash did not take the data (write-protected, or a flash size/mode the chip's flash does not "
            "have): check --flash-size and the build's flash settings, then run again; if it repeats, the "
            "module's flash is faulty";
      break;
    case 0x09:
    case 0x0A:
      fix = "the flash did not read back: check --flash-size, then run again; if it repeats, the module's flash "
            "is faulty";
      break;
    case 0x0B:
    case 0xC7:
      fix = "the loader could not inflate the data: run again with --no-compress";
      break;
    default:
      fix = "reset the board into download mode and run again";
      break;
  }
  return fmt::format("{} (error 0x{:02X}): {}", esp::error_text(error), error, fix);
}

// --- reset sequences -------------------------------------------------------------------------------------------

const char* to_string(ResetStyle style) {
  return style == ResetStyle::usb_serial_jtag ? "USB-Serial/JTAG" : "USB-UART bridge (DTR/RTS)";
}

std::vector<LineStep> bootloader_reset_sequence(ResetStyle style, int variant) {
  if (style == ResetStyle::usb_serial_jtag) {
    return {{false, false, milliseconds(100)},  // idle
            {true, false, milliseconds(100)},   // boot pin low
            {true, true, milliseconds(0)},      // through (1,1) ...
            {false, true, milliseconds(100)},   // ... into reset
            {false, false, milliseconds(0)}};   // out of reset, into the ROM loader
  }
  const milliseconds boot_hold = variant % 2 == 0 ? milliseconds(50) : milliseconds(550);
  return {{false, true, milliseconds(100)},  // GPIO0 high, EN low: in reset
          {true, false, boot_hold},          // GPIO0 low, EN released: the ROM samples GPIO0 low
          {false, false, milliseconds(0)}};  // GPIO0 released
}

std::vector<LineStep> hard_reset_sequence(ResetStyle style) {
  if (style == ResetStyle::usb_serial_jtag)
    return {{false, true, milliseconds(200)}, {false, false, milliseconds(200)}};
  return {{false, true, milliseconds(100)}, {false, false, milliseconds(0)}};
}

void sleep_real(milliseconds d) { std::this_thread::sleep_for(d); }

void run_line_sequence(SerialPort& port, std::span<const LineStep> steps, const Sleeper& sleep) {
  for (const auto& s : steps) {
    port.set_modem_lines(s.dtr, s.rts);
    if (s.hold.count() > 0) sleep(s.hold);
  }
}

// --- the connection ---------------------------------------------------------------------------------------------

EspFlasher::EspFlasher(SerialPort& port, FlasherOptions options)
    : port_(port),
      options_(std::move(options)),
      packet_(esp::kMaxRequest),
      storage_(1024),
      decoder_(storage_),
      frame_(esp::kMaxSlipFrame) {
  if (!options_.sleep) options_.sleep = sleep_real;
  if (options_.connect_attempts < 1) options_.connect_attempts = 1;
}

void EspFlasher::send(std::span<const std::uint8_t> packet) {
  auto n = esp::slip_encode(packet, frame_);
  if (!n) throw FlashError(FlashError::Kind::protocol, "internal: request does not fit its frame buffer");
  // Long enough for the frame at the current rate, twice over, plus a second of slack.
  const auto baud = std::max<std::uint32_t>(port_.settings().baud, 9600);
  const milliseconds timeout(1000 + static_cast<long long>(*n) * 10 * 2 * 1000 / baud);
  port_.write(std::span<const std::uint8_t>(frame_.data(), *n), timeout);
  bytes_sent_ += *n;
}

std::optional<std::span<const std::uint8_t>> EspFlasher::take(std::uint8_t byte) {
  if (!decoder_.in_frame() && byte != esp::kSlipEnd) {
    if (noise_.size() < kNoiseKept) noise_ += static_cast<char>(byte);  // the start of a boot log says the most
  }
  auto frame = decoder_.push(byte);
  if (frame && !frame->empty() && (*frame)[0] == esp::kDirectionRequest) ++echoes_;
  return frame;
}

std::optional<esp::Response> EspFlasher::await(esp::Op op, milliseconds timeout, esp::Loader loader) {
  const auto deadline = steady_clock::now() + timeout;
  for (;;) {
    while (rx_pos_ < rx_.size()) {
      auto frame = take(rx_[rx_pos_++]);
      if (!frame) continue;
      auto r = esp::parse_response(*frame, loader);
      if (r && r->op == static_cast<std::uint8_t>(op)) return *r;  // others: late answers to earlier requests
    }
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    rx_.resize(4096);
    const std::size_t n = port_.read(rx_, left);
    rx_.resize(n);
    rx_pos_ = 0;
  }
}

void EspFlasher::drain(milliseconds quiet) {
  std::array<std::uint8_t, 1024> buf{};
  for (;;) {
    while (rx_pos_ < rx_.size()) (void)take(rx_[rx_pos_++]);
    const std::size_t n = port_.read(buf, quiet);
    if (n == 0) break;
    for (std::size_t i = 0; i < n; ++i) (void)take(buf[i]);
  }
  decoder_.reset();
}

std::optional<esp::Response> EspFlasher::transact(esp::Op op, const Result<std::size_t>& built,
                                                     milliseconds timeout) {
  send(std::span<const std::uint8_t>(packet_.data(), *built));
  return await(op, timeout, chip_.loader);
}

esp::Response EspFlasher::command(esp::Op op, const Result<std::size_t>& built, milliseconds timeout) {
  auto r = transact(op, built, timeout);
  if (!r)
    throw FlashError(FlashError::Kind::no_answer,
                     fmt::format("{}: no answer to {} within {} ms: the board left download mode or the connection "
                                 "broke: reset it into download mode (or replug it) and run again",
                                 port_.path(), esp::to_string(op), timeout.count()));
  if (!r->ok())
    throw FlashError(
        FlashError::Kind::refused,
        fmt::format("{}: {} refused by the {} loader: {}", port_.path(), esp::to_string(op),
                    chip_.loader == esp::Loader::rom ? "ROM" : "stub", refusal_text(r->error)));
  return *r;
}

bool EspFlasher::try_sync() {
  auto n = esp::build_sync(packet_);
  send(std::span<const std::uint8_t>(packet_.data(), *n));
  // Read with the 2-byte status layout: it fits both the ROM's answer (4 status bytes) and a stub's.
  auto r = await(esp::Op::sync, options_.sync_timeout, esp::Loader::stub);
  if (!r || !r->ok()) return false;
  chip_.loader = r->value == 0 ? esp::Loader::stub : esp::Loader::rom;  // the ROM answers SYNC with a non-zero value
  return true;
}

std::string EspFlasher::diagnose_silence() const {
  const bool usj = options_.reset == ResetStyle::usb_serial_jtag;
  const std::string by_hand =
      usj ? "Hold BOOT on the IO board and tap RESET (or plug USB in while holding BOOT), release BOOT, then run "
            "again with --no-reset"
          : "Hold BOOT on the BALANCE board and tap RESET, release BOOT, then run again with --no-reset";
  if (echoes_ > 0)
    return fmt::format(
        "{}: what saulctl sends comes straight back (a loopback or an echoing terminal, not an "
        "ESP32): wrong port? 'saulctl ports' lists them",
        port_.path());
  if (!noise_.empty()) {
    std::string seen = printable(noise_);
    if (seen.size() > 120) seen = seen.substr(0, 117) + "...";
    if (noise_.find("waiting for download") != std::string::npos || noise_.find("DOWNLOAD(") != std::string::npos)
      return fmt::format(
          "{}: the chip is in download mode (its boot log says so: \"{}\") but never answered SYNC: a line "
          "problem between the adapter and the chip (loose TX/RX, wrong level): unplug, replug and run again",
          port_.path(), seen);
    return fmt::format(
        "{}: the board sent text but never answered the bootloader's SYNC: it is running its "
        "application, not in download mode (the {} reset did not reach GPIO0?). Seen: \"{}\". {}",
        port_.path(), to_string(options_.reset), seen, by_hand);
  }
  return fmt::format(
      "{}: no serial data received: the board is not in download mode (not powered, a charge-only "
      "cable, the wrong port, or the auto-reset did not work). {}",
      port_.path(), by_hand);
}

const ChipInfo& EspFlasher::connect() {
  bool synced = false;
  for (int attempt = 0; attempt < options_.connect_attempts && !synced; ++attempt) {
    if (options_.reset_before) {
      const auto seq = bootloader_reset_sequence(options_.reset, attempt);
      run_line_sequence(port_, seq, options_.sleep);
    }
    drain(milliseconds(0));
    for (int i = 0; i < 5 && !synced; ++i) {
      if (cancelled()) throw FlashError(FlashError::Kind::interrupted, "interrupted while connecting: nothing was written; run again");
      synced = try_sync();
    }
  }
  if (!synced) throw FlashError(FlashError::Kind::no_answer, diagnose_silence());
  connected_ = true;
  detect_chip();
  return chip_;
}

void EspFlasher::detect_chip() {
  auto r = transact(esp::Op::get_security_info, esp::build_get_security_info(packet_), kSecurityInfoTimeout);
  bool identified = false;
  if (r && r->ok()) {
    if (auto si = esp::parse_security_info(r->data)) {
      chip_.security_flags = si->flags;
      if (si->has_chip_id) {
        const char* name = esp::chip_name(si->chip_id);
        chip_.name = name ? name : fmt::format("unknown chip (id {})", si->chip_id);
        chip_.detected_by = "GET_SECURITY_INFO";
        identified = true;
      }
    }
  }
  if (!identified) {
    const std::uint32_t magic = read_reg(esp::kChipDetectMagicAddress);
    const char* name = esp::chip_name_from_magic(magic);
    chip_.name = name ? name : fmt::format("unknown chip (magic 0x{:08X})", magic);
    chip_.detected_by = fmt::format("READ_REG 0x{:08X}", esp::kChipDetectMagicAddress);
  }
  if (chip_.name != "ESP32-S3")
    throw FlashError(FlashError::Kind::wrong_chip,
                     fmt::format("{}: this is an {}, not an ESP32-S3 (found by {}): both SAUL-TEE boards carry an "
                                 "ESP32-S3, so this is another board or the wrong port ('saulctl ports' lists them)",
                                 port_.path(), chip_.name, chip_.detected_by));
  if (chip_.security_flags & esp::kSecureDownloadFlag)
    throw FlashError(FlashError::Kind::unsupported,
                     fmt::format("{}: the ESP32-S3 is in secure download mode: its ROM will not compute the flash MD5 "
                                 "saulctl verifies every write with; flash it with esptool's secure-download options",
                                 port_.path()));
  chip_.usb_serial_jtag = (read_reg(esp::s3::kUartDevBufNo) & 0xFF) == esp::s3::kBufNoUsbSerialJtag;
  if (chip_.usb_serial_jtag) {
    // A reset over USB-Serial/JTAG leaves the RTC domain running: a watchdog armed by the application would
    // fire mid-write. Disable the RTC watchdog, let the super watchdog feed itself.
    write_reg(esp::s3::kRtcWdtProtectReg, esp::s3::kRtcWdtKey);
    write_reg(esp::s3::kRtcWdtConfig0Reg, 0);
    write_reg(esp::s3::kRtcWdtProtectReg, 0);
    write_reg(esp::s3::kSwdProtectReg, esp::s3::kSwdKey);
    write_reg(esp::s3::kSwdConfReg, read_reg(esp::s3::kSwdConfReg) | esp::s3::kSwdAutoFeed);
    write_reg(esp::s3::kSwdProtectReg, 0);
  }
  if (options_.note) {
    options_.note(fmt::format("connected: {} ({}), {} loader, talking over {}", chip_.name, chip_.detected_by,
                              chip_.loader == esp::Loader::rom ? "ROM" : "stub",
                              chip_.usb_serial_jtag ? "its USB-Serial/JTAG" : "UART0"));
    if (chip_.usb_serial_jtag != (options_.reset == ResetStyle::usb_serial_jtag))
      options_.note(fmt::format("note: the chip talks over {} but the reset style is {}: is --board right?",
                                chip_.usb_serial_jtag ? "USB-Serial/JTAG (the IO board)" : "UART0 (the BALANCE board)",
                                to_string(options_.reset)));
  }
}

std::uint32_t EspFlasher::read_reg(std::uint32_t address) {
  return command(esp::Op::read_reg, esp::build_read_reg(address, packet_), kCommandTimeout).value;
}

void EspFlasher::write_reg(std::uint32_t address, std::uint32_t value, std::uint32_t mask) {
  (void)command(esp::Op::write_reg, esp::build_write_reg(address, value, mask, 0, packet_), kCommandTimeout);
}

void EspFlasher::change_baud(std::uint32_t baud) {
  const std::uint32_t current = port_.settings().baud;
  if (baud == 0 || baud == current) return;
  const auto n = esp::build_change_baudrate(baud, chip_.loader == esp::Loader::stub ? current : 0, packet_);
  (void)command(esp::Op::change_baudrate, n, kCommandTimeout);
  port_.set_baud(baud);
  drain(milliseconds(20));  // whatever the switch garbled
  if (options_.note) options_.note(fmt::format("baud rate {} -> {}", current, baud));
}

void EspFlasher::reset_to_app() {
  if (!chip_.usb_serial_jtag) {
    const auto seq = hard_reset_sequence(options_.reset);
    run_line_sequence(port_, seq, options_.sleep);
    return;
  }
  // Over USB-Serial/JTAG an RTS reset is a core reset: GPIO0 is not sampled again and a board put into download
  // mode by hand stays there. Clear the forced-download flag, then let the RTC watchdog reset the whole system.
  write_reg(esp::s3::kRtcCntlOption1Reg, 0, esp::s3::kForceDownloadBootMask);
  write_reg(esp::s3::kRtcWdtProtectReg, esp::s3::kRtcWdtKey);
  write_reg(esp::s3::kRtcWdtConfig1Reg, 2000);  // slow-clock cycles, a few ms
  try {
    write_reg(esp::s3::kRtcWdtConfig0Reg, esp::s3::kRtcWdtResetConfig);
    write_reg(esp::s3::kRtcWdtProtectReg, 0);
  } catch (const FlashError&) {
    // The watchdog may fire before the answer leaves the chip.
  } catch (const SerialError& e) {
    if (e.kind() != SerialError::Kind::gone) throw;  // the port dropping off the bus is the reset happening
  }
}

// --- finding the boards ----------------------------------------------------------------------------------------

bool is_board_port(const PortInfo& port, ResetStyle style) {
  if (style == ResetStyle::usb_serial_jtag) return port.usb_vid == 0x303A && port.usb_pid == 0x1001;
  return port.usb_vid == 0x1A86 && (port.usb_pid == 0x55D3 || port.usb_pid == 0x55D4);
}

std::string wait_for_usb_port(const std::string& serial_number, int usb_vid, const std::string& old_path,
                              milliseconds timeout, const Sleeper& sleep,
                              const std::function<std::vector<PortInfo>()>& list) {
  constexpr milliseconds kPoll{100};
  constexpr milliseconds kMaxStay{1500};  // a port still there after this re-enumerated faster than we polled
  bool gone = false;
  for (milliseconds waited{0}; waited <= timeout; waited += kPoll) {
    const auto ports = list();
    const auto it = std::find_if(ports.begin(), ports.end(), [&](const PortInfo& p) {
      return p.usb_vid == usb_vid && !serial_number.empty() && p.serial_number == serial_number;
    });
    if (it == ports.end()) {
      gone = true;
    } else if (gone || it->path != old_path || waited >= kMaxStay) {
      return it->path;
    }
    sleep(kPoll);
  }
  return "";
}

}  // namespace saul::host
