// Writing the boards' flash once esp_connection.hpp has reached the loader: what to write (files at offsets, or a
// build folder's flasher_args.json), the checks before the board is touched, and the region writer (skip a region
// whose flash MD5 matches, else compressed or plain blocks with retries, then verify the MD5).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "saulproto/core/esp_loader.hpp"
#include "saulproto/host/flash/esp_connection.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saul::host {

struct FlashImage {
  std::uint32_t offset = 0;
  std::vector<std::uint8_t> data;
  std::string name;  ///< the file as the user named it
};

struct FlashPlan {
  std::vector<FlashImage> images;
  std::uint32_t flash_size = 0;   ///< bytes; 0 = not known yet
  std::string flash_size_source;  ///< where flash_size came from ("--flash-size", "flasher_args.json", ...)
  std::string target_chip;        ///< from flasher_args.json ("esp32s3"), else empty
  /// flasher_args.json's flash_settings as written there ("dio", "8MB", "80m"), else empty: compared with the
  /// bootloader image's header, which esptool would rewrite to match them and saulctl writes as it is.
  std::string settings_mode, settings_size, settings_freq;
  std::vector<std::string> warnings;  ///< from check_plan: what does not stop the flash but should be read
};

/// Reads one file to write at offset. FlashError(input) for a missing, unreadable or empty file.
FlashImage load_image(std::uint32_t offset, const std::filesystem::path& path);
/// Reads an ESP-IDF build folder's flasher_args.json (or that file itself): flash_files, flash_settings and
/// extra_esptool_args.chip. File names in it are relative to the folder. FlashError(input) when unusable.
FlashPlan load_build_dir(const std::filesystem::path& dir);
/// "4MB", "16MB", "512KB" -> bytes; 0 for "detect", "keep" or anything else.
std::uint32_t parse_flash_size(const std::string& text);
/// "0x10000", "65536" -> offset; nullopt when not a number.
std::optional<std::uint32_t> parse_offset(const std::string& text);

/// Sorts by offset and checks the plan before anything touches the board: offsets on 4 KiB sectors, no overlaps,
/// images built for the ESP32-S3 (an image header's chip id), a build folder made for esp32s3, and every image
/// inside the flash. Fills flash_size when unknown: from a bootloader image's header at 0x0, else 4 MB (the
/// smallest ESP32-S3 module) with the source saying so. FlashError(input / too_large / wrong_chip).
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
  std::uint64_t wire_bytes = 0;  ///< bytes sent on the port for this image so far
  double seconds = 0;            ///< since this image's write began
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
const char* to_string(RegionOutcome::State s);

/// What to do on connecting (esp_connection.hpp), and how to write.
struct FlasherOptions : ConnectOptions {
  bool compress = true;
  bool skip_unchanged = true;  ///< compare the flash MD5 first and skip regions that already match
  std::function<void(const FlashProgress&)> progress;
};

class EspFlasher : public EspConnection {
 public:
  EspFlasher(SerialPort& port, FlasherOptions options);

  /// SPI_ATTACH (default pins) and SPI_SET_PARAMS with the flash size.
  void attach_flash(std::uint32_t flash_size);
  /// Writes one image and verifies it; skips it when its flash MD5 already matches (skip_unchanged).
  /// FlashError(port_gone) leaves the outcome `unverified`; FlashError(verify_failed) when the MD5 differs.
  RegionOutcome write(const FlashImage& image, std::size_t index = 0);
  /// SPI_FLASH_MD5 of a flash range.
  esp::Md5 flash_md5(std::uint32_t offset, std::uint32_t size);

  /// Every write() so far, including one that ended in an exception (its state says how far it got).
  [[nodiscard]] const std::vector<RegionOutcome>& outcomes() const { return outcomes_; }

 private:
  void write_blocks(const FlashImage& image, std::uint32_t size, std::span<const std::uint8_t> payload, bool compressed,
                    std::size_t index, RegionOutcome& out);

  bool compress_;
  bool skip_unchanged_;
  std::function<void(const FlashProgress&)> progress_;
  std::vector<RegionOutcome> outcomes_;
};

/// The MD5 of data (RFC 1321, computed by Debian's nettle), for comparing with SPI_FLASH_MD5.
esp::Md5 md5_of(std::span<const std::uint8_t> data);
std::string to_hex(const esp::Md5& md5);

/// Image bytes as written: padded with 0xFF to a multiple of 4 (what the MD5 is computed over).
std::vector<std::uint8_t> padded_for_flash(std::span<const std::uint8_t> data);

/// zlib stream of data (level 9), what FLASH_DEFL_DATA carries.
std::vector<std::uint8_t> deflate(std::span<const std::uint8_t> data);

}  // namespace saul::host
