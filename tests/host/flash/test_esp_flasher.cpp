// The ESP32-S3 flasher's host side: reset sequences through a recording SerialPort (pseudo-terminals have no modem
// lines), MD5 against RFC 1321's test suite, inputs and plan checks, re-enumeration, and a full flash against the
// ROM emulator (tests/cli/esp_rom_emulator.py) on a pseudo-terminal.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include "saulproto/host/flash/esp_flasher.hpp"

using namespace saul;
using namespace saul::host;
using namespace std::chrono;
namespace fs = std::filesystem;

namespace {

// A SerialPort that records modem-line changes on a fake clock advanced by the fake sleeper; reads and writes go
// to an inner port when there is one, else nothing ever arrives.
class RecordingPort final : public SerialPort {
 public:
  struct Change {
    bool dtr, rts;
    milliseconds at;
  };
  explicit RecordingPort(std::unique_ptr<SerialPort> inner = nullptr) : inner_(std::move(inner)) {}
  std::size_t read(std::span<std::uint8_t> buf, milliseconds timeout) override {
    if (inner_) return inner_->read(buf, timeout);
    std::this_thread::sleep_for(timeout);  // "nothing within the timeout", as a silent port behaves
    return 0;
  }
  void write(std::span<const std::uint8_t> data, milliseconds timeout) override {
    written += data.size();
    if (inner_) inner_->write(data, timeout);
  }
  void set_modem_lines(bool dtr, bool rts) override { changes.push_back({dtr, rts, now}); }
  void set_baud(std::uint32_t baud) override {
    if (inner_) inner_->set_baud(baud);
    settings_.baud = baud;
  }
  [[nodiscard]] const std::string& path() const override { return inner_ ? inner_->path() : path_; }
  [[nodiscard]] const SerialSettings& settings() const override { return settings_; }
  [[nodiscard]] const char* backend() const override { return "recording"; }

  Sleeper sleeper() {
    return [this](milliseconds d) { now += d; };
  }
  std::vector<Change> changes;
  std::size_t written = 0;
  milliseconds now{0};

 private:
  std::unique_ptr<SerialPort> inner_;
  std::string path_ = "/dev/recording";
  SerialSettings settings_{};
};

// The recorded changes as steps: each held until the next change (the last one until the clock's end).
std::vector<LineStep> replayed(const RecordingPort& port, std::size_t from, std::size_t n) {
  const auto& changes = port.changes;
  std::vector<LineStep> steps;
  for (std::size_t i = from; i < from + n && i < changes.size(); ++i) {
    const auto hold = (i + 1 < changes.size() ? changes[i + 1].at : port.now) - changes[i].at;
    steps.push_back({changes[i].dtr, changes[i].rts, hold});
  }
  return steps;
}

std::vector<std::uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }

// An ESP32-S3 app image: header with chip id, first segment holding esp_app_desc_t, then code-like bytes.
std::vector<std::uint8_t> app_image(std::size_t size, std::uint16_t chip = 9, std::uint32_t seed = 1) {
  std::vector<std::uint8_t> img(size, 0);
  const std::uint8_t header[24] = {0xE9,
                                   1,
                                   2,
                                   0x2F,
                                   0x88,
                                   0x5A,
                                   0x37,
                                   0x40,
                                   0xEE,
                                   0,
                                   0,
                                   0,
                                   static_cast<std::uint8_t>(chip),
                                   static_cast<std::uint8_t>(chip >> 8)};
  std::memcpy(img.data(), header, sizeof header);
  const std::uint8_t magic[4] = {0x32, 0x54, 0xCD, 0xAB};
  if (size > 0x20 + 256) {
    std::memcpy(&img[0x20], magic, 4);
    std::memcpy(&img[0x30], "v9.9.9", 6);
    std::memcpy(&img[0x50], "saul_io", 7);
  }
  std::uint32_t x = seed;
  for (std::size_t i = 0x20 + 256; i + 4 <= size; i += 4) {
    x = x * 1103515245U + 12345U;
    const std::uint32_t w = (x & 3U) ? 0x40370000U + (x >> 20) : x;
    std::memcpy(&img[i], &w, 4);
  }
  return img;
}

fs::path temp_dir() {
  char tmpl[] = "/tmp/saul_flash_XXXXXX";
  REQUIRE(::mkdtemp(tmpl) != nullptr);
  return tmpl;
}

void write_file(const fs::path& p, const std::vector<std::uint8_t>& data) {
  std::ofstream out(p, std::ios::binary);
  out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
}

std::vector<std::uint8_t> read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The ROM emulator as a child process: its stdout gives the pty path, its stdin ends it.
class Emulator {
 public:
  explicit Emulator(const std::vector<std::string>& args) {
    int in[2], out[2];
    REQUIRE(::pipe(in) == 0);
    REQUIRE(::pipe(out) == 0);
    pid_ = ::fork();
    REQUIRE(pid_ >= 0);
    if (pid_ == 0) {
      ::dup2(in[0], 0);
      ::dup2(out[1], 1);
      ::close(in[1]);
      ::close(out[0]);
      std::vector<std::string> all = {"python3", std::string(SAUL_SOURCE_DIR) + "/tests/cli/esp_rom_emulator.py"};
      all.insert(all.end(), args.begin(), args.end());
      std::vector<char*> argv;
      for (auto& a : all) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execvp("python3", argv.data());
      ::_exit(127);
    }
    ::close(in[0]);
    ::close(out[1]);
    control_ = in[1];
    char c;
    while (::read(out[0], &c, 1) == 1 && c != '\n') path_ += c;  // driven by what the emulator says
    ::close(out[0]);
    REQUIRE(path_.rfind("/dev/", 0) == 0);
  }
  ~Emulator() { stop(); }
  void stop() {
    if (pid_ <= 0) return;
    if (::write(control_, "quit\n", 5) < 0) {
    }  // it may have ended by itself (a reset)
    ::close(control_);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  pid_t pid_ = -1;
  int control_ = -1;
  std::string path_;
};

}  // namespace

TEST_CASE("flash: the bridge's reset into the bootloader is esptool's classic DTR/RTS sequence") {
  RecordingPort port;
  const auto seq = bootloader_reset_sequence(ResetStyle::usb_uart_bridge, 0);
  run_line_sequence(port, seq, port.sleeper());
  // (DTR,RTS) = (0,1): GPIO0 high, EN low (in reset) for 100 ms; (1,0): GPIO0 low, EN released, 50 ms; (0,0).
  const std::vector<LineStep> expect = {
      {false, true, milliseconds(100)}, {true, false, milliseconds(50)}, {false, false, milliseconds(0)}};
  CHECK(replayed(port, 0, 3) == expect);
  CHECK(port.now == milliseconds(150));
  // The second variant holds GPIO0 low longer, for a slow EN capacitor.
  CHECK(bootloader_reset_sequence(ResetStyle::usb_uart_bridge, 1)[1].hold == milliseconds(550));
  // Out of the bootloader: an EN pulse with GPIO0 released.
  RecordingPort out;
  run_line_sequence(out, hard_reset_sequence(ResetStyle::usb_uart_bridge), out.sleeper());
  CHECK(replayed(out, 0, 2) ==
        std::vector<LineStep>{{false, true, milliseconds(100)}, {false, false, milliseconds(0)}});
}

TEST_CASE("flash: the USB-Serial/JTAG reset goes through (1,1), never (0,0), into reset") {
  RecordingPort port;
  run_line_sequence(port, bootloader_reset_sequence(ResetStyle::usb_serial_jtag), port.sleeper());
  const std::vector<LineStep> expect = {{false, false, milliseconds(100)},  // idle
                                        {true, false, milliseconds(100)},   // boot pin low
                                        {true, true, milliseconds(0)},      // through (1,1)
                                        {false, true, milliseconds(100)},   // reset
                                        {false, false, milliseconds(0)}};   // out of reset
  CHECK(replayed(port, 0, 5) == expect);
  RecordingPort out;
  run_line_sequence(out, hard_reset_sequence(ResetStyle::usb_serial_jtag), out.sleeper());
  CHECK(replayed(out, 0, 2) ==
        std::vector<LineStep>{{false, true, milliseconds(200)}, {false, false, milliseconds(200)}});
}

TEST_CASE("flash: connect() resets once per attempt, alternating variants, then says how to do it by hand") {
  RecordingPort port;
  FlasherOptions o;
  o.reset = ResetStyle::usb_uart_bridge;
  o.connect_attempts = 2;
  o.sync_timeout = milliseconds(2);
  o.sleep = port.sleeper();
  EspFlasher flasher(port, o);
  try {
    flasher.connect();
    FAIL("connect() should have failed");
  } catch (const FlashError& e) {
    CHECK(e.kind() == FlashError::Kind::no_answer);
    CHECK_THAT(e.what(), Catch::Contains("no serial data received"));
    CHECK_THAT(e.what(), Catch::Contains("Hold BOOT on the BALANCE board and tap RESET"));
  }
  REQUIRE(port.changes.size() == 6);
  CHECK(replayed(port, 0, 2) ==
        std::vector<LineStep>{{false, true, milliseconds(100)}, {true, false, milliseconds(50)}});
  CHECK(replayed(port, 3, 2) ==
        std::vector<LineStep>{{false, true, milliseconds(100)}, {true, false, milliseconds(550)}});
  CHECK(port.written == 2 * 5 * 46);  // five SYNC frames per attempt

  RecordingPort manual;
  o.reset_before = false;
  o.connect_attempts = 1;
  o.sleep = manual.sleeper();
  EspFlasher by_hand(manual, o);
  CHECK_THROWS_AS(by_hand.connect(), FlashError);
  CHECK(manual.changes.empty());  // --no-reset leaves the lines alone
}

TEST_CASE("flash: MD5 passes RFC 1321's test suite") {
  const std::pair<const char*, const char*> suite[] = {
      {"", "d41d8cd98f00b204e9800998ecf8427e"},
      {"a", "0cc175b9c0f1b6a831c399e269772661"},
      {"abc", "900150983cd24fb0d6963f7d28e17f72"},
      {"message digest", "f96b697d7cb7938d525a2f31aaf161d0"},
      {"abcdefghijklmnopqrstuvwxyz", "c3fcd3d76192e4007dfb496cca67e13b"},
      {"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789", "d174ab98d277d9f5a5611c2c9f419d9f"},
      {"12345678901234567890123456789012345678901234567890123456789012345678901234567890",
       "57edf4a22be3c955ac49da2e2107b67a"},
  };
  for (const auto& [text, hex] : suite) CHECK(to_hex(md5_of(bytes_of(text))) == hex);
}

TEST_CASE("flash: images are padded to 4 bytes and deflate to a zlib stream that inflates back") {
  const std::vector<std::uint8_t> odd = {1, 2, 3, 4, 5};
  CHECK(padded_for_flash(odd) == std::vector<std::uint8_t>{1, 2, 3, 4, 5, 0xFF, 0xFF, 0xFF});
  const auto img = app_image(50000);
  const auto z = deflate(img);
  CHECK(z.size() < img.size());
  std::vector<std::uint8_t> back(img.size());
  uLongf n = back.size();
  REQUIRE(uncompress(back.data(), &n, z.data(), static_cast<uLong>(z.size())) == Z_OK);
  CHECK(back == img);
}

TEST_CASE("flash: offsets, sizes, files and build folders") {
  CHECK(parse_offset("0x10000") == 0x10000U);
  CHECK(parse_offset("65536") == 65536U);
  CHECK_FALSE(parse_offset("ten"));
  CHECK_FALSE(parse_offset("-1"));
  CHECK_FALSE(parse_offset("0x1FFFFFFFF"));
  CHECK(parse_flash_size("4MB") == 4U * 1024 * 1024);
  CHECK(parse_flash_size("16mb") == 16U * 1024 * 1024);
  CHECK(parse_flash_size("512KB") == 512U * 1024);
  CHECK(parse_flash_size("detect") == 0);
  CHECK(parse_flash_size("keep") == 0);

  const auto dir = temp_dir();
  try {
    (void)load_image(0, dir / "nope.bin");
    FAIL("missing file accepted");
  } catch (const FlashError& e) {
    CHECK(e.kind() == FlashError::Kind::input);
    CHECK_THAT(e.what(), Catch::Contains("nope.bin: no such file"));
  }
  write_file(dir / "empty.bin", {});
  CHECK_THROWS_WITH(load_image(0, dir / "empty.bin"), Catch::Contains("empty"));

  fs::create_directories(dir / "build" / "bootloader");
  write_file(dir / "build" / "bootloader" / "bootloader.bin", app_image(4096));
  write_file(dir / "build" / "saul_io.bin", app_image(9000));
  {
    std::ofstream j(dir / "build" / "flasher_args.json");
    j << R"({"flash_settings": {"flash_mode": "dio", "flash_size": "8MB", "flash_freq": "80m"},
             "flash_files": {"0x10000": "saul_io.bin", "0x0": "bootloader/bootloader.bin"},
             "extra_esptool_args": {"after": "hard_reset", "before": "default_reset", "stub": true, "chip": "esp32s3"}})";
  }
  auto plan = load_build_dir(dir / "build");
  CHECK(plan.images.size() == 2);
  CHECK(plan.flash_size == 8U * 1024 * 1024);
  CHECK(plan.flash_size_source == "flasher_args.json");
  check_plan(plan);
  CHECK(plan.images[0].offset == 0);
  CHECK(plan.images[0].name == "bootloader/bootloader.bin");
  CHECK(plan.images[1].offset == 0x10000);
  // The JSON file itself works too.
  CHECK(load_build_dir(dir / "build" / "flasher_args.json").images.size() == 2);
  CHECK_THROWS_WITH(load_build_dir(dir), Catch::Contains("no flasher_args.json"));
  // A build for another chip.
  {
    std::ofstream j(dir / "flasher_args.json");
    j << R"({"flash_files": {"0x10000": "build/saul_io.bin"}, "extra_esptool_args": {"chip": "esp32c3"}})";
  }
  try {
    (void)load_build_dir(dir);
    FAIL("a build for the ESP32-C3 accepted");
  } catch (const FlashError& e) {
    CHECK(e.kind() == FlashError::Kind::wrong_chip);
  }
  fs::remove_all(dir);
}

TEST_CASE("flash: the plan is checked before the board is touched") {
  auto plan_of = [](std::vector<FlashImage> images) {
    FlashPlan p;
    p.images = std::move(images);
    return p;
  };
  auto kind_of = [](FlashPlan p) {
    try {
      check_plan(p);
    } catch (const FlashError& e) {
      return e.kind();
    }
    return FlashError::Kind::protocol;  // "no error"
  };
  CHECK(kind_of(plan_of({{0x10800, app_image(100), "a.bin"}})) == FlashError::Kind::input);  // off a sector
  CHECK(kind_of(plan_of({{0x10000, app_image(0x2000), "a.bin"}, {0x11000, app_image(100), "b.bin"}})) ==
        FlashError::Kind::input);  // overlap
  CHECK(kind_of(plan_of({{0x10000, app_image(1000, 5), "c3.bin"}})) == FlashError::Kind::wrong_chip);
  CHECK(kind_of(plan_of({})) == FlashError::Kind::input);

  // No size known: 4 MB assumed, and an image past it refused.
  auto big = plan_of({{0x3F0000, app_image(0x20000), "big.bin"}});
  try {
    check_plan(big);
    FAIL("too large accepted");
  } catch (const FlashError& e) {
    CHECK(e.kind() == FlashError::Kind::too_large);
    CHECK_THAT(e.what(), Catch::Contains("beyond the 4 MB flash (assumed"));
  }
  // A bootloader at 0x0 says 16 MB (code 4) in its header.
  auto boot = app_image(4096);
  boot[3] = 0x4F;
  auto sized = plan_of({{0x0, boot, "bootloader.bin"}, {0x3F0000, app_image(0x20000), "big.bin"}});
  check_plan(sized);
  CHECK(sized.flash_size == 16U * 1024 * 1024);
  CHECK(sized.flash_size_source == "the bootloader's image header");
}

TEST_CASE("flash: what the ROM cannot boot is refused unless forced; a header that disagrees with the build warns") {
  auto one = [](std::uint32_t offset, std::vector<std::uint8_t> data, const char* name) {
    FlashPlan p;
    p.images.push_back({offset, std::move(data), name});
    return p;
  };
  // ELF magic (7F 'E' 'L' 'F'), as the linker writes build/<project>.elf.
  std::vector<std::uint8_t> elf = {0x7F, 'E', 'L', 'F', 1, 1, 1, 0};
  elf.resize(4096);
  auto plan = one(0x10000, elf, "build/app.elf");
  try {
    check_plan(plan);
    FAIL("an ELF accepted");
  } catch (const FlashError& e) {
    CHECK(e.kind() == FlashError::Kind::input);
    CHECK_THAT(e.what(), Catch::StartsWith("build/app.elf: this is an ELF file") &&
                             Catch::EndsWith("(--force writes it anyway)"));
  }
  plan = one(0x10000, elf, "build/app.elf");
  check_plan(plan, true);
  REQUIRE(plan.warnings.size() == 1);
  CHECK_THAT(plan.warnings[0], Catch::EndsWith("written anyway (--force)"));

  // A partition table (magic AA 50) is fine at 0x8000, not at 0x0 where the ROM looks for the bootloader.
  std::vector<std::uint8_t> table = {0xAA, 0x50, 0x01, 0x02};
  table.resize(3072, 0xFF);
  plan = one(0x8000, table, "pt.bin");
  check_plan(plan);
  CHECK(plan.warnings.empty());
  plan = one(0x0, table, "pt.bin");
  CHECK_THROWS_WITH(check_plan(plan), Catch::Contains("pt.bin at 0x0: not an ESP image (first byte 0xAA, an image "
                                                      "starts with 0xE9)"));

  // app_image's header: byte 2 = 2 (dio), byte 3 = 0x2F (size code 2 = 4 MB, frequency code 0xF = 80m).
  auto with_settings = [&](const char* mode, const char* size, const char* freq) {
    auto p = one(0x0, app_image(4096), "bootloader.bin");
    p.settings_mode = mode;
    p.settings_size = size;
    p.settings_freq = freq;
    check_plan(p);
    return p.warnings;
  };
  CHECK(with_settings("dio", "4MB", "80m").empty());
  CHECK(with_settings("keep", "detect", "keep").empty());  // nothing to compare
  auto w = with_settings("qio", "4MB", "80m");
  REQUIRE(w.size() == 1);
  CHECK_THAT(w[0], Catch::StartsWith("bootloader.bin: its header says flash mode dio (flasher_args.json: qio); "));
  w = with_settings("DIO", "16MB", "40m");
  REQUIRE(w.size() == 1);
  CHECK_THAT(w[0], Catch::Contains("says flash size 4 MB (flasher_args.json: 16MB), flash frequency 80m "
                                   "(flasher_args.json: 40m); "));
  // The refusal texts end with what to do.
  CHECK_THAT(refusal_text(0x08), Catch::StartsWith("flash write error") && Catch::EndsWith("faulty"));
  CHECK_THAT(refusal_text(0x07), Catch::Contains("(error 0x07): a noisy line: run again with a lower --baud"));
  CHECK_THAT(refusal_text(0x0B), Catch::EndsWith("run again with --no-compress"));
}

TEST_CASE("flash: after a USB-Serial/JTAG reset the IO board is found again by its serial number") {
  PortInfo before{"/dev/ttyACM0",      "",     "Espressif", "USB JTAG/serial debug unit",
                  "48:27:E2:C9:0A:88", 0x303A, 0x1001,      ""};
  PortInfo other{"/dev/ttyACM2",      "",     "Espressif", "USB JTAG/serial debug unit",
                 "11:22:33:44:55:66", 0x303A, 0x1001,      ""};
  PortInfo after = before;
  after.path = "/dev/ttyACM1";
  int call = 0;
  auto list = [&]() -> std::vector<PortInfo> {
    ++call;
    if (call == 1) return {before, other};  // not gone yet
    if (call <= 3) return {other};          // off the bus
    return {other, after};                  // back, renamed
  };
  milliseconds slept{0};
  auto sleep = [&](milliseconds d) { slept += d; };
  CHECK(wait_for_usb_port(before.serial_number, 0x303A, before.path, seconds(10), sleep, list) == "/dev/ttyACM1");
  CHECK(slept == milliseconds(300));
  // Never back: gives up after the timeout.
  auto gone = [&]() -> std::vector<PortInfo> { return {other}; };
  slept = milliseconds(0);
  CHECK(wait_for_usb_port(before.serial_number, 0x303A, before.path, seconds(2), sleep, gone).empty());
  CHECK(slept >= seconds(2));
  CHECK(is_board_port(before, ResetStyle::usb_serial_jtag));
  CHECK_FALSE(is_board_port(before, ResetStyle::usb_uart_bridge));
  PortInfo ch343{"/dev/ttyACM3", "", "WCH", "USB Single Serial", "5A8B", 0x1A86, 0x55D3, ""};
  CHECK(is_board_port(ch343, ResetStyle::usb_uart_bridge));
}

TEST_CASE("flash: a full flash against the ROM emulator lands byte for byte, then skips by MD5") {
  const auto dir = temp_dir();
  const fs::path flash_file = dir / "flash.bin";
  const auto image = app_image(70001);  // odd size: padded to 70004
  FlashImage img{0x10000, image, "saul_io.bin"};
  {
    Emulator emu({"--flash-file", flash_file.string()});
    RecordingPort port(open_serial(emu.path(), SerialSettings{}));
    FlasherOptions o;
    o.sleep = port.sleeper();
    EspFlasher flasher(port, o);
    const auto& chip = flasher.connect();
    CHECK(chip.name == "ESP32-S3");
    CHECK(chip.detected_by == "GET_SECURITY_INFO");
    CHECK(chip.loader == esp::Loader::rom);
    CHECK_FALSE(chip.usb_serial_jtag);
    flasher.attach_flash(4U * 1024 * 1024);
    flasher.change_baud(921600);
    CHECK(port.settings().baud == 921600);
    const auto r = flasher.write(img);
    CHECK(r.state == RegionOutcome::State::written);
    CHECK(r.compressed);
    CHECK(r.size == 70004);
    CHECK(r.md5 == to_hex(md5_of(padded_for_flash(image))));
    CHECK(to_hex(flasher.flash_md5(0x10000, 70004)) == r.md5);
    flasher.reset_to_app();
    // The lines moved exactly twice: into the bootloader, and the EN pulse out of it.
    CHECK(replayed(port, 0, 5) == std::vector<LineStep>{{false, true, milliseconds(100)},
                                                        {true, false, milliseconds(50)},
                                                        {false, false, milliseconds(0)},
                                                        {false, true, milliseconds(100)},
                                                        {false, false, milliseconds(0)}});
  }
  const auto flash = read_file(flash_file);
  REQUIRE(flash.size() == 4U * 1024 * 1024);
  CHECK(std::equal(image.begin(), image.end(), flash.begin() + 0x10000));
  CHECK(flash[0x10000 + 70001] == 0xFF);  // the padding is erased-flash bytes
  {
    Emulator emu({"--flash-file", flash_file.string()});
    auto port = open_serial(emu.path(), SerialSettings{});
    FlasherOptions o;
    o.sleep = [](milliseconds) {};
    EspFlasher flasher(*port, o);
    flasher.connect();
    flasher.attach_flash(4U * 1024 * 1024);
    CHECK(flasher.write(img).state == RegionOutcome::State::unchanged);
  }
  fs::remove_all(dir);
}

TEST_CASE("flash: the IO board's watchdogs are tamed and its reset is a watchdog reset") {
  const auto dir = temp_dir();
  const fs::path report = dir / "report.json";
  {
    Emulator emu({"--usb-serial-jtag", "--report", report.string()});
    RecordingPort port(open_serial(emu.path(), SerialSettings{}));
    FlasherOptions o;
    o.reset = ResetStyle::usb_serial_jtag;
    o.sleep = port.sleeper();
    EspFlasher flasher(port, o);
    CHECK(flasher.connect().usb_serial_jtag);
    flasher.attach_flash(4U * 1024 * 1024);
    CHECK(flasher.write(FlashImage{0x10000, app_image(5000), "io.bin"}).state == RegionOutcome::State::written);
    flasher.reset_to_app();
    CHECK(port.changes.size() == 5);  // the USB-Serial/JTAG sequence in, no RTS pulse out
  }
  std::ifstream in(report);
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  CHECK_THAT(text, Catch::Contains("\"wdt_disabled\": true"));
  CHECK_THAT(text, Catch::Contains("\"kind\": \"rtc_watchdog\""));
  CHECK_THAT(text, Catch::Contains("\"forced_download_cleared\": true"));
  fs::remove_all(dir);
}
