#include "saulproto/core/esp_loader.hpp"

#include "saulproto/core/bytes.hpp"

namespace saul::esp {
namespace {

using bytes::get_u16le;
using bytes::get_u32le;
using bytes::put_u16le;
using bytes::put_u32le;

// Writes the 8-byte request header and copies `words` (LE u32) as the data. For the fixed-layout commands.
template <std::size_t N>
Result<std::size_t> build_words(Op op, const std::uint32_t (&words)[N], std::size_t count,
                                std::span<std::uint8_t> out) noexcept {
  const std::size_t size = kHeaderSize + 4 * count;
  if (out.size() < size) return Reason::buffer_too_small;
  out[0] = kDirectionRequest;
  out[1] = static_cast<std::uint8_t>(op);
  put_u16le(&out[2], static_cast<std::uint16_t>(4 * count));
  put_u32le(&out[4], 0);
  for (std::size_t i = 0; i < count; ++i) put_u32le(&out[kHeaderSize + 4 * i], words[i]);
  return size;
}

Result<std::size_t> build_block(Op op, std::uint32_t sequence, std::span<const std::uint8_t> data,
                                std::span<std::uint8_t> out) noexcept {
  const std::size_t payload = kBlockHeaderSize + data.size();
  if (payload > 0xFFFF) return Reason::out_of_range;
  const std::size_t size = kHeaderSize + payload;
  if (out.size() < size) return Reason::buffer_too_small;
  out[0] = kDirectionRequest;
  out[1] = static_cast<std::uint8_t>(op);
  put_u16le(&out[2], static_cast<std::uint16_t>(payload));
  put_u32le(&out[4], checksum(data));
  put_u32le(&out[8], static_cast<std::uint32_t>(data.size()));
  put_u32le(&out[12], sequence);
  put_u32le(&out[16], 0);
  put_u32le(&out[20], 0);
  for (std::size_t i = 0; i < data.size(); ++i) out[kHeaderSize + kBlockHeaderSize + i] = data[i];
  return size;
}

int hex_value(std::uint8_t c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

template <std::size_t N>
void copy_string(char (&dst)[N], const std::uint8_t* src, std::size_t field) noexcept {
  std::size_t i = 0;
  for (; i < field && i < N - 1 && src[i] != 0; ++i) dst[i] = static_cast<char>(src[i]);
  dst[i] = '\0';
}

}  // namespace

const char* to_string(Op op) noexcept {
  switch (op) {
    case Op::flash_begin: return "FLASH_BEGIN";
    case Op::flash_data: return "FLASH_DATA";
    case Op::flash_end: return "FLASH_END";
    case Op::mem_begin: return "MEM_BEGIN";
    case Op::mem_end: return "MEM_END";
    case Op::mem_data: return "MEM_DATA";
    case Op::sync: return "SYNC";
    case Op::write_reg: return "WRITE_REG";
    case Op::read_reg: return "READ_REG";
    case Op::spi_set_params: return "SPI_SET_PARAMS";
    case Op::spi_attach: return "SPI_ATTACH";
    case Op::read_flash_slow: return "READ_FLASH_SLOW";
    case Op::change_baudrate: return "CHANGE_BAUDRATE";
    case Op::flash_defl_begin: return "FLASH_DEFL_BEGIN";
    case Op::flash_defl_data: return "FLASH_DEFL_DATA";
    case Op::flash_defl_end: return "FLASH_DEFL_END";
    case Op::spi_flash_md5: return "SPI_FLASH_MD5";
    case Op::get_security_info: return "GET_SECURITY_INFO";
  }
  return "UNKNOWN";
}

std::uint8_t checksum(std::span<const std::uint8_t> data, std::uint8_t seed) noexcept {
  std::uint8_t c = seed;
  for (std::uint8_t b : data) c ^= b;
  return c;
}

// --- SLIP ------------------------------------------------------------------------------------------------------

std::size_t slip_encoded_size(std::span<const std::uint8_t> packet) noexcept {
  std::size_t n = 2;
  for (std::uint8_t b : packet) n += (b == kSlipEnd || b == kSlipEsc) ? 2 : 1;
  return n;
}

Result<std::size_t> slip_encode(std::span<const std::uint8_t> packet, std::span<std::uint8_t> out) noexcept {
  if (out.size() < slip_encoded_size(packet)) return Reason::buffer_too_small;
  std::size_t n = 0;
  out[n++] = kSlipEnd;
  for (std::uint8_t b : packet) {
    if (b == kSlipEnd) {
      out[n++] = kSlipEsc;
      out[n++] = kSlipEscEnd;
    } else if (b == kSlipEsc) {
      out[n++] = kSlipEsc;
      out[n++] = kSlipEscEsc;
    } else {
      out[n++] = b;
    }
  }
  out[n++] = kSlipEnd;
  return n;
}

void SlipDecoder::reset() noexcept {
  length_ = 0;
  in_frame_ = false;
  escape_ = false;
  broken_ = false;
}

std::optional<std::span<const std::uint8_t>> SlipDecoder::push(std::uint8_t byte) noexcept {
  if (!in_frame_) {
    if (byte == kSlipEnd) {
      in_frame_ = true;
      length_ = 0;
      escape_ = false;
      broken_ = false;
    } else {
      ++counters_.noise_bytes;
    }
    return std::nullopt;
  }
  if (byte == kSlipEnd) {
    if (length_ == 0 && !broken_ && !escape_) return std::nullopt;  // C0 C0: the second one opens the frame
    const bool good = !broken_ && !escape_;
    if (escape_) ++counters_.bad_escapes;
    in_frame_ = false;
    escape_ = false;
    broken_ = false;
    if (!good) return std::nullopt;
    ++counters_.frames;
    return std::span<const std::uint8_t>(storage_.data(), length_);
  }
  if (broken_) return std::nullopt;
  std::uint8_t value = byte;
  if (escape_) {
    escape_ = false;
    if (byte == kSlipEscEnd) {
      value = kSlipEnd;
    } else if (byte == kSlipEscEsc) {
      value = kSlipEsc;
    } else {
      ++counters_.bad_escapes;
      broken_ = true;
      return std::nullopt;
    }
  } else if (byte == kSlipEsc) {
    escape_ = true;
    return std::nullopt;
  }
  if (length_ == storage_.size()) {
    ++counters_.overlong_frames;
    broken_ = true;
    return std::nullopt;
  }
  storage_[length_++] = value;
  return std::nullopt;
}

// --- packets ---------------------------------------------------------------------------------------------------

Result<std::size_t> encode_request(std::uint8_t op, std::span<const std::uint8_t> data, std::uint32_t sum,
                                   std::span<std::uint8_t> out) noexcept {
  if (data.size() > 0xFFFF) return Reason::out_of_range;
  const std::size_t size = kHeaderSize + data.size();
  if (out.size() < size) return Reason::buffer_too_small;
  out[0] = kDirectionRequest;
  out[1] = op;
  put_u16le(&out[2], static_cast<std::uint16_t>(data.size()));
  put_u32le(&out[4], sum);
  for (std::size_t i = 0; i < data.size(); ++i) out[kHeaderSize + i] = data[i];
  return size;
}

Result<Request> parse_request(std::span<const std::uint8_t> packet) noexcept {
  if (packet.size() < kHeaderSize) return Reason::truncated;
  if (packet[0] != kDirectionRequest) return Reason::unknown_type;
  const std::uint16_t size = get_u16le(&packet[2]);
  if (packet.size() < kHeaderSize + size) return Reason::truncated;
  if (packet.size() > kHeaderSize + size) return Reason::bad_length;
  Request r;
  r.op = packet[1];
  r.checksum = get_u32le(&packet[4]);
  r.data = packet.subspan(kHeaderSize, size);
  return r;
}

Result<std::size_t> encode_response(std::uint8_t op, std::uint32_t value, std::span<const std::uint8_t> data,
                                    std::uint8_t status, std::uint8_t error, Loader loader,
                                    std::span<std::uint8_t> out) noexcept {
  const std::size_t status_len = status_length(loader);
  const std::size_t payload = data.size() + status_len;
  if (payload > 0xFFFF) return Reason::out_of_range;
  const std::size_t size = kHeaderSize + payload;
  if (out.size() < size) return Reason::buffer_too_small;
  out[0] = kDirectionResponse;
  out[1] = op;
  put_u16le(&out[2], static_cast<std::uint16_t>(payload));
  put_u32le(&out[4], value);
  for (std::size_t i = 0; i < data.size(); ++i) out[kHeaderSize + i] = data[i];
  std::uint8_t* s = &out[kHeaderSize + data.size()];
  s[0] = status;
  s[1] = error;
  for (std::size_t i = 2; i < status_len; ++i) s[i] = 0;
  return size;
}

Result<Response> parse_response(std::span<const std::uint8_t> packet, Loader loader) noexcept {
  if (packet.size() < kHeaderSize) return Reason::truncated;
  if (packet[0] != kDirectionResponse) return Reason::unknown_type;
  const std::uint16_t size = get_u16le(&packet[2]);
  if (packet.size() < kHeaderSize + size) return Reason::truncated;
  if (packet.size() > kHeaderSize + size) return Reason::bad_length;
  const std::size_t status_len = status_length(loader);
  if (size < status_len) return Reason::bad_length;
  Response r;
  r.op = packet[1];
  r.value = get_u32le(&packet[4]);
  r.data = packet.subspan(kHeaderSize, size - status_len);
  r.status = packet[kHeaderSize + size - status_len];
  r.error = packet[kHeaderSize + size - status_len + 1];
  return r;
}

// --- builders --------------------------------------------------------------------------------------------------

Result<std::size_t> build_sync(std::span<std::uint8_t> out) noexcept {
  constexpr std::size_t kData = 36;
  if (out.size() < kHeaderSize + kData) return Reason::buffer_too_small;
  out[0] = kDirectionRequest;
  out[1] = static_cast<std::uint8_t>(Op::sync);
  put_u16le(&out[2], kData);
  put_u32le(&out[4], 0);
  out[8] = 0x07;
  out[9] = 0x07;
  out[10] = 0x12;
  out[11] = 0x20;
  for (std::size_t i = 12; i < kHeaderSize + kData; ++i) out[i] = 0x55;
  return kHeaderSize + kData;
}

Result<std::size_t> build_read_reg(std::uint32_t address, std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {address};
  return build_words(Op::read_reg, w, 1, out);
}

Result<std::size_t> build_write_reg(std::uint32_t address, std::uint32_t value, std::uint32_t mask,
                                    std::uint32_t delay_us, std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {address, value, mask, delay_us};
  return build_words(Op::write_reg, w, 4, out);
}

Result<std::size_t> build_get_security_info(std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {0};
  return build_words(Op::get_security_info, w, 0, out);
}

Result<std::size_t> build_spi_attach(std::uint32_t pins, Loader loader, std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {pins, 0};
  return build_words(Op::spi_attach, w, loader == Loader::rom ? 2 : 1, out);
}

Result<std::size_t> build_spi_set_params(std::uint32_t total_size, std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {0, total_size, 0x10000, kSectorSize, 0x100, 0xFFFF};
  return build_words(Op::spi_set_params, w, 6, out);
}

Result<std::size_t> build_change_baudrate(std::uint32_t new_baud, std::uint32_t old_baud,
                                          std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {new_baud, old_baud};
  return build_words(Op::change_baudrate, w, 2, out);
}

Result<std::size_t> build_flash_begin(std::uint32_t erase_size, std::uint32_t blocks, std::uint32_t block,
                                      std::uint32_t offset, Loader loader, std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {erase_size, blocks, block, offset, 0};
  return build_words(Op::flash_begin, w, loader == Loader::rom ? 5 : 4, out);
}

Result<std::size_t> build_flash_data(std::uint32_t sequence, std::span<const std::uint8_t> data,
                                     std::span<std::uint8_t> out) noexcept {
  return build_block(Op::flash_data, sequence, data, out);
}

Result<std::size_t> build_flash_end(bool run_user_code, std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {run_user_code ? 1U : 0U};
  return build_words(Op::flash_end, w, 1, out);
}

Result<std::size_t> build_flash_defl_begin(std::uint32_t size, std::uint32_t blocks, std::uint32_t block,
                                           std::uint32_t offset, Loader loader, std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {size, blocks, block, offset, 0};
  return build_words(Op::flash_defl_begin, w, loader == Loader::rom ? 5 : 4, out);
}

Result<std::size_t> build_flash_defl_data(std::uint32_t sequence, std::span<const std::uint8_t> data,
                                          std::span<std::uint8_t> out) noexcept {
  return build_block(Op::flash_defl_data, sequence, data, out);
}

Result<std::size_t> build_flash_defl_end(bool run_user_code, std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {run_user_code ? 1U : 0U};
  return build_words(Op::flash_defl_end, w, 1, out);
}

Result<std::size_t> build_spi_flash_md5(std::uint32_t address, std::uint32_t size,
                                        std::span<std::uint8_t> out) noexcept {
  const std::uint32_t w[] = {address, size, 0, 0};
  return build_words(Op::spi_flash_md5, w, 4, out);
}

// --- answers ---------------------------------------------------------------------------------------------------

Result<SecurityInfo> parse_security_info(std::span<const std::uint8_t> data) noexcept {
  if (data.size() < 12) return Reason::truncated;
  SecurityInfo s;
  s.flags = get_u32le(&data[0]);
  s.flash_crypt_cnt = data[4];
  for (std::size_t i = 0; i < 7; ++i) s.key_purposes[i] = data[5 + i];
  if (data.size() >= 20) {
    s.has_chip_id = true;
    s.chip_id = get_u32le(&data[12]);
    s.api_version = get_u32le(&data[16]);
  }
  return s;
}

Result<Md5> parse_md5(std::span<const std::uint8_t> data) noexcept {
  Md5 md5{};
  if (data.size() == 16) {
    for (std::size_t i = 0; i < 16; ++i) md5[i] = data[i];
    return md5;
  }
  if (data.size() != 32) return Reason::bad_length;
  for (std::size_t i = 0; i < 16; ++i) {
    const int hi = hex_value(data[2 * i]);
    const int lo = hex_value(data[2 * i + 1]);
    if (hi < 0 || lo < 0) return Reason::syntax;
    md5[i] = static_cast<std::uint8_t>((hi << 4) | lo);
  }
  return md5;
}

const char* chip_name(std::uint32_t chip_id) noexcept {
  switch (chip_id) {
    case 0: return "ESP32";
    case 2: return "ESP32-S2";
    case 5: return "ESP32-C3";
    case 9: return "ESP32-S3";
    case 12: return "ESP32-C2";
    case 13: return "ESP32-C6";
    case 16: return "ESP32-H2";
    case 18: return "ESP32-P4";
    case 20: return "ESP32-C61";
    case 23: return "ESP32-C5";
    default: return nullptr;
  }
}

const char* chip_name_from_magic(std::uint32_t magic) noexcept {
  switch (magic) {
    case 0xFFF0C101: return "ESP8266";
    case 0x00F01D83: return "ESP32";
    case 0x000007C6: return "ESP32-S2";
    case 0x00000009: return "ESP32-S3";
    case 0x6921506F:
    case 0x1B31506F:
    case 0x4881606F:
    case 0x4361606F: return "ESP32-C3";
    case 0x6F51306F:
    case 0x7C41A06F: return "ESP32-C2";
    case 0x2CE0806F: return "ESP32-C6";
    case 0xD7B73E80: return "ESP32-H2";
    default: return nullptr;
  }
}

const char* error_text(std::uint8_t code) noexcept {
  switch (code) {
    case 0x05: return "received message is invalid (parameters or length)";
    case 0x06: return "failed to act on received message";
    case 0x07: return "invalid checksum in message";
    case 0x08: return "flash write error (read-back mismatch)";
    case 0x09: return "flash read error";
    case 0x0A: return "flash read length error";
    case 0x0B: return "deflate error";
    case 0xC0: return "stub: bad data length";
    case 0xC1: return "stub: bad data checksum";
    case 0xC2: return "stub: bad block size";
    case 0xC3: return "stub: invalid command";
    case 0xC4: return "stub: SPI operation failed";
    case 0xC5: return "stub: SPI unlock failed";
    case 0xC6: return "stub: not in flash mode";
    case 0xC7: return "stub: inflate error";
    case 0xC8: return "stub: not enough data";
    case 0xC9: return "stub: too much data";
    case 0xFF: return "command not implemented";
    default: return "unknown error";
  }
}

// --- image -----------------------------------------------------------------------------------------------------

Result<ImageHeader> parse_image_header(std::span<const std::uint8_t> image) noexcept {
  if (image.empty() || image[0] != kImageMagic) return Reason::unknown_type;
  if (image.size() < kImageHeaderSize) return Reason::truncated;
  ImageHeader h;
  h.segment_count = image[1];
  if (h.segment_count > kMaxSegments) return Reason::out_of_range;
  h.flash_mode = image[2];
  h.flash_size_code = static_cast<std::uint8_t>(image[3] >> 4);
  h.flash_freq_code = static_cast<std::uint8_t>(image[3] & 0x0F);
  h.entry = get_u32le(&image[4]);
  h.wp_pin = image[8];
  h.chip_id = get_u16le(&image[12]);
  h.min_chip_rev = image[14];
  h.min_chip_rev_full = get_u16le(&image[15]);
  h.max_chip_rev_full = get_u16le(&image[17]);
  h.hash_appended = image[23] != 0;
  return h;
}

Result<AppDescription> parse_app_description(std::span<const std::uint8_t> image) noexcept {
  auto header = parse_image_header(image);
  if (!header) return header.reason();
  if (header->segment_count == 0) return Reason::unknown_type;
  constexpr std::size_t kDescSize = 256;
  if (image.size() < kAppDescOffset + kDescSize) return Reason::truncated;
  const std::uint8_t* d = &image[kAppDescOffset];
  if (get_u32le(d) != kAppDescMagic) return Reason::unknown_type;
  AppDescription a;
  a.secure_version = get_u32le(d + 4);
  copy_string(a.version, d + 16, 32);
  copy_string(a.project_name, d + 48, 32);
  copy_string(a.time, d + 80, 16);
  copy_string(a.date, d + 96, 16);
  copy_string(a.idf_ver, d + 112, 32);
  return a;
}

}  // namespace saul::esp
