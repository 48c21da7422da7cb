// Espressif ROM bootloader codec: the byte-exact request examples of docs/protocols.md §7.7 (verified there
// against esptool's encoding), written out by hand, plus the answers and the image header.
#include <catch2/catch.hpp>

#include <array>
#include <cstring>
#include <vector>

#include "saulproto/core/esp_loader.hpp"

using namespace saul;
using namespace saul::esp;

namespace {

using Bytes = std::vector<std::uint8_t>;

// Builds the raw packet with f, then frames it: what goes on the wire.
template <class F>
Bytes wire(F&& f) {
  std::array<std::uint8_t, kMaxRequest> packet{};
  auto n = f(std::span<std::uint8_t>(packet));
  REQUIRE(n.ok());
  std::vector<std::uint8_t> frame(kMaxSlipFrame);
  auto m = slip_encode(std::span<const std::uint8_t>(packet.data(), *n), frame);
  REQUIRE(m.ok());
  frame.resize(*m);
  return frame;
}

Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

std::vector<Bytes> decode_all(SlipDecoder& d, const Bytes& in) {
  std::vector<Bytes> frames;
  for (std::uint8_t b : in)
    if (auto f = d.push(b)) frames.emplace_back(f->begin(), f->end());
  return frames;
}

}  // namespace

TEST_CASE("esp: the checksum is 0xEF xor the data bytes") {
  const Bytes data = {0xC0, 0xDB, 0x01, 0x02};
  CHECK(checksum(data) == 0xF7);
  CHECK(checksum(Bytes{}) == 0xEF);
  CHECK(checksum(Bytes{0xEF}) == 0x00);
}

TEST_CASE("esp: requests are byte-exact (protocols.md 7.7)") {
  Bytes sync = {0xC0, 0x00, 0x08, 0x24, 0x00, 0x00, 0x00, 0x00, 0x00, 0x07, 0x07, 0x12, 0x20};
  sync.insert(sync.end(), 32, 0x55);
  sync.push_back(0xC0);
  CHECK(sync.size() == 46);
  CHECK(wire([](auto out) { return build_sync(out); }) == sync);

  CHECK(wire([](auto out) { return build_read_reg(0x40001000, out); }) ==
        Bytes{0xC0, 0x00, 0x0A, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x10, 0x00, 0x40, 0xC0});

  CHECK(wire([](auto out) { return build_get_security_info(out); }) ==
        Bytes{0xC0, 0x00, 0x14, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xC0});

  CHECK(wire([](auto out) { return build_spi_attach(0, Loader::rom, out); }) ==
        Bytes{0xC0, 0x00, 0x0D, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
              0xC0});

  CHECK(wire([](auto out) { return build_change_baudrate(921600, 0, out); }) ==
        Bytes{0xC0, 0x00, 0x0F, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x10, 0x0E, 0x00, 0x00, 0x00, 0x00, 0x00,
              0xC0});

  CHECK(wire([](auto out) { return build_flash_begin(0x4000, 16, 0x400, 0x10000, Loader::rom, out); }) ==
        Bytes{0xC0, 0x00, 0x02, 0x14, 0x00, 0x00, 0x00, 0x00, 0x00,  //
              0x00, 0x40, 0x00, 0x00,                                // erase size 0x4000
              0x10, 0x00, 0x00, 0x00,                                // 16 blocks
              0x00, 0x04, 0x00, 0x00,                                // of 0x400
              0x00, 0x00, 0x01, 0x00,                                // at 0x10000
              0x00, 0x00, 0x00, 0x00,                                // not encrypted
              0xC0});

  const Bytes data = {0xC0, 0xDB, 0x01, 0x02};
  CHECK(wire([&](auto out) { return build_flash_data(0, data, out); }) ==
        Bytes{0xC0, 0x00, 0x03, 0x14, 0x00, 0xF7, 0x00, 0x00, 0x00,  // size 20, checksum 0xF7
              0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,        // 4 bytes, sequence 0
              0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,        // two zero words
              0xDB, 0xDC, 0xDB, 0xDD, 0x01, 0x02,                    // C0 DB escaped
              0xC0});

  CHECK(wire([](auto out) { return build_spi_flash_md5(0x10000, 0x100000, out); }) ==
        Bytes{0xC0, 0x00, 0x13, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00,  //
              0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x10, 0x00,        //
              0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xC0});
}

TEST_CASE("esp: the stub forms drop the ROM-only words") {
  CHECK(wire([](auto out) { return build_spi_attach(0, Loader::stub, out); }) ==
        Bytes{0xC0, 0x00, 0x0D, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xC0});
  CHECK(wire([](auto out) { return build_flash_defl_begin(1000, 1, 0x4000, 0, Loader::stub, out); }).size() ==
        2 + 8 + 16);
  CHECK(wire([](auto out) { return build_flash_defl_begin(1024, 1, 0x400, 0, Loader::rom, out); }).size() ==
        2 + 8 + 20);
}

TEST_CASE("esp: remaining builders lay out their words little-endian") {
  CHECK(wire([](auto out) { return build_spi_set_params(0x800000, out); }) ==
        Bytes{0xC0, 0x00, 0x0B, 0x18, 0x00, 0x00, 0x00, 0x00, 0x00,  //
              0x00, 0x00, 0x00, 0x00,                                // id 0
              0x00, 0x00, 0x80, 0x00,                                // 8 MiB
              0x00, 0x00, 0x01, 0x00,                                // block 64 KiB
              0x00, 0x10, 0x00, 0x00,                                // sector 4 KiB
              0x00, 0x01, 0x00, 0x00,                                // page 256
              0xFF, 0xFF, 0x00, 0x00,                                // status mask
              0xC0});
  CHECK(wire([](auto out) { return build_write_reg(0x600080B0, 0x50D83AA1, 0xFFFFFFFF, 0, out); }) ==
        Bytes{0xC0, 0x00, 0x09, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00,  //
              0xB0, 0x80, 0x00, 0x60, 0xA1, 0x3A, 0xD8, 0x50,        //
              0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0x00, 0x00, 0xC0});
  CHECK(wire([](auto out) { return build_flash_end(true, out); }) ==
        Bytes{0xC0, 0x00, 0x04, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0xC0});
  CHECK(wire([](auto out) { return build_flash_defl_end(false, out); }) ==
        Bytes{0xC0, 0x00, 0x12, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xC0});
  // FLASH_DEFL_DATA: same layout as FLASH_DATA, opcode 0x11.
  const Bytes z = {0x78, 0xDA};
  CHECK(wire([&](auto out) { return build_flash_defl_data(3, z, out); }) ==
        Bytes{0xC0, 0x00, 0x11, 0x12, 0x00, 0x4D, 0x00, 0x00, 0x00,  // size 18, checksum EF^78^DA = 4D
              0x02, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00,        //
              0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x78, 0xDA, 0xC0});
}

TEST_CASE("esp: ROM deflate sizes round up to whole blocks, the stub's do not") {
  CHECK(block_count(0, 0x400) == 0);
  CHECK(block_count(1, 0x400) == 1);
  CHECK(block_count(0x400, 0x400) == 1);
  CHECK(block_count(0x401, 0x400) == 2);
  CHECK(defl_begin_size(1000, Loader::rom) == 1024);
  CHECK(defl_begin_size(1000, Loader::stub) == 1000);
}

TEST_CASE("esp: builders refuse a short buffer") {
  std::array<std::uint8_t, 10> small{};
  CHECK(build_sync(small).reason() == Reason::buffer_too_small);
  CHECK(build_flash_begin(0, 0, 0, 0, Loader::rom, small).reason() == Reason::buffer_too_small);
  std::array<std::uint8_t, 3> tiny{};  // C0 DB DC C0 needs 4
  CHECK(slip_encode(Bytes{0xC0}, tiny).reason() == Reason::buffer_too_small);
  CHECK(slip_encoded_size(Bytes{0xC0, 0xDB, 0x01}) == 7);
}

TEST_CASE("esp: an S3 ROM security-info answer parses with its chip id (protocols.md 7.7)") {
  const Bytes reply = {0xC0, 0x01, 0x14, 0x18, 0x00, 0x00, 0x00, 0x00, 0x00,  // 24 bytes of data
                       0x00, 0x00, 0x00, 0x00,                                // flags
                       0x00,                                                  // flash_crypt_cnt
                       0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,              // key purposes
                       0x09, 0x00, 0x00, 0x00,                                // chip id 9
                       0x00, 0x00, 0x00, 0x00,                                // api version
                       0x00, 0x00, 0x00, 0x00,                                // ROM status: ok
                       0xC0};
  std::array<std::uint8_t, kMaxResponse> storage{};
  SlipDecoder d(storage);
  auto frames = decode_all(d, reply);
  REQUIRE(frames.size() == 1);
  auto r = parse_response(frames[0], Loader::rom);
  REQUIRE(r.ok());
  CHECK(r->op == 0x14);
  CHECK(r->ok());
  CHECK(r->data.size() == 20);
  auto info = parse_security_info(r->data);
  REQUIRE(info.ok());
  CHECK(info->has_chip_id);
  CHECK(info->chip_id == kChipIdEsp32s3);
  CHECK(std::strcmp(chip_name(info->chip_id), "ESP32-S3") == 0);
  CHECK(info->flags == 0);
  // The ESP32-S2 ROM answers 12 bytes: no chip id.
  auto s2 = parse_security_info(std::span<const std::uint8_t>(r->data.data(), 12));
  REQUIRE(s2.ok());
  CHECK_FALSE(s2->has_chip_id);
  CHECK(parse_security_info(std::span<const std::uint8_t>(r->data.data(), 11)).reason() == Reason::truncated);
}

TEST_CASE("esp: ROM answers end in 4 status bytes, the stub's in 2") {
  // READ_REG answer from the ROM: value in the header, data = 4 status bytes only.
  const Bytes rom = {0x01, 0x0A, 0x04, 0x00, 0x09, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
  auto r = parse_response(rom, Loader::rom);
  REQUIRE(r.ok());
  CHECK(r->value == 9);
  CHECK(r->data.empty());
  CHECK(r->ok());
  // The same bytes read as a stub answer leave two bytes of data.
  auto s = parse_response(rom, Loader::stub);
  REQUIRE(s.ok());
  CHECK(s->data.size() == 2);
  // A failure: status 1, error 0x07 (checksum).
  const Bytes fail = {0x01, 0x03, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x07, 0x00, 0x00};
  auto f = parse_response(fail, Loader::rom);
  REQUIRE(f.ok());
  CHECK_FALSE(f->ok());
  CHECK(f->error == 0x07);
  CHECK(std::string(error_text(f->error)) == "invalid checksum in message");
  // Shape errors.
  CHECK(parse_response(Bytes{0x01, 0x0A, 0x04}, Loader::rom).reason() == Reason::truncated);
  CHECK(parse_response(Bytes{0x00, 0x0A, 0x00, 0x00, 0, 0, 0, 0}, Loader::rom).reason() == Reason::unknown_type);
  CHECK(parse_response(Bytes{0x01, 0x0A, 0x02, 0x00, 0, 0, 0, 0, 0, 0}, Loader::rom).reason() == Reason::bad_length);
  CHECK(parse_response(Bytes{0x01, 0x0A, 0x04, 0x00, 0, 0, 0, 0, 0, 0}, Loader::rom).reason() == Reason::truncated);
  Bytes extra = rom;
  extra.push_back(0);
  CHECK(parse_response(extra, Loader::rom).reason() == Reason::bad_length);
}

TEST_CASE("esp: encode_response and parse_request are the chip side of the same layout") {
  std::array<std::uint8_t, 64> buf{};
  const Bytes md5 = {'d', '4', '1', 'd'};
  auto n = encode_response(0x13, 0, md5, 0, 0, Loader::rom, buf);
  REQUIRE(n.ok());
  CHECK(*n == 8 + 4 + 4);
  CHECK(Bytes(buf.begin(), buf.begin() + 8) == Bytes{0x01, 0x13, 0x08, 0x00, 0, 0, 0, 0});
  auto stub = encode_response(0x13, 0, md5, 1, 0xC1, Loader::stub, buf);
  REQUIRE(stub.ok());
  CHECK(*stub == 8 + 4 + 2);
  CHECK(buf[12] == 1);
  CHECK(buf[13] == 0xC1);

  std::array<std::uint8_t, kMaxRequest> packet{};
  const Bytes data = {1, 2, 3, 4, 5};
  auto p = build_flash_data(7, data, packet);
  REQUIRE(p.ok());
  auto req = parse_request(std::span<const std::uint8_t>(packet.data(), *p));
  REQUIRE(req.ok());
  CHECK(req->op == 0x03);
  CHECK(req->checksum == checksum(data));
  CHECK(req->data.size() == 16 + 5);
  CHECK(req->data[4] == 7);  // sequence
  CHECK(parse_request(std::span<const std::uint8_t>(packet.data(), *p - 1)).reason() == Reason::truncated);
  packet[0] = 0x01;
  CHECK(parse_request(std::span<const std::uint8_t>(packet.data(), *p)).reason() == Reason::unknown_type);
}

TEST_CASE("esp: the SLIP decoder streams frames out of noise, back to back, one byte at a time") {
  std::array<std::uint8_t, 16> storage{};
  SlipDecoder d(storage);
  // Boot text, then the stub hello, then a frame whose payload holds both escaped bytes, back to back.
  const Bytes in = cat({Bytes{'r', 's', 't', ':', '\r', '\n'}, Bytes{0xC0, 0x4F, 0x48, 0x41, 0x49, 0xC0},
                        Bytes{0xC0, 0x01, 0xDB, 0xDC, 0xDB, 0xDD, 0x02, 0xC0}});
  auto frames = decode_all(d, in);
  REQUIRE(frames.size() == 2);
  CHECK(frames[0] == Bytes{'O', 'H', 'A', 'I'});
  CHECK(frames[1] == Bytes{0x01, 0xC0, 0xDB, 0x02});
  CHECK(d.counters().frames == 2);
  CHECK(d.counters().noise_bytes == 6);
}

TEST_CASE("esp: the SLIP decoder drops bad escapes and overlong frames and recovers") {
  std::array<std::uint8_t, 4> storage{};
  SlipDecoder d(storage);
  const Bytes in = cat({Bytes{0xC0, 0x01, 0xDB, 0x01, 0x02, 0xC0},    // DB 01: bad escape
                        Bytes{0xC0, 1, 2, 3, 4, 5, 0xC0},             // 5 bytes > storage
                        Bytes{0xC0, 0xC0, 0xC0, 0x0A, 0x0B, 0xC0}});  // repeated C0 then a good frame
  auto frames = decode_all(d, in);
  REQUIRE(frames.size() == 1);
  CHECK(frames[0] == Bytes{0x0A, 0x0B});
  CHECK(d.counters().bad_escapes == 1);
  CHECK(d.counters().overlong_frames == 1);
  // reset() forgets a partial frame.
  CHECK_FALSE(d.push(0xC0));
  CHECK_FALSE(d.push(0x33));
  CHECK(d.in_frame());
  d.reset();
  CHECK_FALSE(d.in_frame());
  CHECK_FALSE(d.push(0xC0));
  CHECK_FALSE(d.push(0x44));
  auto f = d.push(0xC0);
  REQUIRE(f);
  CHECK(Bytes(f->begin(), f->end()) == Bytes{0x44});
}

TEST_CASE("esp: SLIP round trip of every byte value") {
  Bytes packet(256);
  for (int i = 0; i < 256; ++i) packet[i] = static_cast<std::uint8_t>(i);
  Bytes frame(slip_encoded_size(packet));
  CHECK(frame.size() == 256 + 2 + 2);
  REQUIRE(slip_encode(packet, frame).ok());
  std::array<std::uint8_t, 300> storage{};
  SlipDecoder d(storage);
  auto frames = decode_all(d, frame);
  REQUIRE(frames.size() == 1);
  CHECK(frames[0] == packet);
}

TEST_CASE("esp: MD5 answers come as 32 hex characters (ROM) or 16 raw bytes (stub)") {
  // MD5 of nothing: d41d8cd98f00b204e9800998ecf8427e.
  const char* hex = "d41d8cd98f00b204e9800998ecf8427e";
  const Md5 expect = {0xd4, 0x1d, 0x8c, 0xd9, 0x8f, 0x00, 0xb2, 0x04, 0xe9, 0x80, 0x09, 0x98, 0xec, 0xf8, 0x42, 0x7e};
  auto rom = parse_md5(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(hex), 32));
  REQUIRE(rom.ok());
  CHECK(*rom == expect);
  auto stub = parse_md5(expect);
  REQUIRE(stub.ok());
  CHECK(*stub == expect);
  CHECK(parse_md5(Bytes(31, '0')).reason() == Reason::bad_length);
  CHECK(parse_md5(Bytes(32, 'x')).reason() == Reason::syntax);
}

TEST_CASE("esp: chips are named from their id or their magic value") {
  CHECK(std::string(chip_name(5)) == "ESP32-C3");
  CHECK(std::string(chip_name(0)) == "ESP32");
  CHECK(chip_name(99) == nullptr);
  CHECK(std::string(chip_name_from_magic(0x9)) == "ESP32-S3");
  CHECK(std::string(chip_name_from_magic(0x00F01D83)) == "ESP32");
  CHECK(std::string(chip_name_from_magic(0x1B31506F)) == "ESP32-C3");
  CHECK(chip_name_from_magic(0x12345678) == nullptr);
  CHECK(std::string(to_string(Op::spi_flash_md5)) == "SPI_FLASH_MD5");
}

TEST_CASE("esp: image header and app description") {
  Bytes image(0x20 + 256 + 16, 0);
  // Common header: magic, 3 segments, DIO, 8 MB / 80 MHz (0x3F), entry 0x40375A88.
  const Bytes header = {0xE9, 0x03, 0x02, 0x3F, 0x88, 0x5A, 0x37, 0x40,
                        0xEE, 0x00, 0x00, 0x00, 0x09, 0x00, 0x00, 0x00,   // wp pin, drives, chip id 9, min rev 0
                        0x00, 0x63, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01};  // max rev full 99, hash appended
  std::copy(header.begin(), header.end(), image.begin());
  // First segment header (load address, length), then esp_app_desc_t.
  const Bytes desc_magic = {0x32, 0x54, 0xCD, 0xAB};
  std::copy(desc_magic.begin(), desc_magic.end(), image.begin() + 0x20);
  image[0x20 + 4] = 2;  // secure version
  const char version[] = "v1.4.2-3-gabcdef";
  std::memcpy(&image[0x30], version, sizeof version - 1);
  const char project[] = "saul_balance";
  std::memcpy(&image[0x50], project, sizeof project - 1);
  std::memset(&image[0x90], 'X', 32);  // an idf_ver that fills its field with no NUL

  auto h = parse_image_header(image);
  REQUIRE(h.ok());
  CHECK(h->segment_count == 3);
  CHECK(h->flash_mode == 2);
  CHECK(h->flash_size_code == 3);
  CHECK(flash_size_from_code(h->flash_size_code) == 8U * 1024 * 1024);
  CHECK(h->flash_freq_code == 0xF);
  CHECK(h->entry == 0x40375A88);
  CHECK(h->wp_pin == 0xEE);
  CHECK(h->chip_id == 9);
  CHECK(h->max_chip_rev_full == 99);
  CHECK(h->hash_appended);

  auto a = parse_app_description(image);
  REQUIRE(a.ok());
  CHECK(std::string(a->version) == "v1.4.2-3-gabcdef");
  CHECK(std::string(a->project_name) == "saul_balance");
  CHECK(a->secure_version == 2);
  CHECK(std::string(a->idf_ver) == std::string(32, 'X'));

  // A bootloader image has no descriptor; a partition table is no image at all.
  image[0x20] = 0;
  CHECK(parse_app_description(image).reason() == Reason::unknown_type);
  CHECK(parse_image_header(Bytes{0xAA, 0x50, 0x01, 0x02}).reason() == Reason::unknown_type);
  CHECK(parse_image_header(Bytes{0xE9, 0x01}).reason() == Reason::truncated);
  image[1] = 17;
  CHECK(parse_image_header(image).reason() == Reason::out_of_range);
  CHECK(flash_size_from_code(0) == 0x100000);
  CHECK(flash_size_from_code(7) == 128U * 1024 * 1024);
  CHECK(flash_size_from_code(8) == 0);
}
