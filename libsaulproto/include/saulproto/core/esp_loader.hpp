// The Espressif ROM serial bootloader protocol (what esptool speaks to an ESP32-S3 in download mode): SLIP
// framing, command and response packets, the 0xEF XOR checksum, builders for the requests saulctl flash sends,
// parsers for what comes back, and the ESP image header with its application description.
//
// Facts (Espressif's "Serial Protocol" page and esptool's loader.py / targets/esp32s3.py; byte-exact examples
// in docs/flashing.md and tests/unit/test_esp_loader.cpp):
//  - SLIP: every packet starts and ends with 0xC0; inside, 0xC0 -> DB DC and 0xDB -> DB DD. Escaping comes after
//    sizes and checksum are computed, so a frame on the wire can be up to twice the packet plus two.
//  - Request: 00, opcode, u16 LE data size, u32 LE checksum (only meaningful for *_DATA), data.
//  - Response: 01, opcode, u16 LE data size, u32 LE value (READ_REG result), data ending in status bytes:
//    4 from the ESP32-S3 ROM [status, error, 0, 0], 2 from esptool's stub [status, error]. Status 0 = ok.
//  - Checksum: 0xEF XOR every data byte of a FLASH_DATA / FLASH_DEFL_DATA block (not its 16-byte sub-header).
//
// Lives in the core because firmware may one day speak it (an IO board flashing the BALANCE board over the
// inter-board UART) and because a test double of the ROM is easiest to write on the same packet layout. No heap,
// no exceptions: builders write into the caller's buffer and return its used length; the SLIP decoder writes
// into caller storage and does O(1) work per byte.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "saulproto/core/result.hpp"

namespace saul::esp {

/// Opcodes (esptool loader.py ESP_CMDS). Only the ones the ROM of an ESP32-S3 implements plus the stub's erase.
enum class Op : std::uint8_t {
  flash_begin = 0x02,
  flash_data = 0x03,
  flash_end = 0x04,
  mem_begin = 0x05,
  mem_end = 0x06,
  mem_data = 0x07,
  sync = 0x08,
  write_reg = 0x09,
  read_reg = 0x0A,
  spi_set_params = 0x0B,
  spi_attach = 0x0D,
  read_flash_slow = 0x0E,
  change_baudrate = 0x0F,
  flash_defl_begin = 0x10,
  flash_defl_data = 0x11,
  flash_defl_end = 0x12,
  spi_flash_md5 = 0x13,
  get_security_info = 0x14,
};
/// "FLASH_BEGIN", ... or "UNKNOWN".
const char* to_string(Op op) noexcept;

inline constexpr std::uint8_t kSlipEnd = 0xC0;
inline constexpr std::uint8_t kSlipEsc = 0xDB;
inline constexpr std::uint8_t kSlipEscEnd = 0xDC;
inline constexpr std::uint8_t kSlipEscEsc = 0xDD;

inline constexpr std::uint8_t kDirectionRequest = 0x00;
inline constexpr std::uint8_t kDirectionResponse = 0x01;
inline constexpr std::size_t kHeaderSize = 8;        ///< direction, op, size, checksum/value
inline constexpr std::size_t kBlockHeaderSize = 16;  ///< *_DATA: data length, sequence, 0, 0
inline constexpr std::uint8_t kChecksumSeed = 0xEF;

inline constexpr std::uint32_t kRomBlockSize = 0x400;    ///< FLASH_WRITE_SIZE for the ROM loader
inline constexpr std::uint32_t kStubBlockSize = 0x4000;  ///< FLASH_WRITE_SIZE for esptool's stub
inline constexpr std::uint32_t kSectorSize = 0x1000;     ///< erase granularity of the SPI flash
/// Largest request this codec builds: a stub-sized data block.
inline constexpr std::size_t kMaxRequest = kHeaderSize + kBlockHeaderSize + kStubBlockSize;
/// Largest SLIP frame of such a request (every byte escaped, plus the two delimiters).
inline constexpr std::size_t kMaxSlipFrame = 2 + 2 * kMaxRequest;
/// Responses the host parses are small (the ROM's MD5 answer is the largest: 8 + 32 + 4).
inline constexpr std::size_t kMaxResponse = 256;

/// Which loader answers: decides the status length, SPI_ATTACH / FLASH_BEGIN forms, block size, MD5 format.
enum class Loader : std::uint8_t { rom, stub };
constexpr std::size_t status_length(Loader l) noexcept { return l == Loader::rom ? 4 : 2; }
constexpr std::uint32_t block_size(Loader l) noexcept { return l == Loader::rom ? kRomBlockSize : kStubBlockSize; }

/// 0xEF XOR over data (ESPLoader.checksum). O(n).
std::uint8_t checksum(std::span<const std::uint8_t> data, std::uint8_t seed = kChecksumSeed) noexcept;

// ---------------------------------------------------------------------------------------------------------------
// SLIP

/// Bytes slip_encode() will write for packet, delimiters included. O(n).
std::size_t slip_encoded_size(std::span<const std::uint8_t> packet) noexcept;
/// C0, packet with C0/DB escaped, C0. Returns the frame length; buffer_too_small when out cannot hold it
/// (nothing useful is left in out then).
Result<std::size_t> slip_encode(std::span<const std::uint8_t> packet, std::span<std::uint8_t> out) noexcept;

struct SlipCounters {
  std::uint32_t frames = 0;           ///< complete, well-formed frames returned
  std::uint32_t noise_bytes = 0;      ///< bytes outside any frame (boot messages, echoes, line noise)
  std::uint32_t bad_escapes = 0;      ///< DB followed by something else than DC/DD: frame dropped
  std::uint32_t overlong_frames = 0;  ///< frames larger than the storage: dropped
};

/// Streaming SLIP decoder. Feed bytes in any chunking; a frame comes back when its closing C0 arrives.
/// A C0 right after another C0 is taken as the start of a frame (so back-to-back "C0 .. C0 C0 .. C0" and a
/// lone resynchronising C0 both work). Storage is the caller's: its size bounds the largest frame.
class SlipDecoder {
 public:
  explicit SlipDecoder(std::span<std::uint8_t> storage) noexcept : storage_(storage) {}

  /// One byte. When it closes a frame, returns the unescaped packet (a view of the storage, valid until the
  /// next push or reset).
  std::optional<std::span<const std::uint8_t>> push(std::uint8_t byte) noexcept;

  /// Forgets a partial frame (e.g. after a timeout); counters stay.
  void reset() noexcept;
  /// True while inside a frame (between its opening C0 and its end).
  [[nodiscard]] bool in_frame() const noexcept { return in_frame_; }
  [[nodiscard]] const SlipCounters& counters() const noexcept { return counters_; }

 private:
  std::span<std::uint8_t> storage_;
  std::size_t length_ = 0;
  bool in_frame_ = false;
  bool escape_ = false;
  bool broken_ = false;  ///< bad escape or overflow seen: swallow the rest of the frame
  SlipCounters counters_{};
};

// ---------------------------------------------------------------------------------------------------------------
// Packets

/// A request as the chip sees it (views into the packet).
struct Request {
  std::uint8_t op = 0;
  std::uint32_t checksum = 0;
  std::span<const std::uint8_t> data{};
};

/// A response as the host sees it: data without the status bytes.
struct Response {
  std::uint8_t op = 0;
  std::uint32_t value = 0;
  std::span<const std::uint8_t> data{};
  std::uint8_t status = 0;  ///< 0 ok, 1 failure
  std::uint8_t error = 0;   ///< ROM (0x05..) or stub (0xC0..) error code when status != 0
  [[nodiscard]] constexpr bool ok() const noexcept { return status == 0; }
};

/// 00, op, size, checksum, data -> out. Returns the packet length (8 + data).
Result<std::size_t> encode_request(std::uint8_t op, std::span<const std::uint8_t> data, std::uint32_t checksum,
                                   std::span<std::uint8_t> out) noexcept;
/// Checks direction 0x00 (unknown_type otherwise), length (truncated / bad_length when size disagrees).
Result<Request> parse_request(std::span<const std::uint8_t> packet) noexcept;

/// 01, op, size, value, data, status bytes (status_length(loader) of them) -> out. For the chip side: the
/// firmware or a test double of the ROM.
Result<std::size_t> encode_response(std::uint8_t op, std::uint32_t value, std::span<const std::uint8_t> data,
                                    std::uint8_t status, std::uint8_t error, Loader loader,
                                    std::span<std::uint8_t> out) noexcept;
/// Checks direction 0x01, the size field against the packet, and that the data holds the status bytes.
Result<Response> parse_response(std::span<const std::uint8_t> packet, Loader loader) noexcept;

// ---------------------------------------------------------------------------------------------------------------
// Request builders. Each writes the raw packet (before SLIP) into out and returns its length; buffer_too_small
// when out is short. Sizes: 8 + data; data lengths are given per builder.

/// SYNC: 07 07 12 20 + 32 x 55 (36 bytes).
Result<std::size_t> build_sync(std::span<std::uint8_t> out) noexcept;
/// READ_REG addr (4 bytes); the answer's value field holds the register.
Result<std::size_t> build_read_reg(std::uint32_t address, std::span<std::uint8_t> out) noexcept;
/// WRITE_REG addr, value, mask, delay_us (16 bytes).
Result<std::size_t> build_write_reg(std::uint32_t address, std::uint32_t value, std::uint32_t mask,
                                    std::uint32_t delay_us, std::span<std::uint8_t> out) noexcept;
/// GET_SECURITY_INFO (no data).
Result<std::size_t> build_get_security_info(std::span<std::uint8_t> out) noexcept;
/// SPI_ATTACH pin config (0 = the pins from efuse / default). The ROM takes a second word (0): 8 bytes; the stub 4.
Result<std::size_t> build_spi_attach(std::uint32_t pins, Loader loader, std::span<std::uint8_t> out) noexcept;
/// SPI_SET_PARAMS: id 0, total size, block 64 KiB, sector 4 KiB, page 256, status mask 0xFFFF (24 bytes).
Result<std::size_t> build_spi_set_params(std::uint32_t total_size, std::span<std::uint8_t> out) noexcept;
/// CHANGE_BAUDRATE new, old (old = 0 when talking to the ROM) (8 bytes).
Result<std::size_t> build_change_baudrate(std::uint32_t new_baud, std::uint32_t old_baud,
                                          std::span<std::uint8_t> out) noexcept;
/// FLASH_BEGIN erase size, block count, block size, offset; the ROM of an ESP32-S3 takes a fifth word,
/// "encrypted" (always 0 here): 20 bytes for the ROM, 16 for the stub. The ROM erases here.
Result<std::size_t> build_flash_begin(std::uint32_t erase_size, std::uint32_t blocks, std::uint32_t block,
                                      std::uint32_t offset, Loader loader, std::span<std::uint8_t> out) noexcept;
/// FLASH_DATA: data length, sequence (0-based), 0, 0, data; checksum of data in the header. The caller pads a
/// short last block with 0xFF to the block size (uncompressed writes only).
Result<std::size_t> build_flash_data(std::uint32_t sequence, std::span<const std::uint8_t> data,
                                     std::span<std::uint8_t> out) noexcept;
/// FLASH_END: 0 = reboot, 1 = run user code. The ROM leaves the loader on it; saulctl does not send it to the ROM.
Result<std::size_t> build_flash_end(bool run_user_code, std::span<std::uint8_t> out) noexcept;
/// FLASH_DEFL_BEGIN: size (see defl_begin_size), count of compressed blocks, block size, offset [, 0 for the ROM].
Result<std::size_t> build_flash_defl_begin(std::uint32_t size, std::uint32_t blocks, std::uint32_t block,
                                           std::uint32_t offset, Loader loader, std::span<std::uint8_t> out) noexcept;
/// FLASH_DEFL_DATA: like FLASH_DATA, carrying the next slice of the zlib stream (never padded).
Result<std::size_t> build_flash_defl_data(std::uint32_t sequence, std::span<const std::uint8_t> data,
                                          std::span<std::uint8_t> out) noexcept;
/// FLASH_DEFL_END: 0 = reboot, 1 = run user code.
Result<std::size_t> build_flash_defl_end(bool run_user_code, std::span<std::uint8_t> out) noexcept;
/// SPI_FLASH_MD5 address, size, 0, 0 (16 bytes).
Result<std::size_t> build_spi_flash_md5(std::uint32_t address, std::uint32_t size,
                                        std::span<std::uint8_t> out) noexcept;

/// ceil(bytes / block).
constexpr std::uint32_t block_count(std::uint32_t bytes, std::uint32_t block) noexcept {
  return block == 0 ? 0 : static_cast<std::uint32_t>((static_cast<std::uint64_t>(bytes) + block - 1) / block);
}
/// First word of FLASH_DEFL_BEGIN: the ROM erases up front and wants the uncompressed size rounded up to whole
/// blocks; the stub erases as it goes and wants the exact uncompressed size (esptool flash_defl_begin).
constexpr std::uint32_t defl_begin_size(std::uint32_t uncompressed, Loader loader) noexcept {
  return loader == Loader::rom ? block_count(uncompressed, kRomBlockSize) * kRomBlockSize : uncompressed;
}

// ---------------------------------------------------------------------------------------------------------------
// Answers

/// GET_SECURITY_INFO: flags, flash_crypt_cnt, 7 key purposes, then (not on the ESP32-S2) chip id and API version.
struct SecurityInfo {
  std::uint32_t flags = 0;
  std::uint8_t flash_crypt_cnt = 0;
  std::array<std::uint8_t, 7> key_purposes{};
  bool has_chip_id = false;
  std::uint32_t chip_id = 0;
  std::uint32_t api_version = 0;
};
inline constexpr std::uint32_t kSecureDownloadFlag = 1U << 2;  ///< SECURE_DOWNLOAD_ENABLE in flags
/// data = Response::data (status bytes already removed): 12 or 20 bytes.
Result<SecurityInfo> parse_security_info(std::span<const std::uint8_t> data) noexcept;

using Md5 = std::array<std::uint8_t, 16>;
/// SPI_FLASH_MD5 answer: the ROM sends 32 lower-case hex characters, the stub 16 raw bytes.
Result<Md5> parse_md5(std::span<const std::uint8_t> data) noexcept;

/// Chip ids (GET_SECURITY_INFO chip_id = the image header's chip id): ESP32 0, S2 2, C3 5, S3 9, C2 12, C6 13,
/// H2 16, P4 18, C61 20, C5 23. Name, or nullptr when unknown.
const char* chip_name(std::uint32_t chip_id) noexcept;
inline constexpr std::uint32_t kChipIdEsp32s3 = 9;
/// READ_REG of this address gives a per-chip magic value (the fallback esptool used before GET_SECURITY_INFO).
inline constexpr std::uint32_t kChipDetectMagicAddress = 0x40001000;
inline constexpr std::uint32_t kMagicEsp32s3 = 0x00000009;
/// Name for a magic value (ESP8266, ESP32, S2, S3, C3, C2, C6, H2), or nullptr when unknown.
const char* chip_name_from_magic(std::uint32_t magic) noexcept;

/// What a ROM (0x05..0x0F) or stub (0xC0.., 0xFF) error code means, short and lower-case; "unknown error".
const char* error_text(std::uint8_t code) noexcept;

/// ESP32-S3 registers the flasher touches (esptool targets/esp32s3.py).
namespace s3 {
inline constexpr std::uint32_t kUartDevBufNo = 0x3FCEF14C;  ///< ROM variable: which port the loader talks on
inline constexpr std::uint32_t kBufNoUsbOtg = 3;
inline constexpr std::uint32_t kBufNoUsbSerialJtag = 4;
inline constexpr std::uint32_t kGpioStrapReg = 0x60004038;
inline constexpr std::uint32_t kStrapSpiBootMask = 0x8;  ///< set = strapped for SPI boot (BOOT not held)
inline constexpr std::uint32_t kRtcCntlOption1Reg = 0x6000812C;
inline constexpr std::uint32_t kForceDownloadBootMask = 0x1;  ///< USB-Serial/JTAG forced download mode
inline constexpr std::uint32_t kRtcWdtConfig0Reg = 0x60008098;
inline constexpr std::uint32_t kRtcWdtConfig1Reg = 0x6000809C;
inline constexpr std::uint32_t kRtcWdtProtectReg = 0x600080B0;
inline constexpr std::uint32_t kRtcWdtKey = 0x50D83AA1;
/// RTC WDT on, stage 0 resets the whole system (re-samples the strapping pins), as esptool's watchdog reset.
inline constexpr std::uint32_t kRtcWdtResetConfig = (1U << 31) | (5U << 28) | (1U << 8) | 2U;
inline constexpr std::uint32_t kSwdConfReg = 0x600080B4;
inline constexpr std::uint32_t kSwdProtectReg = 0x600080B8;
inline constexpr std::uint32_t kSwdKey = 0x8F1D312A;
inline constexpr std::uint32_t kSwdAutoFeed = 1U << 31;
}  // namespace s3

// ---------------------------------------------------------------------------------------------------------------
// ESP image (bootloader.bin, app .bin): 8-byte common header + 16-byte extended header, then segments.

inline constexpr std::uint8_t kImageMagic = 0xE9;
inline constexpr std::size_t kImageHeaderSize = 24;
inline constexpr std::size_t kMaxSegments = 16;

struct ImageHeader {
  std::uint8_t segment_count = 0;
  std::uint8_t flash_mode = 0;       ///< 0 QIO, 1 QOUT, 2 DIO, 3 DOUT
  std::uint8_t flash_size_code = 0;  ///< high nibble of byte 3: 0 = 1 MB ... 7 = 128 MB
  std::uint8_t flash_freq_code = 0;  ///< low nibble of byte 3
  std::uint32_t entry = 0;
  std::uint8_t wp_pin = 0;
  std::uint16_t chip_id = 0;  ///< 9 = ESP32-S3
  std::uint8_t min_chip_rev = 0;
  std::uint16_t min_chip_rev_full = 0;
  std::uint16_t max_chip_rev_full = 0;
  bool hash_appended = false;
};
/// unknown_type when byte 0 is not 0xE9 (not an image), truncated below 24 bytes, out_of_range for more than
/// 16 segments.
Result<ImageHeader> parse_image_header(std::span<const std::uint8_t> image) noexcept;
/// 1 MiB << code for codes 0..7, else 0.
constexpr std::uint32_t flash_size_from_code(std::uint8_t code) noexcept {
  return code <= 7 ? (0x100000U << code) : 0U;
}

/// esp_app_desc_t, which ESP-IDF places at the start of an app image's first segment (image offset 0x20).
inline constexpr std::size_t kAppDescOffset = kImageHeaderSize + 8;
inline constexpr std::uint32_t kAppDescMagic = 0xABCD5432;
struct AppDescription {
  std::uint32_t secure_version = 0;
  char version[33] = {};  ///< NUL-terminated
  char project_name[33] = {};
  char time[17] = {};
  char date[17] = {};
  char idf_ver[33] = {};
};
/// Needs a valid image header, 0x20 + 256 bytes, and the descriptor's magic word (unknown_type otherwise: a
/// bootloader image has none).
Result<AppDescription> parse_app_description(std::span<const std::uint8_t> image) noexcept;

}  // namespace saul::esp
