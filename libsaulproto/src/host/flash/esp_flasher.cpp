// EspFlasher (see esp_flasher.hpp): what to write and the checks before the board is touched (files,
// flasher_args.json, image headers, the flash size); reaching the loader: the DTR/RTS resets, the SLIP exchange,
// SYNC, the chip check, register access and the reset into the application; then each region: MD5 compare and
// skip, compressed or plain blocks with retries, MD5 verify.
#include "saulproto/host/flash/esp_flasher.hpp"

#include <fmt/format.h>
#include <nettle/md5.h>
#include <zlib.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <string_view>
#include <thread>
#include <nlohmann/json.hpp>

#include "../util.hpp"

namespace saul::host {

using namespace std::chrono;
using detail::ascii_lower;

namespace {

using K = FlashError::Kind;

// Every failure with a formatted line: the FlashError thrown.
template <class... Args>
[[noreturn]] void fail(K kind, fmt::format_string<Args...> format, Args&&... args) {
  throw FlashError(kind, fmt::format(format, std::forward<Args>(args)...));
}

constexpr std::uint32_t kDefaultFlashSize = 4U * 1024 * 1024;
constexpr int kBlockAttempts = 3;
constexpr milliseconds kSecurityInfoTimeout{500};  // older ROMs do not know the command: do not wait long
constexpr std::size_t kNoiseKept = 200;

// Timeouts that grow with the flash involved (esptool: erase 40 s/MB, MD5 8 s/MB), never below a command's.
milliseconds per_mb(double seconds_per_mb, std::uint64_t bytes) {
  const double s = seconds_per_mb * static_cast<double>(bytes) / 1e6;
  return std::max(EspFlasher::kCommandTimeout, milliseconds(static_cast<long long>(s * 1000)));
}

std::string size_text(std::uint64_t bytes) {
  if (bytes >= 1024 * 1024 && bytes % (1024 * 1024) == 0) return fmt::format("{} MB", bytes / (1024 * 1024));
  if (bytes >= 10 * 1024) return fmt::format("{:.1f} KiB", static_cast<double>(bytes) / 1024.0);
  return fmt::format("{} bytes", bytes);
}

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

esp::Md5 md5_of(std::span<const std::uint8_t> data) {
  md5_ctx ctx;
  md5_init(&ctx);
  md5_update(&ctx, data.size(), data.data());
  esp::Md5 out{};
  static_assert(std::tuple_size_v<esp::Md5> == MD5_DIGEST_SIZE);
  md5_digest(&ctx, out.size(), out.data());
  return out;
}

std::string to_hex(const esp::Md5& md5) {
  std::string s;
  for (std::uint8_t b : md5) s += fmt::format("{:02x}", b);
  return s;
}

std::vector<std::uint8_t> padded_for_flash(std::span<const std::uint8_t> data) {
  std::vector<std::uint8_t> out(data.begin(), data.end());
  out.resize((out.size() + 3) / 4 * 4, 0xFF);
  return out;
}

std::vector<std::uint8_t> deflate(std::span<const std::uint8_t> data) {
  uLongf size = compressBound(static_cast<uLong>(data.size()));
  std::vector<std::uint8_t> out(size);
  if (compress2(out.data(), &size, data.data(), static_cast<uLong>(data.size()), 9) != Z_OK)
    throw FlashError(K::input, "zlib could not compress the image (out of memory?): run again with --no-compress");
  out.resize(size);
  return out;
}

// --- inputs ----------------------------------------------------------------------------------------------------

FlashImage load_image(std::uint32_t offset, const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec))
    fail(K::input,
         "{}: no such file (an ESP-IDF build leaves build/<project>.bin, build/bootloader/bootloader.bin and "
         "build/partition_table/partition-table.bin)",
         path.string());
  if (fs::is_directory(path, ec))
    fail(K::input, "{}: is a folder; for an ESP-IDF build folder use --build-dir", path.string());
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(K::input, "{}: cannot be read: check its permissions (ls -l) and run again", path.string());
  FlashImage img;
  img.offset = offset;
  img.name = path.string();
  img.data.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (img.data.empty())
    fail(K::input, "{}: the file is empty: build again (idf.py build) or fix the path", path.string());
  return img;
}

std::optional<std::uint32_t> parse_offset(const std::string& text) {
  if (text.empty() || text[0] == '-' || text[0] == '+') return std::nullopt;
  std::size_t used = 0;
  unsigned long long v = 0;
  try {
    v = std::stoull(text, &used, 0);
  } catch (...) {
    return std::nullopt;
  }
  if (used != text.size() || v > 0xFFFFFFFFULL) return std::nullopt;
  return static_cast<std::uint32_t>(v);
}

std::uint32_t parse_flash_size(const std::string& text) {
  const std::string t = ascii_lower(text);
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(t, &used, 10);
  } catch (...) {
    return 0;
  }
  const std::string unit = t.substr(used);
  if (unit == "mb" && v > 0 && v <= 128) return static_cast<std::uint32_t>(v * 1024 * 1024);
  if (unit == "kb" && v > 0 && v <= 128 * 1024) return static_cast<std::uint32_t>(v * 1024);
  return 0;
}

FlashPlan load_build_dir(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const bool is_file = fs::is_regular_file(dir, ec);  // flasher_args.json itself
  const fs::path json_path = is_file ? dir : dir / "flasher_args.json";
  const fs::path base = is_file ? dir.parent_path() : dir;
  if (!fs::exists(json_path, ec))
    fail(K::input,
         "{}: no flasher_args.json there (it is what 'idf.py build' leaves in the build folder: build it first, or "
         "pass OFFSET FILE pairs)",
         dir.string());
  std::ifstream in(json_path);
  nlohmann::json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    fail(K::input, "{}: not valid JSON ({}): run 'idf.py build' again to rewrite it", json_path.string(), e.what());
  }
  // j[object][key] when it is a string, else "".
  const auto text = [&j](const char* object, const char* key) {
    return j.contains(object) && j[object].contains(key) && j[object][key].is_string()
               ? j[object][key].get<std::string>() : "";
  };
  if (const std::string chip = text("extra_esptool_args", "chip"); !chip.empty() && ascii_lower(chip) != "esp32s3")
    fail(K::wrong_chip,
         "{}: the build was made for {}, not esp32s3: wrong build folder, or run 'idf.py set-target esp32s3' and build "
         "again",
         json_path.string(), chip);
  if (!j.contains("flash_files") || !j["flash_files"].is_object() || j["flash_files"].empty())
    fail(K::input,
         "{}: has no \"flash_files\", so it is not an ESP-IDF flasher_args.json: give the build folder idf.py wrote, "
         "or OFFSET FILE pairs",
         json_path.string());
  FlashPlan plan;
  for (const auto& [key, value] : j["flash_files"].items()) {
    const auto offset = parse_offset(key);
    if (!offset || !value.is_string())
      fail(K::input,
           "{}: flash_files entry \"{}\" is not OFFSET: \"file\": run 'idf.py build' again to rewrite it, or give "
           "OFFSET FILE pairs",
           json_path.string(), key);
    FlashImage img = load_image(*offset, base / value.get<std::string>());
    img.name = value.get<std::string>();
    plan.images.push_back(std::move(img));
  }
  plan.settings_mode = text("flash_settings", "flash_mode");
  plan.settings_size = text("flash_settings", "flash_size");
  plan.settings_freq = text("flash_settings", "flash_freq");
  plan.flash_size = parse_flash_size(plan.settings_size);
  if (plan.flash_size) plan.flash_size_source = "flasher_args.json";
  return plan;
}

namespace {

bool is_elf(std::span<const std::uint8_t> d) {
  return d.size() >= 4 && d[0] == 0x7F && d[1] == 'E' && d[2] == 'L' && d[3] == 'F';
}

// What the ROM cannot boot, refused as esptool does: an ELF anywhere (the linker's output, not a flash image), and
// at 0x0, where the ROM looks for the second-stage bootloader, anything without the image magic 0xE9.
void check_kind(const FlashImage& img, bool force, std::vector<std::string>& warnings) {
  std::string problem;
  if (is_elf(img.data)) {
    std::filesystem::path bin = img.name;
    bin.replace_extension(".bin");
    std::error_code ec;
    const std::string hint = bin.string() != img.name && std::filesystem::exists(bin, ec)
                                 ? fmt::format("flash {}, the .bin idf.py wrote beside it", bin.string())
                                 : "flash the .bin idf.py wrote (build/<project>.bin, build/bootloader/bootloader.bin)";
    problem = fmt::format("{}: this is an ELF file (the linker's output), not a flash image: {}", img.name, hint);
  } else if (img.offset == 0 && img.data[0] != esp::kImageMagic) {
    problem = fmt::format("{} at 0x0: not an ESP image (first byte 0x{:02X}, an image starts with 0x{:02X}), so the "
                          "ROM would not boot: 0x0 takes the bootloader, build/bootloader/bootloader.bin",
                          img.name, img.data[0], esp::kImageMagic);
  }
  if (problem.empty()) return;
  if (!force) throw FlashError(K::input, problem + " (--force writes it anyway)");
  warnings.push_back(problem + "; written anyway (--force)");
}

// esptool's names of the header's codes for the ESP32-S3 (targets/esp32s3.py): mode in byte 2, frequency in the
// low nibble of byte 3.
using CodeNames = std::span<const std::pair<std::uint8_t, std::string_view>>;
constexpr std::pair<std::uint8_t, std::string_view> kModes[]{{0, "qio"}, {1, "qout"}, {2, "dio"}, {3, "dout"}};
constexpr std::pair<std::uint8_t, std::string_view> kFreqs[]{{0xF, "80m"}, {0x0, "40m"}, {0x2, "20m"}};

// The header's name for `code` when it and flasher_args.json's `wanted` are names of the table that differ, else
// empty ("keep" and the like: nothing to compare).
std::string_view differing(CodeNames names, std::uint8_t code, const std::string& wanted) {
  const auto it = std::find_if(names.begin(), names.end(), [&](const auto& e) { return e.first == code; });
  const bool known = std::any_of(names.begin(), names.end(), [&](const auto& e) { return e.second == wanted; });
  return it != names.end() && known && it->second != wanted ? it->second : std::string_view();
}

// The image header of the bootloader: the image at 0x0, first once the plan is sorted.
Result<esp::ImageHeader> bootloader_header(const FlashPlan& plan) {
  if (plan.images.empty() || plan.images.front().offset != 0) return Reason::truncated;
  return esp::parse_image_header(plan.images.front().data);
}

// The bootloader's header against flasher_args.json: esptool (idf.py flash) rewrites the header to match the
// settings, saulctl writes the file as it is, so a disagreement means the board boots with the header's.
void check_settings(FlashPlan& plan) {
  if (plan.settings_mode.empty() && plan.settings_size.empty() && plan.settings_freq.empty()) return;
  if (const auto h = bootloader_header(plan)) {
    std::vector<std::string> differ;
    if (const auto mode = differing(kModes, h->flash_mode, ascii_lower(plan.settings_mode)); !mode.empty())
      differ.push_back(fmt::format("flash mode {} (flasher_args.json: {})", mode, plan.settings_mode));
    const std::uint32_t size = esp::flash_size_from_code(h->flash_size_code);
    const std::uint32_t want_size = parse_flash_size(plan.settings_size);  // 0 for "detect", "keep"
    if (size && want_size && size != want_size)
      differ.push_back(fmt::format("flash size {} (flasher_args.json: {})", size_text(size), plan.settings_size));
    if (const auto freq = differing(kFreqs, h->flash_freq_code, ascii_lower(plan.settings_freq)); !freq.empty())
      differ.push_back(fmt::format("flash frequency {} (flasher_args.json: {})", freq, plan.settings_freq));
    if (!differ.empty())
      plan.warnings.push_back(fmt::format(
          "{}: its header says {}; esptool would rewrite the header to the build's settings, saulctl writes the file "
          "as it is, so the board boots with the header's: rebuild (idf.py build) so they agree",
          plan.images.front().name, fmt::join(differ, ", ")));
  }
}

}  // namespace

void check_plan(FlashPlan& plan, bool force) {
  if (plan.images.empty())
    throw FlashError(K::input, "nothing to flash: give FILE [--offset], OFFSET FILE pairs or --build-dir");
  std::sort(plan.images.begin(), plan.images.end(), [](const auto& a, const auto& b) { return a.offset < b.offset; });
  for (std::size_t i = 0; i < plan.images.size(); ++i) {
    const auto& img = plan.images[i];
    if (img.offset % esp::kSectorSize != 0)
      fail(K::input,
           "{}: offset 0x{:X} is not on a 4 KiB sector boundary (the flash is erased by whole sectors): use a multiple "
           "of 0x1000",
           img.name, img.offset);
    if (i > 0) {
      const auto& prev = plan.images[i - 1];
      const std::uint64_t prev_end = prev.offset + static_cast<std::uint64_t>(prev.data.size());
      if (prev_end > img.offset)
        fail(K::input, "{} (0x{:X}..0x{:X}) overlaps {} at 0x{:X}: fix the offsets (or the wrong file)", prev.name,
             prev.offset, prev_end, img.name, img.offset);
    }
    check_kind(img, force, plan.warnings);
    if (auto h = esp::parse_image_header(img.data); h && h->chip_id != esp::kChipIdEsp32s3) {
      const char* name = esp::chip_name(h->chip_id);
      fail(K::wrong_chip,
           "{}: is an image for the {} (image chip id {}), not for the ESP32-S3: wrong build (idf.py set-target "
           "esp32s3)",
           img.name, name ? name : "unknown chip", h->chip_id);
    }
  }
  if (const auto h = bootloader_header(plan); plan.flash_size == 0 && h) {
    plan.flash_size = esp::flash_size_from_code(h->flash_size_code);
    if (plan.flash_size) plan.flash_size_source = "the bootloader's image header";
  }
  if (plan.flash_size == 0) {
    plan.flash_size = kDefaultFlashSize;
    plan.flash_size_source = "assumed: the smallest ESP32-S3 module; pass --flash-size for more";
  }
  check_settings(plan);
  for (const auto& img : plan.images) {
    const std::uint64_t end = img.offset + static_cast<std::uint64_t>(padded_for_flash(img.data).size());
    if (end > plan.flash_size)
      fail(K::too_large,
           "{} ({}) at 0x{:X} ends at 0x{:X}, beyond the {} flash ({}): wrong file or offset, or pass --flash-size if "
           "the board's flash is larger",
           img.name, size_text(img.data.size()), img.offset, end, size_text(plan.flash_size), plan.flash_size_source);
  }
}

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

std::optional<esp::Response> EspFlasher::exchange(const Result<std::size_t>& built, milliseconds timeout,
                                                  esp::Loader loader) {
  auto n = esp::slip_encode(std::span<const std::uint8_t>(packet_.data(), *built), frame_);
  if (!n) throw FlashError(K::protocol, "internal: request does not fit its frame buffer");
  // Long enough for the frame at the current rate, twice over, plus a second of slack.
  const auto baud = std::max<std::uint32_t>(port_.settings().baud, 9600);
  const milliseconds write_timeout(1000 + static_cast<long long>(*n) * 10 * 2 * 1000 / baud);
  port_.write(std::span<const std::uint8_t>(frame_.data(), *n), write_timeout);
  bytes_sent_ += *n;
  const std::uint8_t op = packet_[1];  // every request is 00, op, size, checksum, data
  const auto deadline = steady_clock::now() + timeout;
  for (;;) {
    while (rx_pos_ < rx_.size()) {
      auto frame = take(rx_[rx_pos_++]);
      if (!frame) continue;
      auto r = esp::parse_response(*frame, loader);
      if (r && r->op == op) return *r;  // others: late answers to earlier requests
    }
    const auto left = duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    fill(left);
  }
}

std::optional<std::span<const std::uint8_t>> EspFlasher::take(std::uint8_t byte) {
  if (!decoder_.in_frame() && byte != esp::kSlipEnd) {
    if (noise_.size() < kNoiseKept) noise_ += static_cast<char>(byte);  // the start of a boot log says the most
  }
  auto frame = decoder_.push(byte);
  if (frame && !frame->empty() && (*frame)[0] == esp::kDirectionRequest) ++echoes_;
  return frame;
}

bool EspFlasher::fill(milliseconds timeout) {
  rx_.resize(4096);
  rx_.resize(port_.read(rx_, timeout));
  rx_pos_ = 0;
  return !rx_.empty();
}

void EspFlasher::drain(milliseconds quiet) {
  do {
    while (rx_pos_ < rx_.size()) (void)take(rx_[rx_pos_++]);
  } while (fill(quiet));
  decoder_.reset();
}

esp::Response EspFlasher::command(const Result<std::size_t>& built, milliseconds timeout) {
  auto r = exchange(built, timeout, chip_.loader);
  const auto op = static_cast<esp::Op>(packet_[1]);
  if (!r)
    fail(K::no_answer,
         "{}: no answer to {} within {} ms: the board left download mode or the connection broke: reset it into "
         "download mode (or replug it) and run again",
         port_.path(), esp::to_string(op), timeout.count());
  if (!r->ok())
    fail(K::refused, "{}: {} refused by the {} loader: {}", port_.path(), esp::to_string(op),
         chip_.loader == esp::Loader::rom ? "ROM" : "stub", refusal_text(r->error));
  return *r;
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
    if (options_.reset_before)
      run_line_sequence(port_, bootloader_reset_sequence(options_.reset, attempt), options_.sleep);
    drain(milliseconds(0));
    for (int i = 0; i < 5 && !synced; ++i) {
      if (cancelled()) throw FlashError(K::interrupted, "interrupted while connecting: nothing was written; run again");
      // Read with the 2-byte status layout: it fits both the ROM's answer (4 status bytes) and a stub's.
      const auto r = exchange(esp::build_sync(packet_), options_.sync_timeout, esp::Loader::stub);
      synced = r && r->ok();
      if (synced) chip_.loader = r->value == 0 ? esp::Loader::stub : esp::Loader::rom;  // the ROM answers SYNC non-zero
    }
  }
  if (!synced) throw FlashError(K::no_answer, diagnose_silence());
  connected_ = true;
  detect_chip();
  return chip_;
}

void EspFlasher::detect_chip() {
  auto r = exchange(esp::build_get_security_info(packet_), kSecurityInfoTimeout, chip_.loader);
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
    fail(K::wrong_chip,
         "{}: this is an {}, not an ESP32-S3 (found by {}): both SAUL-TEE boards carry an ESP32-S3, so this is another "
         "board or the wrong port ('saulctl ports' lists them)",
         port_.path(), chip_.name, chip_.detected_by);
  if (chip_.security_flags & esp::kSecureDownloadFlag)
    fail(K::unsupported,
         "{}: the ESP32-S3 is in secure download mode: its ROM will not compute the flash MD5 saulctl verifies every "
         "write with; flash it with esptool's secure-download options",
         port_.path());
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
  return command(esp::build_read_reg(address, packet_), kCommandTimeout).value;
}

void EspFlasher::write_reg(std::uint32_t address, std::uint32_t value, std::uint32_t mask) {
  (void)command(esp::build_write_reg(address, value, mask, 0, packet_), kCommandTimeout);
}

void EspFlasher::change_baud(std::uint32_t baud) {
  const std::uint32_t current = port_.settings().baud;
  if (baud == 0 || baud == current) return;
  (void)command(esp::build_change_baudrate(baud, chip_.loader == esp::Loader::stub ? current : 0, packet_),
                kCommandTimeout);
  port_.set_baud(baud);
  drain(milliseconds(20));  // whatever the switch garbled
  if (options_.note) options_.note(fmt::format("baud rate {} -> {}", current, baud));
}

void EspFlasher::reset_to_app() {
  if (!chip_.usb_serial_jtag) {
    run_line_sequence(port_, hard_reset_sequence(options_.reset), options_.sleep);
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

// --- the region writer ----------------------------------------------------------------------------------------

esp::Md5 EspFlasher::flash_md5(std::uint32_t offset, std::uint32_t size) {
  auto r = command(esp::build_spi_flash_md5(offset, size, packet_), per_mb(8, size));
  auto md5 = esp::parse_md5(r.data);
  if (!md5)
    fail(K::protocol,
         "{}: SPI_FLASH_MD5 answered {} bytes, not an MD5 ({}): reset the board into download mode and run again",
         port_.path(), r.data.size(), saul::to_string(md5.reason()));
  return *md5;
}

void EspFlasher::attach_flash(std::uint32_t flash_size) {
  (void)command(esp::build_spi_attach(0, chip_.loader, packet_), kCommandTimeout);
  (void)command(esp::build_spi_set_params(flash_size, packet_), kCommandTimeout);
}

void EspFlasher::write_blocks(const FlashImage& image, std::uint32_t size, std::span<const std::uint8_t> payload,
                              bool compressed, std::size_t index, RegionOutcome& out) {
  const esp::Loader loader = chip_.loader;
  const std::uint32_t block = esp::block_size(loader);
  const auto payload_size = static_cast<std::uint32_t>(payload.size());
  const std::uint32_t blocks = esp::block_count(payload_size, block);
  const auto t0 = steady_clock::now();
  const std::uint64_t sent0 = bytes_sent_;
  // The ROM erases the whole region when the write begins.
  const milliseconds begin_timeout = loader == esp::Loader::rom ? per_mb(40, size) : kCommandTimeout;
  auto n = compressed ? esp::build_flash_defl_begin(esp::defl_begin_size(size, loader), blocks, block, image.offset,
                                                    loader, packet_)
                      : esp::build_flash_begin(size, blocks, block, image.offset, loader, packet_);
  (void)command(n, begin_timeout);
  std::vector<std::uint8_t> chunk(block, 0xFF);
  for (std::uint32_t seq = 0; seq < blocks; ++seq) {
    if (cancelled())
      fail(K::interrupted,
           "interrupted while writing {} at 0x{:X}: that region is UNVERIFIED and the board may not boot; flash it "
           "again",
           image.name, image.offset);
    const std::uint32_t from = seq * block;
    const std::uint32_t len = std::min(block, payload_size - from);
    std::span<const std::uint8_t> slice = payload.subspan(from, len);
    if (!compressed && len < block) {  // plain writes pad the last block with erased-flash bytes
      std::fill(chunk.begin(), chunk.end(), 0xFF);
      std::copy(slice.begin(), slice.end(), chunk.begin());
      slice = chunk;
    }
    n = compressed ? esp::build_flash_defl_data(seq, slice, packet_) : esp::build_flash_data(seq, slice, packet_);
    for (int attempt = 1;; ++attempt) {
      auto r = exchange(n, per_mb(40, block), loader);
      if (r && r->ok()) break;
      if (attempt == kBlockAttempts) {
        if (!r)
          fail(K::no_answer,
               "{}: no answer to block {} of {} of {} after {} tries: the board left download mode or the connection "
               "broke mid-write, the region at 0x{:X} is UNVERIFIED: reset the board into download mode (or replug it) "
               "and flash again",
               port_.path(), seq + 1, blocks, image.name, kBlockAttempts, image.offset);
        fail(K::refused, "{}: block {} of {} of {} refused {} times, the region at 0x{:X} is UNVERIFIED: {}",
             port_.path(), seq + 1, blocks, image.name, kBlockAttempts, image.offset, refusal_text(r->error));
      }
      ++out.retries;
    }
    out.wire_bytes = bytes_sent_ - sent0;
    if (options_.progress)
      options_.progress({.stage = FlashProgress::Stage::writing, .index = index, .image = &image,
                         .bytes_done = (std::uint64_t{from} + len) * size / payload_size, .bytes_total = size,
                         .seconds = duration<double>(steady_clock::now() - t0).count()});
  }
  if (loader == esp::Loader::stub) {
    // The stub writes behind the answers: an empty begin makes it finish, END(1) keeps it in the loader.
    (void)command(esp::build_flash_begin(0, 0, block, 0, loader, packet_), kCommandTimeout);
    (void)command(compressed ? esp::build_flash_defl_end(true, packet_) : esp::build_flash_end(true, packet_),
                  kCommandTimeout);
  }
}

RegionOutcome EspFlasher::write(const FlashImage& image, std::size_t index) {
  if (!connected_) throw FlashError(K::protocol, "internal: write() before connect()");
  const std::vector<std::uint8_t> data = padded_for_flash(image.data);
  const auto size = static_cast<std::uint32_t>(data.size());
  const esp::Md5 expected = md5_of(data);
  auto& slot = outcomes_.emplace_back(
      RegionOutcome{.offset = image.offset, .name = image.name, .size = size, .md5 = to_hex(expected)});
  const auto t0 = steady_clock::now();
  auto report = [&](FlashProgress::Stage stage, std::uint64_t done) {
    if (options_.progress)
      options_.progress({.stage = stage, .index = index, .image = &image, .bytes_done = done, .bytes_total = size,
                 .seconds = duration<double>(steady_clock::now() - t0).count()});
  };
  try {
    if (options_.skip_unchanged) {
      report(FlashProgress::Stage::checking, 0);
      if (flash_md5(image.offset, size) == expected) {
        slot.state = RegionOutcome::State::unchanged;
        slot.seconds = duration<double>(steady_clock::now() - t0).count();
        return slot;
      }
    }
    slot.compressed = options_.compress;
    slot.state = RegionOutcome::State::unverified;  // from the first erased byte until the MD5 says otherwise
    write_blocks(image, size, options_.compress ? deflate(data) : data, options_.compress, index, slot);
    report(FlashProgress::Stage::verifying, size);
    const esp::Md5 got = flash_md5(image.offset, size);
    slot.seconds = duration<double>(steady_clock::now() - t0).count();
    if (got != expected)
      fail(K::verify_failed,
           "{} at 0x{:X}: the flash MD5 after writing is {}, the file's is {}: the region is UNVERIFIED; flash again, "
           "and if it repeats suspect the flash size/mode or the chip",
           image.name, image.offset, to_hex(got), to_hex(expected));
    slot.state = RegionOutcome::State::written;
    return slot;
  } catch (const SerialError& e) {
    slot.seconds = duration<double>(steady_clock::now() - t0).count();
    if (e.kind() == SerialError::Kind::gone)
      fail(K::port_gone,
           "{}: the port went away while flashing {} at 0x{:X}: that region is UNVERIFIED and the board may not boot; "
           "reconnect it and flash again",
           port_.path(), image.name, image.offset);
    throw;
  }
}

}  // namespace saul::host
